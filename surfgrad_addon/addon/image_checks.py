"""The images a bake reads, checked before it runs (bake_request.check): every image node the
object's materials reach from the Material Output Cycles uses, through links and into node
groups; each image set, present, loadable, whole (a JPEG or TIFF cut short loads, the rest
filled in), with defined (image_channels.py) and finite pixels; the UV maps nodes name.
Cycles would bake its magenta 'missing' colour for an image it cannot read, silently."""

import contextlib
import tempfile
from pathlib import Path

from ..reference import input_checks as IC
from ..reference import tiles as T
from . import material_inputs as MI
from . import normal_sources as NS
from .bake_uvs import baked_mesh, modified, rendered_materials
from .float_pixels import PixelsTooLarge, file_facts, pixel_facts
from .header_reads import one_header_read, path_headers
from .read_once import ReadOnce
from .image_channels import (cut_short_file, cut_short_problem, layered_file,
                             path_channel_problem, running_facts, undefined_channel_problem)


def material_images(obj, only=None, viewport=False):
    """[(material, node path, node, image or None)] for every image node the object's
    materials (or material `only`) read: reached from the Material Output Cycles uses
    (material_inputs.py) through links, into node groups. viewport: the materials of obj as
    the viewport evaluates it (bake_uvs.rendered_materials)."""
    found, memo = [], {}
    for mat in checked_materials(obj, only, viewport):
        if mat.node_tree is None:
            continue                                # (a tree without use_nodes: checked too)
        for node, path, _ in material_nodes(mat, memo):
            if node.bl_idname in ("ShaderNodeTexImage", "ShaderNodeTexEnvironment"):
                found.append((mat, path, node, node.image))
    return found


def checked_materials(obj, only=None, viewport=False):
    """The materials to check: `only`, or every material obj renders with (bake_uvs.
    rendered_materials: a Geometry Nodes Set Material's too)."""
    return [only] if only is not None else rendered_materials(obj, viewport)


def muted_output_warnings(obj):
    """A warning per material obj renders with (checked_materials: a Geometry Nodes Set
    Material's too) that Cycles renders nothing through (MI.renders_nothing): its faces bake
    the flat normal, whatever its nodes hold."""
    return [f"material {mat.name!r}: {MI.muted_output_text(output)}; its faces bake flat"
            for mat in checked_materials(obj) if mat.node_tree is not None
            and MI.renders_nothing(output := MI.cycles_output(mat.node_tree))]


def material_nodes(mat, memo):
    """(node, path, group nodes it lies in) of every node `mat` reads through the output
    Cycles renders (none through a muted one on 4.2 and 4.5: MI.renders_nothing)."""
    output = MI.cycles_output(mat.node_tree)
    read = output is not None and not MI.renders_nothing(output)
    return _reached(mat.node_tree, [output] if read else [], memo)


def data_key(block):
    """A data-block's identity: a local one and a library's may share a name."""
    return block.name, block.library.filepath if block.library else None


def _reached(tree, starts, memo):
    """(node, path of node names, the group nodes it lies in from `tree` on) of every node
    `starts` read in `tree` through links that are not muted, and inside the node groups they
    use (each group walked once: memo). A muted node is not read: Cycles only passes on the
    inputs its internal links name (none for an Image Texture or a Normal Map's Color; a
    group's inside never), measured in tests/test_faults_leftovers41.py."""
    links_to = {}
    for link in tree.links:
        if link.is_valid and not getattr(link, "is_muted", False):
            links_to.setdefault(link.to_node.name, []).append(link)
    out, todo, seen = [], list(starts), set()
    while todo:
        node = todo.pop()
        if node.name in seen:
            continue
        seen.add(node.name)
        links = links_to.get(node.name, [])
        if node.mute and node not in starts:
            passed = {lk.from_socket.identifier for lk in node.internal_links}
            todo += [lk.from_node for lk in links if lk.to_socket.identifier in passed]
            continue
        out.append((node, node.name, ()))
        todo += [lk.from_node for lk in links]
        group = getattr(node, "node_tree", None) if node.type == "GROUP" else None
        if group is not None:
            key = data_key(group)
            if key not in memo:
                memo[key] = []                  # a group that holds itself stops here
                memo[key] = _reached(group, MI.group_outputs(group), memo)
            out += [(n, f"{node.name} > {p}", (node, *outer))
                    for n, p, outer in memo[key]]
    return out


