"""Freeze a material's surface-gradient stack into a tangent-space normal map, and thaw it back.

Freezing bakes what reaches the BSDF Normal input(s) through SG groups with the same code as
`bake-normal-map` (normal_bake.bake_normal_tiles, tangent space, the chosen UV map), then wires
UV Map -> Image Texture -> Normal Map (tangent, same UV map) into those inputs: the built-in
twin's render cost. The live stack stays in the material, unlinked, inside a frame; what thaw
needs (the links it replaced, the nodes it added and moved, the image) is kept as JSON in the
material's custom property RECORD. Thawing relinks the stack exactly and removes what freezing
added; the image too when freezing made it and nothing else uses it. No file is ever deleted.

Both are all-or-nothing: every check runs before anything changes, and a failure or a cancel
after the bake puts the material back as it was. freeze_steps is a generator that yields
between its stages (checked, baked, wired) so a modal operator can cancel between them by
throwing FreezeCancelled into it; freeze() runs it to the end.
"""

import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

from . import normal_bake as NB
from . import unrealized_instances as UI
from .bake_target import object_not_a_mesh
from .bake_request import _only_instances, mesh_problems
from .bake_uvs import baked_mesh, one_read
from .cache_files import unread_cache_problems
from .empty_slots import empty_slot_problem
from .float_pixels import one_pixel_read
from .foreign_nodes import foreign_node_problems
from .image_checks import image_problems, output_input_problems
from .image_memory import images_memory
from .preview_links import previewed
from .input_stamps import changed_problem, stamps
from .memory_limit import bake_memory_problem
from .normal_map_checks import input_warnings
from .parallax_heights import parallax_height_warnings
from .deformed_mesh import frozen_deform_warnings
from .small_objects import small_object_messages
from .material_inputs import (cycles_output, edits_lost, linked_text, live_links,
                              muted_output_text, no_tree_problem, nodes_off_problem,
                              renders_nothing, upstream_nodes)

RECORD = "surfgrad_freeze"
ADDED_LABEL = "surfgrad: "        # on every node the freeze adds: Thaw removes only those
FRAME_LABEL = ADDED_LABEL + "live stack (frozen into {})"
SG_PREFIX = "SG "
NORMAL = "Normal"
# A BSDF's normal inputs (Principled BSDF's coat has its own): the frozen map goes into each
# the stack feeds, or the frozen material would still run the live stack for the others.
NORMAL_INPUTS = (NORMAL, "Coat Normal")


class FreezeError(ValueError):
    """A freeze or thaw that cannot be done: the message names the thing and the fix."""


class FreezeCancelled(FreezeError):
    """The user cancelled; the material is as it was."""


@contextmanager
def _baking_the_stack_alone(tree, end):
    """For the bake only: the Material Output's Surface fed by a Diffuse BSDF whose Normal is
    the stack's end. Cycles' NORMAL bake averages the closures' normals, and a Principled
    BSDF's glossy and coat closures bend theirs (its bump correction), so baking the material
    as it is gave a visibly flatter map (mean |live - frozen| 0.0156 against 0.0078 through a
    Diffuse BSDF, 160x90 renders); the Diffuse closure's normal is the stack's. Restored after,
    also when the bake fails or is cancelled."""
    output = cycles_output(tree)
    surface = output.inputs["Surface"]
    shader = surface.links[0].from_socket
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    try:
        tree.links.new(end, diffuse.inputs[NORMAL])
        tree.links.new(diffuse.outputs[0], surface)
        yield
    finally:
        tree.links.new(shader, surface)
        tree.nodes.remove(diffuse)


def _upstream(socket, rendered=False):
    """The names of the nodes that feed `socket` (material_inputs.upstream_nodes)."""
    return set(upstream_nodes(socket, rendered))


def _is_sg(node, seen=()):
    """An SG group, or a group of the artist's with one inside (at any depth)."""
    tree = getattr(node, "node_tree", None) if node.bl_idname == "ShaderNodeGroup" else None
    if tree is None or tree in seen:
        return False
    return tree.name.startswith(SG_PREFIX) or any(_is_sg(n, (*seen, tree)) for n in tree.nodes)


