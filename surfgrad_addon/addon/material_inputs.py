"""What a Cycles bake reads from an object's materials, beyond "the image file exists": the
Material Output Cycles uses, the frame file of an image sequence, the tiles of a tiled image,
linked materials whose library is missing, and UV map names nodes refer to. Each problem is a
sentence naming the thing and the fix (bake_request.py gathers them before anything bakes)."""

import re
from pathlib import Path

from .compat import renders_nodes
from .open_blend import newer_than_running

MAGENTA = "Cycles would bake its magenta 'missing' colour"
MAGENTA_RENDERED = "Cycles renders its magenta 'missing' colour"     # (not in the bake)
# Geometry attributes Cycles provides without a mesh layer of that name.
BUILT_IN = {"position", "normal", "generated", "orco", "tangent", "uv"}


def live_links(socket):
    """The links into `socket` Cycles follows: a muted link (the artist's switch) is none, and
    the socket takes its own value."""
    return [lk for lk in socket.links if lk.is_valid and not lk.is_muted]



def upstream_nodes(socket, rendered=False):
    """{name: node} of every node that feeds `socket`, at any depth, through links Cycles
    follows, in the order met. `rendered`: only the nodes Cycles evaluates for it: a muted node
    is none, and passes on only the inputs its internal links name."""
    seen, found, todo = set(), {}, [lk.from_node for lk in live_links(socket)]
    while todo:
        node = todo.pop()
        if node.name in seen:
            continue
        seen.add(node.name)
        inputs = node.inputs
        if rendered and node.mute:
            passed = {lk.from_socket.identifier for lk in node.internal_links}
            inputs = [s for s in inputs if s.identifier in passed]
        else:
            found[node.name] = node
        todo += [lk.from_node for s in inputs for lk in live_links(s)]
    return found

def render_output(tree, target):
    """The Material Output node the engine `target` ("CYCLES" or "EEVEE") renders through
    (Blender's ntreeShaderOutputNode rule): an output targeted at that engine wins over one
    targeted at All, even an active one; within the target, the active one, else the first.
    None when every output is the other engine's."""
    for kind in (target, "ALL"):
        outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"
                   and getattr(n, "target", "ALL") == kind]
        if outputs:
            return next((n for n in outputs if n.is_active_output), outputs[0])
    return None


def group_outputs(tree):
    """The Group Output nodes of group `tree` whose inputs its group node gives out: the active
    one (Blender flattens a shader group through the one flagged active alone), all of them
    where none is flagged. Walked through every Group Output, a missing image feeding only an
    inactive one refused a bake whose map it cannot change (rt56a)."""
    outputs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"]
    return [n for n in outputs if n.is_active_output] or outputs


def cycles_output(tree):
    """The Material Output node Cycles renders through (render_output)."""
    return render_output(tree, "CYCLES")


def renders_nothing(output):
    """True where Cycles renders nothing through `output`: muted, on a line whose Cycles does
    not pass a muted Material Output on (4.2, 4.5: LineFacts.muted_output_renders)."""
    import bpy
    from ..reference.blender_lines import facts_for
    return output is not None and output.mute and \
        not facts_for(bpy.app.version).muted_output_renders


def muted_output_text(output):
    """Why nothing is rendered through `output` (renders_nothing), and the fix."""
    import bpy
    return (f"its Material Output {output.name!r} is muted, and Blender "
            f"{bpy.app.version_string} renders nothing through a muted output (no closure: the "
            f"flat normal); unmute it (select it, M)")


def sequence_frame(image_user, scene_frame):
    """The frame number an Image Sequence's image user reads at `scene_frame` (Blender's
    BKE_image_user_frame_get: start, duration, cyclic, then the offset)."""
    n = image_user.frame_duration
    if n == 0:
        return 0
    f = scene_frame - image_user.frame_start + 1
    if image_user.use_cyclic:
        f %= n
        if f == 0:
            f = n
    return max(0, min(f, n)) + image_user.frame_offset