def image_problems(obj, covered=(), only=None, warnings=None):
    """Every image the object's materials (or material `only`) read that can change the baked
    normal (normal_sources.py: a Normal input's, a height's; not a Base Color's): set,
    present, loadable, finite pixels; the frame file a sequence reads now, the tiles
    (`covered`, the UDIM tiles the bake writes) of a tiled image; linked materials whose
    library is missing; UV map names nodes refer to. The same problems of the other images
    go to `warnings` (a list, when given): Cycles does not read them for the bake, and
    refusing it for a missing Base Color (as up to round 53) stopped a map they cannot
    change."""
    import bpy
    out, checked = [], set()
    for mat in checked_materials(obj, only):
        # (a missing library's placeholder has no tree either: its library is the fix)
        problem = MI.missing_library_problem(mat, "material") or MI.no_tree_problem(mat)
        if problem and problem not in out:
            out.append(problem)
    out += uv_reference_problems(obj, only)
    out += linked_group_problems(obj, only)
    reached = {}
    found = material_images(obj, only)
    # An image read for the normal and for a colour too is checked (and refused) as the
    # normal's: its readers that reach the normal first.
    found.sort(key=lambda f: not feeds_normal(f[0], f[2], reached))
    for mat, path, node, image in found:
        normal = feeds_normal(mat, node, reached)
        said = out if normal else (warnings if warnings is not None else [])
        if image is None:
            said.append(f"image node {path!r} (material {mat.name!r}) has no image: Cycles "
                        f"would bake its magenta 'missing' colour; pick an image or remove "
                        f"the node" if normal else
                        f"image node {path!r} (material {mat.name!r}) has no image: the "
                        f"material renders magenta there; pick an image or remove the node "
                        f"({NOT_NORMAL})")
            continue
        if data_key(image) in checked:
            continue
        checked.add(data_key(image))
        problem = _image_problem(image, node, covered)
        if problem and normal:
            out.append(f"{problem} (read by {path!r} in material {mat.name!r})")
        elif problem:
            said.append(f"{problem.replace(MI.MAGENTA, MI.MAGENTA_RENDERED)} (read by "
                        f"{path!r} in material {mat.name!r}; {NOT_NORMAL})")
    return out


NOT_NORMAL = ("it feeds no normal the bake reads, so the map is baked without it: the "
              "material still renders it wrong")


def feeds_normal(mat, node, reached):
    """Image node `node` of `mat` can change the baked normal (normal_sources.py); `reached`:
    a dict kept between calls (each material walked once)."""
    if mat.name_full not in reached:
        reached[mat.name_full] = NS.normal_nodes(mat) if mat.node_tree is not None else set()
    return NS.reaches_normal(node, reached[mat.name_full])


def _image_problem(image, node, covered):
    """What is wrong with `image`, read by Image Texture `node`, else None (image_problems)."""
    import bpy
    on_disk = image.packed_file is None and image.filepath
    if on_disk and image.source == "SEQUENCE" and hasattr(node, "image_user"):
        # the frame the bake reads now, not the file the path names
        file = bpy.path.abspath(image.filepath, library=image.library)
        problem = MI.sequence_problem(image, node, file, bpy.context.scene) or \
            file_problem(f"image sequence {image.name!r}", sequence_file(image, node))
    else:
        problem = MI.missing_library_problem(image, "image") or one_image_problem(image)
    if not problem and image.source == "TILED" and covered:      # (packed ones too)
        problem = MI.missing_tiles_problem(image, covered)
    if not problem and on_disk and image.source == "TILED":
        problem = _tile_files_problem(image, covered)
    if not problem and packed_tiled(image):
        problem = _packed_tiles_problem(image, covered)
    return problem


def linked_group_problems(obj, only=None):
    """Node groups the materials read that are placeholders of linked data a library no
    longer gives (missing, unreadable, renamed there; also a library linked in through
    another): Cycles evaluates the empty group as nothing and bakes a flat map, exit 0."""
    out = []
    for mat, node, path, _ in objects_nodes(obj, only):
        group = getattr(node, "node_tree", None) if node.type == "GROUP" else None
        problem = group is not None and MI.missing_library_problem(group, "node group")
        if problem and not any(problem in p for p in out):
            out.append(f"{problem} (read by {path!r} in material {mat.name!r})")
    return out


def objects_nodes(obj, only=None):
    """(material, node, path, the group nodes it lies in) for every node the object's
    materials (or material `only`) read through the output Cycles renders (material_nodes)."""
    memo = {}
    for mat in checked_materials(obj, only):
        if mat.node_tree is None:
            continue
        for node, path, outer in material_nodes(mat, memo):
            yield mat, node, path, outer