def _fed(tree, output, rendered=False):
    """(the nodes reaching `output`'s Surface, [(shader node, normal input)] an SG group
    feeds), as Cycles renders them (`rendered`: _upstream) or as they are drawn."""
    nodes = [tree.nodes[n] for n in _upstream(output.inputs["Surface"], rendered)]
    return nodes, [(node, s) for node in nodes if _is_shader(node) for s in node.inputs
                   if s.name in NORMAL_INPUTS and live_links(s) and
                   any(_is_sg(tree.nodes[n]) for n in _upstream(s, rendered))]


def _is_shader(node):
    """A node that makes a closure (a BSDF), not one that passes a normal on (a Bump node)."""
    return any(o.type == "SHADER" for o in node.outputs)


def find_stack(tree):
    """(the socket the stack ends in, [(shader node, normal input)] it feeds) for the shaders
    reaching the Surface of the Material Output Cycles renders. Raises FreezeError naming
    the fix."""
    output = cycles_output(tree)
    if output is None or not output.inputs["Surface"].is_linked:
        raise FreezeError("the material has no shader linked to its Material Output's Surface: "
                          "link a BSDF first (to an output targeted at All or Cycles, which "
                          "Cycles renders)")
    if renders_nothing(output):
        raise FreezeError(f"nothing to freeze: {muted_output_text(output)}")
    # What Cycles renders: a muted node (a BSDF, a Mix Shader, an SG group) passes on only the
    # inputs its internal links name; a stack behind one is not rendered (baked, it was wired
    # in as if it were).
    shaders, fed = _fed(tree, output, rendered=True)
    muted = [f"the link into {node.name!r} {s.name}" for node in shaders if _is_shader(node)
             for s in node.inputs if s.name in NORMAL_INPUTS and s.is_linked and not live_links(s)]
    drawn, stacked = _fed(tree, output) if not fed else ((), ())
    between = {n for _, s in stacked for n in _upstream(s)} | {n.name for n, _ in stacked}
    muted += [f"node {n.name!r}" for n in drawn if stacked and n.mute and
              (n.name in between or _is_shader(n))]
    if not fed and muted:
        raise FreezeError(f"{', '.join(muted)} {'is' if len(muted) == 1 else 'are'} muted, so "
                          f"Cycles renders the material without what the stack brings: nothing "
                          f"to freeze; unmute it first")
    inside = sorted({repr(n.node_tree.name) for n in shaders if _is_shader(n) and _is_sg(n)})
    if not fed and inside:
        raise FreezeError(f"the stack is inside shader node group {', '.join(inside)}: Freeze "
                          f"wires the frozen map into the material's own BSDF Normal inputs "
                          f"(a group may serve other materials too); ungroup it (Ctrl+Alt+G) "
                          f"or bring the stack's normal out of the group into a BSDF in the "
                          f"material, then freeze")
    if not fed:
        outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
        which = (f" of the shader Cycles renders (through {output.name!r}, targeted at "
                 f"{output.target.title()}: Cycles takes a Cycles output before an All one, "
                 f"then the active one)" if len(outputs) > 1 else "")
        preview = previewed(tree, output)
        if preview:
            raise FreezeError(f"Cycles renders a preview, not the stack: {preview}, then "
                              f"freeze")
        raise FreezeError(f"no surface-gradient stack feeds a BSDF Normal input{which}: add one "
                          f"(Add > Surface Gradient > Add Surface-Gradient Layer Stack) first")
    ends = {(_source(s).node.name, _source(s).identifier) for _, s in fed}
    if len(ends) > 1:
        raise FreezeError(f"{len(ends)} different surface-gradient stacks feed the BSDF Normal "
                          f"inputs; one normal map holds one: feed them all from one SG "
                          f"Resolve, or freeze a material with one stack")
    return _source(fed[0][1]), fed