def sequence_frame_path(path, frame):
    """`path` with its file name's last run of digits (or of '#') replaced by `frame`,
    padded to the same width, as Blender names a sequence's frame file."""
    p = Path(path)
    m = None
    for m in re.finditer(r"\d+|#+", p.name):
        pass
    if m is None:
        return p
    digits = m.group(0)
    return p.with_name(p.name[:m.start()] + str(frame).zfill(len(digits)) + p.name[m.end():])


def sequence_problem(image, node, path, scene):
    """The frame file the bake reads at the scene's current frame, when it is missing."""
    frame = sequence_frame(node.image_user, scene.frame_current)
    wanted = sequence_frame_path(path, frame)
    if wanted.is_file():
        return None
    return (f"image sequence {image.name!r} reads frame {frame} at scene frame "
            f"{scene.frame_current}, file {str(wanted)!r}, which does not exist: {MAGENTA}; "
            f"add that frame's file, or set the Image Texture node's Start Frame / Offset (or "
            f"the scene's current frame) to a frame that exists")


def missing_tiles_problem(image, covered):
    """A tiled image lacking a tile the bake's UVs cover (Cycles bakes magenta there)."""
    have = {t.number for t in image.tiles}
    lacking = [t for t in covered if t not in have]
    if not lacking:
        return None
    return (f"tiled image {image.name!r} has no tile {lacking[0]} (tiles: {sorted(have)}), but "
            f"the UVs cover it: {MAGENTA} there; add the tile with its file (Image > Add Tile), "
            f"or move those UVs into tiles the image has")


def missing_library_problem(block, what="object"):
    """A block (an object, or a node group or image a material reads) linked from a library
    that is missing, unreadable, or no longer holds it: Blender keeps an empty placeholder
    under its name (no mesh to bake; a group that outputs nothing, an image of no pixels: a
    flat or uniform map). A library linked in through another one is named with it."""
    import bpy
    lib = getattr(block, "library", None)
    if lib is None:
        return None
    path = bpy.path.abspath(lib.filepath)
    via = f" (linked in through library {lib.parent.filepath!r})" \
        if getattr(lib, "parent", None) is not None else ""
    if not Path(path).is_file():
        return (f"{what} {block.name!r} is linked from library {lib.filepath!r} ({path}){via}, "
                f"which is missing, so Blender left an empty placeholder: put the library "
                f"file there or relink it (File > External Data > Find Missing Files)")
    if getattr(lib, "is_missing", False):
        newer = newer_than_running(path, bpy.app.version)
        why, fix = (f"which was saved by Blender {newer}, newer than this Blender "
                    f"({bpy.app.version[0]}.{bpy.app.version[1]}), and could not be read",
                    f"bake with Blender {newer} or later") if newer else \
            ("which this Blender could not read (damaged?)",
             "put a readable copy of the library there, or relink it")
        return (f"{what} {block.name!r} is linked from library {lib.filepath!r} ({path}){via}, "
                f"{why}, so Blender left an empty placeholder: {fix}")
    if getattr(block, "is_missing", False):
        return (f"{what} {block.name!r} is linked from library {lib.filepath!r}{via}, which no "
                f"longer holds it (renamed or removed there), so Blender left an empty "
                f"placeholder: restore it in the library, or relink it")
    return None


def edits_lost(*blocks):
    """True when an edit of these data-blocks (a material, its node tree) would never be saved:
    linked from a library, or a library override. An override's node tree reports itself
    editable on every line (4.2 to 5.2) and takes new nodes, but the file keeps only an
    override's changed values: reopened, the nodes are gone."""
    return any(b is not None and (not b.is_editable or b.library is not None
                                  or getattr(b, "override_library", None) is not None)
               for b in blocks)


def linked_text(what):
    """Why an edit of `what` (a material, a node tree) is refused: the file would not save it."""
    return (f"{what} is linked from a library (or override data), so an edit would not be "
            f"saved: make it local first (Object > Relations > Make Local)")