def output_input_problems(obj, finals):
    """An output file that is the file of an image the object's materials read (a texture
    named like the map, or a pattern that lands on one): the bake would replace its own input,
    with overwrite even silently, and a second run would bake from the first one's map."""
    reads = {}
    for mat, _, _, image in material_images(obj):
        if image is None or image.packed_file is not None or not image.filepath or \
                image.source in ("GENERATED", "VIEWER"):
            continue
        for f in image_files(image):
            reads.setdefault(Path(f).resolve(), (image.name, mat.name))
    out = []
    for final in finals.values():
        hit = reads.get(Path(final).resolve())
        if hit:
            out.append(f"output {str(final)!r} is the file of image {hit[0]!r}, which material "
                       f"{hit[1]!r} reads: the bake would replace its own input; write the map "
                       f"to another file")
    return out


def uv_reference_problems(obj, only=None):
    """Nodes naming a UV map (an attribute, a colour attribute) the mesh the bake renders lacks
    (in the object's materials, or material `only`). That mesh, not the viewport's: a modifier on in
    renders only that writes the UV map was refused, one on in the viewport only baked a flat
    map with exit 0."""
    baked = baked_mesh(obj)
    as_rendered = " as it renders (its modifiers at their render settings)" \
        if modified(obj) else ""
    out, memo = [], {}
    for mat in checked_materials(obj, only):
        if mat.node_tree is None:
            continue
        for node, path, _ in material_nodes(mat, memo):
            problem = MI.uv_name_problem(mat, path, node, obj.data.name, baked.layout,
                                         baked.attribute_names, as_rendered) or \
                MI.colour_attribute_problem(mat, path, node, obj.data.name,
                                            baked.colour_attributes, as_rendered)
            if problem:
                out.append(problem)
    return out


def sequence_file(image, node):
    """The frame file the on-disk Image Sequence `image`, read by Image Texture `node`, reads
    at the scene's current frame."""
    import bpy
    file = bpy.path.abspath(image.filepath, library=image.library)
    return MI.sequence_frame_path(file, MI.sequence_frame(node.image_user,
                                                          bpy.context.scene.frame_current))


def textures_feeding(socket, outer=(), through=None):
    """The Image Texture nodes whose output reaches `socket` (through reroutes, out of the
    node groups `outer`, the group nodes `socket` lies in, outermost first, through their
    inputs, and through a node whose bl_idname `through` maps to the names of the inputs to
    follow, None for all).
    Through links Cycles follows: a muted one leaves the socket its value; a muted node passes
    on only the input its internal link names (an Image Texture none)."""
    found = []
    while socket is not None and (links := MI.live_links(socket)):
        link = links[0]
        source = link.from_node
        if source.mute:
            socket = next((lk.from_socket for lk in source.internal_links
                           if lk.to_socket.identifier == link.from_socket.identifier), None)
        elif source.bl_idname == "NodeReroute":
            socket = source.inputs[0]
        elif source.bl_idname == "NodeGroupInput" and outer:
            socket = next((s for s in outer[-1].inputs
                           if s.identifier == link.from_socket.identifier), None)
            outer = outer[:-1]
        elif through and source.bl_idname in through:
            names = through[source.bl_idname]
            followed = [s for s in source.inputs
                        if s.enabled and (names is None or s.name in names)]
            for tex in (t for s in followed for t in textures_feeding(s, outer, through)):
                if tex not in found:
                    found.append(tex)
            return found
        else:
            return [source] if source.bl_idname == "ShaderNodeTexImage" else []
    return found


def sampler_textures(socket):
    """The Image Texture nodes Cycles reads upstream of a Sampler group's Sampler input
    `socket` (in the Sampler zone linked into it; MI.upstream_nodes, muted ones left out)."""
    return [n for n in MI.upstream_nodes(socket, rendered=True).values()
            if n.bl_idname == "ShaderNodeTexImage"]


def image_files(image):
    """The files an unpacked file image reads (one per UDIM tile for a tiled one)."""
    import bpy
    path = bpy.path.abspath(image.filepath, library=image.library)
    if image.source == "TILED":
        return [T.tile_path(path, t.number) for t in image.tiles]
    return [Path(path)]


def one_image_problem(image):
    """None when `image` can be read as Cycles will read it, else what is wrong and the fix.
    An image this check loads is freed again (it stays as unloaded as it was)."""
    with one_header_read():                     # (each of its files' headers read once)
        return _one_image_problem(image)