def _source(socket):
    """The output feeding `socket`, through reroutes (one stack may reach several inputs
    through reroutes of its own)."""
    source = socket.links[0].from_socket
    while source.node.bl_idname == "NodeReroute" and live_links(source.node.inputs[0]):
        source = live_links(source.node.inputs[0])[0].from_socket
    return source


# SG groups that look up the surface's position or normal in object (or world) space where
# their coordinate input (if any) is left unlinked: a pose or shape-key mix moves that lookup.
OBJECT_SPACE_GROUPS = ("SG Noise", "SG Triplanar", "SG Object Normal",
                       "SG Projector Coordinates", "SG Decal Coordinates")
COORDINATE_INPUTS = ("Vector", "Position")
# Built-in nodes' outputs that are positions or normals in object or world space.
OBJECT_SPACE_OUTPUTS = {"ShaderNodeTexCoord": ("Object", "Normal"),
                        "ShaderNodeNewGeometry": ("Position",)}


def _reads_object_space(node, stack=None, seen=()):
    if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
        tree = node.node_tree
        if tree.name.startswith(OBJECT_SPACE_GROUPS):
            return not any(s.name in COORDINATE_INPUTS and live_links(s) for s in node.inputs)
        # The artist's own group that wraps one (or a Texture Coordinate node): what leads to
        # its output inside. Measured (rt53a, tests/test_faults_trust53a.py): the layered
        # stack's SG Noise wrapped in a group froze posed with no warning.
        return tree not in seen and _tree_reads_object_space(tree, (*seen, tree))
    outputs = OBJECT_SPACE_OUTPUTS.get(node.bl_idname, ())
    # Only where such an output leads into the stack (`stack`: its nodes' names; a muted node
    # may pass it on): a Texture Coordinate node whose UV feeds the stack and whose Object
    # feeds the Base Color's noise is no object-space reader of the stack.
    return any(stack is None or lk.to_node.name in stack or lk.to_node.mute
               for name in outputs if name in node.outputs
               for lk in live_links(node.outputs[name]))


def _tree_reads_object_space(tree, seen):
    """A group's tree reads object space where such a node leads to its Group Output."""
    outputs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"]
    outputs = [n for n in outputs if n.is_active_output] or outputs   # the one Blender uses
    names = set()
    for out in outputs:
        for socket in out.inputs:
            names |= _upstream(socket, rendered=True)
    # The Group Output is part of the stack: a Texture Coordinate's Object linked straight to
    # it (a coordinates group) is read outside. Measured (rt54a, tests/test_faults_review54a.py):
    # such a group feeding SG Noise's Vector froze posed with no warning (readers []).
    stack = names | {out.name for out in outputs}
    return any(_reads_object_space(tree.nodes[n], stack, seen) for n in names)


def object_space_readers(tree, fed):
    """The nodes in the stack feeding `fed` that read object-space positions or normals, named
    for a message (what a pose or a shape-key mix moves, even through a tangent-space bake)."""
    names = set()
    for _, socket in fed:
        names |= _upstream(socket, rendered=True)
    nodes = [tree.nodes[n] for n in sorted(names) if _reads_object_space(tree.nodes[n], names)]
    return [f"{n.name!r} ({n.node_tree.name})" if n.bl_idname == "ShaderNodeGroup" else
            repr(n.name) for n in nodes]


def _stack_nodes(tree, fed):
    """The nodes that feed the stack and nothing else, not in a frame already: they go into
    the freeze's frame (a node that also feeds the shader elsewhere stays where it is)."""
    normals = {(node.name, s.identifier) for node, s in fed}
    inside = set()
    for _, s in fed:
        inside |= _upstream(s)
    changed = True
    while changed:
        changed = False
        for name in list(inside):
            outs = [lk for o in tree.nodes[name].outputs for lk in o.links]
            if any(lk.to_node.name not in inside and
                   (lk.to_node.name, lk.to_socket.identifier) not in normals for lk in outs):
                inside.discard(name)
                changed = True
    return sorted(n for n in inside if tree.nodes[n].parent is None)