def no_tree_problem(mat):
    """A material without a node tree (Use Nodes never turned on, before 5.0): the bake writes
    through an Image Texture node in each material, and has nowhere to put one."""
    if mat.node_tree is not None:
        if renders_nodes(mat):
            return None
        # Up to 4.5: Cycles renders it without the tree, and the bake finds no image in it
        # (it failed after the checks with "Blender gave no reason", exit 1).
        return (f"material {mat.name!r} has Use Nodes off, so Cycles renders it without its "
                f"nodes and the bake has nowhere to write its faces: turn on Use Nodes for it "
                f"(Material Properties > Surface; its nodes then render), or give its faces "
                f"another material")
    return (f"material {mat.name!r} has no node tree (Use Nodes is off), so the bake has "
            f"nowhere to write its faces: turn on Use Nodes for it (Material Properties > "
            f"Surface), or give its faces another material")


def nodes_off_problem(mat, what):
    """A material that does not render through nodes (Use Nodes off, 4.2 and 4.5; never turned
    on there: no tree): an edit of its nodes (`what`, e.g. "a layer stack") would not render,
    and turning Use Nodes on for the artist would change its look unasked."""
    if renders_nodes(mat):
        return None
    return (f"material {mat.name!r} does not use nodes (Use Nodes is off), so {what} would "
            f"not render: turn on Use Nodes (Material Properties > Surface, or the Shader "
            f"Editor's header), then try again")


def uv_name_problem(mat, path, node, mesh_name, uv_maps, attributes, as_rendered=""):
    """A Normal Map (tangent space), UV Map or Attribute (Geometry) node naming a UV map or
    attribute that mesh `mesh_name` lacks: `uv_maps` (in order) and `attributes` are the names
    the mesh the bake renders has; as_rendered says so in the message where its modifiers
    may have made them."""
    maps = list(uv_maps)
    kind = node.bl_idname
    if kind == "ShaderNodeNormalMap" and node.space == "TANGENT":
        name, what = node.uv_map, "UV map"
    elif kind == "ShaderNodeUVMap" or (kind == "ShaderNodeTangent" and
                                       node.direction_type == "UV_MAP"):
        name, what = node.uv_map, "UV map"
    elif kind == "ShaderNodeAttribute" and node.attribute_type == "GEOMETRY":
        name, what = node.attribute_name, "attribute"
        if not name or name in maps or name in attributes or name in BUILT_IN:
            return None
    else:
        return None
    if not name or name in maps:
        return None
    return (f"node {path!r} (material {mat.name!r}) reads {what} {name!r}, which mesh "
            f"{mesh_name!r}{as_rendered} does not have (UV maps: {maps}): the bake would read "
            f"nothing there; pick one of its UV maps in the node, or rename the UV map")


def colour_attribute_problem(mat, path, node, mesh_name, colours, as_rendered=""):
    """A Color Attribute node naming no colour attribute of the mesh the bake renders
    (`colours`, their names), or none named and the mesh has none: Cycles bakes zero there
    (tests/test_faults_materials39.py), and for an attribute of another kind (a UV map) reads
    past it: measured, a crash (SIGSEGV) on every line, at times values near 1e25 on 4.2."""
    if node.bl_idname != "ShaderNodeVertexColor" or node.layer_name in colours or \
            (not node.layer_name and colours):
        return None
    what = f"colour attribute {node.layer_name!r}" if node.layer_name else \
        "the active render colour attribute"
    return (f"node {path!r} (material {mat.name!r}) reads {what}, which mesh {mesh_name!r}"
            f"{as_rendered} does not have (colour attributes: {list(colours)}): the bake "
            f"would read nothing there, or a crash or garbage for an attribute of another "
            f"kind (a UV map); pick one of its colour attributes in the node, or read a UV "
            f"map or other attribute with an Attribute node")