def _one_image_problem(image):
    if image.source in ("GENERATED", "VIEWER"):
        return None
    packed = bool(getattr(image, "packed_files", None) and len(image.packed_files)) or \
        image.packed_file is not None
    what = f"image {image.name!r}"
    if not packed:
        if not image.filepath:
            return f"{what} has no file path and is not packed: pick its file, or pack it"
        problem = tile_format_problem(image)
        if problem:
            return problem
        folders = [str(p) for p in image_files(image) if p.is_dir()]
        if folders:
            return (f"{what} reads {folders[0]!r}, which is a folder, not an image file: "
                    f"Cycles would bake its magenta 'missing' colour; point the image at its "
                    f"file (File > External Data > Find Missing Files), or pack it")
        missing = [str(p) for p in image_files(image) if not p.is_file()]
        if missing:
            return (f"{what} reads {missing[0]!r}, which does not exist: Cycles would bake "
                    f"its magenta 'missing' colour; put the file there, fix the path "
                    f"(File > External Data > Find Missing Files), or pack it")
        if image.source == "SEQUENCE":
            return None                         # its frame file: image_problems loads it
    if not image.has_data and layered_file(image):
        # From the header, before a load: 4.2 never returns from one of such a file cut short.
        return multilayer_problem(f"{what} ({'packed' if packed else repr(image.filepath)})")
    # From the headers, before a load: garbage in the pixels would make the NaN check's answer
    # a matter of luck, and Blender does not open a subsampled luminance-chroma EXR at all.
    problem = undefined_channel_problem(image, running_facts())
    cut = cut_short_file(image)
    if problem or cut:
        return problem or cut_short_problem(what, cut[0] if cut[0].startswith("packed") else
                                            repr(cut[0]), cut[1])
    had_data = image.has_data
    try:
        w, h = image.size
        if w == 0 or h == 0:
            problem = not packed and next(filter(None, (
                unreadable_problem(what, p) for p in image_files(image))), None)
            if problem:
                return problem
            if image.type == "MULTILAYER":      # set by the load above; Cycles reads it
                return multilayer_problem(
                    f"{what} ({'packed' if packed else repr(image.filepath)})")
            if image.source == "MOVIE":         # a movie Blender cannot decode: magenta
                return (f"movie {what[6:]} ({image.filepath!r}) could not be read (damaged, "
                        f"or this Blender cannot decode it): {MI.MAGENTA}; render it to an "
                        f"image sequence (PNG or EXR) and use that")
            return (f"{what} ({'packed' if packed else repr(image.filepath)}) could not be "
                    f"read (damaged, or a format Blender does not open): re-save it as PNG "
                    f"or EXR")
        try:
            facts = pixel_facts(image)          # only float buffers can hold NaN / Inf
        except PixelsTooLarge as err:
            return str(err)
        return facts and IC.nonfinite_pixels_problem(what, facts.nonfinite, facts.beyond,
                                                      facts.largest_magnitude)
    finally:
        if not had_data and image.has_data:
            image.buffers_free()


def tile_format_problem(image):
    """A UDIM image on disk whose path holds '%': Blender reads a tiled image's tiles from its
    path as a printf format (<UDIM> becomes %d), so the load read other files (refused as
    damaged) or crashed ('%s'). Checked before any load."""
    import bpy
    path = bpy.path.abspath(image.filepath, library=image.library)
    if image.source != "TILED" or "%" not in path:
        return None
    return (f"UDIM image {image.name!r} reads {path!r}, whose '%' Blender takes as part of a "
            f"format when it loads the tiles (it reads other files, or crashes): rename the "
            f"folder or file without '%' and point the image at it (File > External Data > "
            f"Find Missing Files)")


def _tile_files_problem(image, covered):
    """The first tile of the UDIM tiles the bake reads (`covered`, else all) whose file is
    damaged: the image's own load reads one tile only, and Cycles bakes magenta for a tile
    it cannot read."""
    import bpy
    path = bpy.path.abspath(image.filepath, library=image.library)
    for tile in image.tiles:
        if covered and tile.number not in covered:
            continue
        problem = file_problem(f"tiled image {image.name!r} (tile {tile.number})",
                               T.tile_path(path, tile.number))
        if problem:
            return problem
    return None


def packed_tiled(image):
    """A UDIM image with more than one tile packed: its own load reads the first only."""
    return image.source == "TILED" and len(getattr(image, "packed_files", ())) > 1