def _check_file(filepath, overwrite):
    """The absolute Path for a save path, or a FreezeError naming the fix."""
    import bpy
    if filepath.startswith("//") and not bpy.data.filepath:
        raise FreezeError(f"{filepath!r} is relative to the .blend file, which is not saved "
                          f"yet: save the file first, or give an absolute path (or pack)")
    problem = NB.brace_token_problem(filepath, "Freeze's Save As", None)
    if problem:                           # Blender 5's {blend_name} is not filled in here
        raise FreezeError(problem)
    if NB.UDIM_TOKEN in filepath:         # (a file named with it was written)
        raise FreezeError(f"Save As {filepath!r} has {NB.UDIM_TOKEN}, which Freeze does not "
                          f"fill in: it bakes one image, of the 0-1 UV square; write the name "
                          f"itself (for tile 1001: {filepath.replace(NB.UDIM_TOKEN, '1001')!r})")
    path = Path(bpy.path.abspath(filepath))
    try:
        NB.check_output(path)
    except NB.NormalBakeError as err:
        raise FreezeError(str(err)) from None
    try:                          # a real write: permission bits do not bind root
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=".surfgrad_probe"):
            pass
    except OSError as err:
        raise FreezeError(f"folder {str(path.parent)!r} is not writable ({err.strerror}): "
                          f"choose a folder you can write to, or pack the image into the "
                          f".blend") from None
    if path.exists() and not overwrite:
        raise FreezeError(f"{str(path)!r} exists: tick Overwrite to replace it, or choose "
                          f"another file name")
    return path


def _other_meshes_using(obj, mat):
    """Names of the objects other than obj, on other data than obj's mesh, that use `mat`:
    a frozen map fits obj's surface and UVs only (linked duplicates share them)."""
    import bpy
    return sorted(repr(o.name) for o in bpy.data.objects
                  if o != obj and o.data != obj.data and
                  any(slot.material == mat for slot in getattr(o, "material_slots", ())))


def check(obj, resolution=NB.DEFAULT_RESOLUTION, uv_map="", filepath="", overwrite=False,
          mat=None, warn=lambda _: None):
    """Everything freeze needs, checked before anything changes: (material, tree, stack end,
    fed Normal inputs, uv_map, output Path or None for pack, the stamps of the image files it
    reads: input_stamps.stamps, taken before the checks read them). `mat`: one of obj's materials
    (the one a Shader Editor shows); None: obj's active material. bake-normal-map's warnings
    on the mesh and its UV map go to `warn`, also when the freeze is refused."""
    if obj is None:
        raise FreezeError("no active object: select the mesh whose material to freeze")
    if NB.cycles_problem():
        raise FreezeError(NB.cycles_problem())
    if obj.type != "MESH":
        raise FreezeError(object_not_a_mesh(obj, "select a mesh object"))
    if mat is not None and all(slot.material != mat for slot in obj.material_slots):
        raise FreezeError(f"the Shader Editor shows material {mat.name!r}, which {obj.name!r} "
                          f"does not use: the map is baked on the active object's surface; "
                          f"make an object using {mat.name!r} active, or show one of "
                          f"{obj.name!r}'s materials")
    mat = obj.active_material if mat is None else mat
    if mat is None or mat.node_tree is None:
        raise FreezeError(f"{obj.name!r} has no active material with nodes: add a material "
                          f"with a surface-gradient stack first")
    if mat.library is not None or getattr(mat, "override_library", None) is not None:
        raise FreezeError(linked_text(f"material {mat.name!r}"))
    if RECORD in mat:
        raise FreezeError(f"material {mat.name!r} is frozen already: thaw it first")
    off = nodes_off_problem(mat, "a frozen map")    # Blender's bake fails, naming nothing
    if off:
        raise FreezeError(off)
    others = _other_meshes_using(obj, mat)
    if others:
        raise FreezeError(f"material {mat.name!r} is also used by {', '.join(others)} (not "
                          f"{obj.name!r}'s mesh): the frozen map is baked on {obj.name!r}'s "
                          f"UVs and would be wrong there; give {obj.name!r} its own copy of "
                          f"the material first (the number next to the material's name "
                          f"makes it single-user)")
    tree = mat.node_tree
    end, fed = find_stack(tree)
    stamped = stamps(obj, mat)
    problem = NB.resolution_problem(resolution, *NB.RESOLUTION_RANGE)
    if problem:
        raise FreezeError(problem)
    stale = unread_cache_problems(obj)   # the mesh baked would be the import's, not the cache's
    if stale:
        raise FreezeError("; ".join(stale))
    with one_read():          # the mesh as it renders: one render-mode pass for both checks
        try:
            uv_map, _, _, _, outside = NB.plan_tile_layout(obj, "freeze.png", uv_map or None)
        except NB.NormalBakeError as err:
            text = str(err).replace(" (--object NAME)", "")
            if NB.UDIM_TOKEN in text:                 # one image: the 0-1 square alone
                text = _outside_square_text(obj, uv_map)
            # All faces instances: the layout's error would blame the UV map.
            raise FreezeError((_only_instances(obj) or [text])[0]) from None
        if outside:         # beyond the UDIM tiles: bake-normal-map refuses them too
            raise FreezeError(_outside_square_text(obj, uv_map))
        path = _check_file(filepath, overwrite) if filepath else None
        # The images the material reads, as bake-normal-map checks them: a missing one, or one
        # Blender loads other than its file says, would be frozen into the map.
        problem = NB.unslotted_problem(obj, mat) or \
            _memory_problem(obj, resolution)            # (its map would hold theirs too)
        warnings = []           # (an image the stack does not read: warned, not refused)
        problems = [problem] if problem else image_problems(obj, only=mat, warnings=warnings)
        problems += _treeless_problems(obj, mat)
        # The mesh as bake-normal-map checks it (NaN in the baked UV map or one the material
        # reads, positions, faces with area), and an object too small for the float32
        # derivatives of the groups it bakes through: each baked wrong texels with no word.
        # Its warnings too: far from the origin, faces collapsed in UV, overlapping islands.
        problems += mesh_problems(obj, uv_map, warnings, [NB.UDIM_FIRST], resolution, only=mat)
        problems += small_object_messages(obj, only=mat)[0]
        problems += foreign_node_problems(obj, only=mat)      # a newer line's: baked as zero
        # Unrealized instances of the material: the bake leaves them out of the map they read.
        baked = baked_mesh(obj)
        # Faces the rendered mesh holds in an empty slot the object fills or lacks (Geometry
        # Nodes): Blender's bake cancels, or bakes them with the slot's material (after the
        # checks had passed). Faces in a slot empty on the object too are skipped by the
        # bake like another material's, the map whole: not refused (rt58a).
        problem = empty_slot_problem(obj.name, baked.face_materials, baked.filled_slots, obj,
                                     own_empty_ok=True)
        problems += [problem] if problem else []
        more, notes = UI.instance_problems(baked.instances, obj, baked.triangle_uvs.get(uv_map),
                                           uv_map, [NB.UDIM_FIRST], resolution, None, only=mat)
        problems += more
        warnings += notes
        # Tangent space follows a pose or a shape-key mix, but what the stack reads in object
        # space is looked up where they put the surface.
        import bpy
        warnings += frozen_deform_warnings(obj, bpy.context.evaluated_depsgraph_get(),
                                           object_space_readers(tree, fed))
        # A Save As path that is the file of an image the object's materials read.
        problems += output_input_problems(obj, {NB.UDIM_FIRST: path}) if path else []
        for warning in warnings:
            warn(warning)
        if problems:
            raise FreezeError("; ".join(problems))
    return mat, tree, end, fed, uv_map, path, stamped