# {image pointer: TemporaryDirectory of its packed tiles} in one_tile_write(): the image and
# normal-map checks read the same files (and their pixels once: float_pixels keys by path).
_tile_folders = ReadOnce(close=lambda folder: folder.cleanup())


def one_tile_write():
    """Within this block each packed UDIM tile is written to a temporary file once (the files
    go when it ends). Nothing may change an image's packed data within it."""
    return _tile_folders.scope()


@contextlib.contextmanager
def packed_tile_files(image, covered):
    """[(tile number, temporary file of its packed data)] of each of a packed UDIM image's
    tiles the bake reads (`covered`, else all), for as long as the `with` lasts (inside
    one_tile_write, as long as that): bpy loads no packed tile alone."""
    scoped = _tile_folders.active
    folder = _tile_folders.get(image.as_pointer(),
                               lambda: tempfile.TemporaryDirectory(prefix="surfgrad-tile-"))
    try:
        files = []
        for tile in image.packed_files:
            if covered and tile.tile_number not in covered:
                continue
            path = Path(folder.name) / f"tile{tile.tile_number}{Path(tile.filepath).suffix}"
            if not path.exists():
                path.write_bytes(tile.packed_file.data)
            files.append((tile.tile_number, path))
        yield files
    finally:
        if not scoped:
            folder.cleanup()


def _packed_tiles_problem(image, covered):
    """The first tile of a packed UDIM image's tiles the bake reads (`covered`, else all)
    whose packed data does not load with finite pixels: as _tile_files_problem, each from a
    temporary file of its own (packed_tile_files)."""
    with packed_tile_files(image, covered) as files:
        for number, path in files:
            problem = file_problem(f"tiled image {image.name!r} (tile {number})", path,
                                   shown="its packed data")
            if problem:
                return problem
    return None


def file_problem(what, path, shown=None):
    """None when the image file `path` (a UDIM tile's, a sequence frame's) loads with finite
    pixels, else what is wrong and the fix, naming the file as `shown` (else its path).
    Loaded into a probe image of its own, removed again, so the file's own images stay as
    they were."""
    import bpy
    shown = shown or repr(str(path))
    found = path_headers(path)
    if found and found.layered:                 # before a load (see one_image_problem)
        return multilayer_problem(f"{what} reads {shown}, which")
    if found and found.cut:
        return cut_short_problem(what, shown, found.cut)
    problem = path_channel_problem(what, path, running_facts())     # (as one_image_problem)
    if problem:
        return problem
    try:
        probe = bpy.data.images.load(str(path), check_existing=False)
    except RuntimeError:
        probe = None
    try:
        if probe is not None and 0 in probe.size[:] and probe.type == "MULTILAYER":
            return multilayer_problem(f"{what} reads {shown}, which")
        if probe is None or 0 in probe.size[:]:
            return unreadable_problem(what, path) or (
                f"{what} reads {shown}, which could not be read (damaged, or a format "
                f"Blender does not open): {MI.MAGENTA} there; re-save it as PNG or EXR")
        try:
            facts = file_facts(path, probe)     # (read once with normal_map_checks' range)
        except PixelsTooLarge as err:
            return str(err)
        return facts and IC.nonfinite_pixels_problem(f"{what} ({shown})", facts.nonfinite,
                                                      facts.beyond, facts.largest_magnitude)
    finally:
        if probe is not None:
            bpy.data.images.remove(probe)


def multilayer_problem(what):
    """A multilayer EXR reads 0 x 0 through bpy (its pixels are the Image Texture node's
    layer and pass), yet Cycles renders it: it is not damaged, but cannot be checked."""
    return (f"{what} is a multilayer OpenEXR: Cycles bakes the layer and pass its Image "
            f"Texture node picks, but surfgrad cannot read those pixels to check them (for "
            f"NaN, channels and range): save that pass as a single-layer OpenEXR and use that")


def unreadable_problem(what, path):
    """What is wrong when this process may not read the image file `path` (a permission, a
    file another user owns), else None: Blender says only that it could not load it, which
    reads as a damaged file."""
    try:
        with open(path, "rb") as f:
            f.read(1)
    except OSError as err:
        if isinstance(err, (FileNotFoundError, IsADirectoryError)):
            return None
        return (f"{what} reads {str(path)!r}, which cannot be opened ({err.strerror}): "
                f"{MI.MAGENTA}; let this user read it (its permissions or owner), or pack it")
    return None