def _treeless_problems(obj, mat):
    """The object's other materials without a node tree (4.2, 4.5): the bake puts an image
    node in every material of the object (normal_bake.py), and in one without a tree it ended
    in a raw AttributeError (red team 47c)."""
    others = dict.fromkeys(s.material for s in obj.material_slots
                           if s.material is not None and s.material is not mat)
    return [no_tree_problem(m) for m in others if m.node_tree is None]


def _memory_problem(obj, resolution):
    """bake-normal-map's memory check, before the images are loaded: a bake the system
    would kill (SIGKILL) ends the artist's Blender session, the unsaved work with it."""
    problem = bake_memory_problem(resolution, 1, images_memory(obj, [NB.UDIM_FIRST]))
    return problem and problem.replace("--resolution", "Resolution")


def _outside_square_text(obj, uv_map):
    """The refusal of faces outside the 0-1 square, naming the UV map (the active render one
    where none was given) and, where the mesh data's UVs lie inside it, the modifiers that
    move them there (an Array's or Mirror's UV offset, a UV Warp)."""
    name = uv_map or next((uv.name for uv in obj.data.uv_layers if uv.active_render), "")
    layer = obj.data.uv_layers.get(name)
    moved = ""
    if layer is not None and len(layer.data) and obj.modifiers:
        uv = [0.0] * (2 * len(layer.data))
        layer.data.foreach_get("uv", uv)
        if 0.0 <= min(uv) and max(uv) <= 1.0:
            shown = ", ".join(repr(m.name) for m in obj.modifiers if m.show_render)
            moved = (f" as it renders (mesh {obj.data.name!r} has them inside it; its "
                     f"modifier(s) {shown} move them out, e.g. an Array's or Mirror's UV "
                     f"offset)")
    return (f"UV map {name!r} of {obj.name!r} has faces outside the 0-1 UV square{moved}: a "
            f"frozen stack is one image of that square; pick (or unwrap) a UV map inside it"
            f"{', or set the offsets to 0' if moved else ''}")


def freeze_warnings(obj, mat):
    """What the Freeze operator reports once the freeze is done, as bake-normal-map warns of
    it: what bends the normal maps the material reads, parallax heights, a small object."""
    with one_pixel_read():          # (each image's pixels read once for all of them)
        return (input_warnings(obj, mat) + parallax_height_warnings(obj, mat) +
                small_object_messages(obj, only=mat)[1])


def freeze_steps(obj, resolution=NB.DEFAULT_RESOLUTION, uv_map="", filepath="", overwrite=False,
                 samples=1, log=lambda *_: None, mat=None, warn=lambda _: None):
    """Freeze obj's active material (see the module doc), yielding "checked", "baked" and
    "wired" (the file is written after it); the generator's return value is the record.
    Throw FreezeCancelled in at a stage to cancel. `warn`: check's warnings."""
    import bpy
    mat, tree, end, fed, uv_map, path, stamped = check(obj, resolution, uv_map, filepath,
                                                       overwrite, mat, warn)
    yield "checked"
    suffix = path.suffix.lower() if path else ".png"
    depth = "16" if suffix == ".png" else "float"         # 8 bits would cost ~0.3 degrees
    folder = path.parent if path else Path(tempfile.mkdtemp(prefix="surfgrad_freeze_"))
    stem = path.stem if path else f"{mat.name}_frozen_normal"
    # The packed map's working file is named after the material, which may hold a "/".
    baked = folder / f".{bpy.path.clean_name(stem)}.freeze{os.getpid()}{suffix}"
    image = None
    try:
        with _baking_the_stack_alone(tree, end):
            NB.bake_normal_tiles(obj, baked, "tangent", resolution, uv_map, samples=samples,
                                 depth=depth, overwrite=True, log=log, only=mat)
        # A file removed or rewritten since the checks (the modal run lets the artist save
        # over a texture meanwhile) baked Cycles' magenta or unchecked pixels into the map.
        changed = changed_problem(stamped)
        if changed:
            raise FreezeError(changed.replace("bake again", "freeze again"))
        yield "baked"
        image = bpy.data.images.load(str(baked), check_existing=False)
        image.name = path.name if path else f"{stem}{suffix}"
        image.colorspace_settings.is_data = True
        if path is None:
            image.pack()
            image.filepath_raw = f"//{image.name}"    # where File > Unpack would put it
        record = _wire(mat, tree, fed, uv_map, image)
        try:
            yield "wired"                         # the last chance to cancel: nothing written
            if path is not None:
                try:
                    NB._publish(baked, path, overwrite)
                except NB.NormalBakeError:
                    raise FreezeError(f"{str(path)!r} appeared during the bake: tick "
                                      f"Overwrite to replace it, or choose another file "
                                      f"name") from None
                image.filepath_raw = str(path) if not filepath.startswith("//") else filepath
                image.reload()
                record["file"] = str(path)
                mat[RECORD] = json.dumps(record)
        except BaseException:
            thaw(mat)
            image = None                              # thaw removed it
            raise
        return record
    except BaseException:
        if image is not None:
            bpy.data.images.remove(image)
        raise
    finally:
        if baked.exists():
            baked.unlink()
        if path is None and folder.exists() and not any(folder.iterdir()):
            os.rmdir(folder)


def freeze(obj, resolution=NB.DEFAULT_RESOLUTION, uv_map="", filepath="", overwrite=False,
           samples=1, log=lambda *_: None, cancel=lambda stage: False, warn=lambda _: None):
    """Run freeze_steps to the end; `cancel(stage)` True after a stage cancels the freeze."""
    steps = freeze_steps(obj, resolution, uv_map, filepath, overwrite, samples, log, warn=warn)
    stage = next(steps)
    try:
        while True:
            if cancel(stage):
                steps.throw(FreezeCancelled(f"freeze cancelled after stage {stage!r}: the "
                                            f"material is as it was"))
            stage = steps.send(None)
    except StopIteration as done:
        return done.value


def _drawn_at(node):
    """Where `node` is drawn: its location is relative to its frame (and that frame's)."""
    x, y = node.location
    while node.parent is not None:
        node = node.parent
        x, y = x + node.location.x, y + node.location.y
    return x, y


def _wire(mat, tree, fed, uv_map, image):
    """Add the frozen chain, link it into the fed Normal inputs, frame the stack; returns the
    record (also stored on the material). Undone in full if anything fails."""
    x = min(_drawn_at(node)[0] for node, _ in fed)
    y = min(_drawn_at(node)[1] for node, _ in fed)
    record = {"image": image.name, "image_created": True, "file": "",
              "links": [[s.links[0].from_node.name, s.links[0].from_socket.identifier,
                         node.name, s.identifier] for node, s in fed],
              "added": [], "moved": {}, "frame": ""}
    stack = _stack_nodes(tree, fed)          # before the frozen chain takes their place
    try:
        nodes = tree.nodes
        uv = nodes.new("ShaderNodeUVMap")
        uv.uv_map = uv_map
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = image
        nmap = nodes.new("ShaderNodeNormalMap")
        nmap.space = "TANGENT"
        nmap.uv_map = uv_map
        frame = nodes.new("NodeFrame")
        frame.label = FRAME_LABEL.format(image.name)
        for node in (uv, tex, nmap):
            node.label = f"{ADDED_LABEL}frozen ({node.bl_label})"
        record["added"] = [n.name for n in (uv, tex, nmap, frame)]
        record["frame"] = frame.name
        for i, node in enumerate((uv, tex, nmap)):
            node.location = (x - 760 + 260 * i, y - 420)
        tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])
        tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
        for node, s in fed:
            tree.links.new(nmap.outputs["Normal"], s)
        for name in stack:
            node = nodes[name]
            record["moved"][name] = list(node.location)
            node.parent = frame
        mat[RECORD] = json.dumps(record)
    except BaseException:
        _undo(mat, tree, record)
        raise
    return record


def _undo(mat, tree, record):
    """Put the stack back as the record says, remove the added nodes and the record. A node
    is removed only while it still carries the freeze's label: one the user deleted leaves its
    name free, and a node of the user's that took it again stays."""
    nodes = tree.nodes
    def added(name):
        node = nodes.get(name)
        return node if node is not None and node.label.startswith(ADDED_LABEL) else None
    for name in record["added"]:
        node = added(name)
        if node is not None and node.bl_idname != "NodeFrame":
            nodes.remove(node)
    for name, location in record["moved"].items():
        if name in nodes:
            nodes[name].parent = None
            nodes[name].location = location
    if added(record["frame"]) is not None:
        nodes.remove(nodes[record["frame"]])
    for from_node, from_id, to_node, to_id in record["links"]:
        tree.links.new(_socket(nodes[from_node].outputs, from_id),
                       _socket(nodes[to_node].inputs, to_id))
    if RECORD in mat:
        del mat[RECORD]


def _socket(sockets, identifier):
    return next(s for s in sockets if s.identifier == identifier)


# What thaw reads of a record, and the type of each.
_RECORD_FIELDS = {"image": str, "image_created": bool, "file": str, "links": list,
                  "added": list, "moved": dict, "frame": str}


def frozen_record(mat):
    """The freeze record of `mat`, or None when it is not frozen. A property under the
    record's name that is not one (edited by hand, or made by something else) is a
    FreezeError naming the fix."""
    if mat is None or RECORD not in mat:
        return None
    try:
        record = json.loads(mat[RECORD])
        readable = isinstance(record, dict) and all(
            isinstance(record.get(key), kind) for key, kind in _RECORD_FIELDS.items()) and all(
            isinstance(link, list) and len(link) == 4 and all(isinstance(s, str) for s in link)
            for link in record["links"])
    except (TypeError, ValueError):
        readable = False
    if not readable:
        raise FreezeError(f"material {mat.name!r} has a custom property {RECORD!r} that is not "
                          f"a freeze record surfgrad can read, so the live stack cannot be "
                          f"relinked from it: remove the property (Material Properties > "
                          f"Custom Properties) and relink the stack by hand")
    return record


def _made_image(tree, record):
    """The image the freeze made: the one its Image Texture node holds, under the record's name
    or, renamed by the artist, still at the file or pack path the freeze gave it; else the
    image under the record's name."""
    import bpy
    where = bpy.path.abspath(record["file"] or f"//{record['image']}")
    for name in record["added"]:
        node = tree.nodes.get(name)
        image = getattr(node, "image", None) if node is not None and \
            node.label.startswith(ADDED_LABEL) else None
        if image is not None and (image.name == record["image"] or
                                  bpy.path.abspath(image.filepath_raw) == where):
            return image
    return bpy.data.images.get(record["image"])


def thaw(mat):
    """Relink the live stack of a frozen material exactly as it was and remove what the
    freeze added (the image only if the freeze made it and nothing else uses it; never a
    file). Returns the record. Checks everything first: on a FreezeError nothing changed."""
    import bpy
    if mat is None:
        raise FreezeError("no active material: select the object whose frozen material to "
                          "thaw")
    record = frozen_record(mat)
    if record is None:
        raise FreezeError(f"material {mat.name!r} is not frozen: nothing to thaw")
    if edits_lost(mat):
        raise FreezeError(linked_text(f"material {mat.name!r}"))
    tree = mat.node_tree
    for from_node, from_id, to_node, to_id in record["links"]:
        for name, side, ident in ((from_node, "outputs", from_id), (to_node, "inputs", to_id)):
            node = tree.nodes.get(name)
            if node is None or not any(s.identifier == ident for s in getattr(node, side)):
                raise FreezeError(f"node {name!r} of the live stack is gone or changed, so "
                                  f"the stack cannot be relinked: undo to before its removal, "
                                  f"or remove the property {RECORD!r} and relink by hand")
    image = _made_image(tree, record)
    _undo(mat, tree, record)
    if image is not None and record["image_created"] and image.users == 0:
        bpy.data.images.remove(image)
    return record
