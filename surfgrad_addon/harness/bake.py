"""Headless Cycles CPU bakes of any shader vector into a float image, without leaving a trace.

`bake_vector` routes a vector (built by a callback in a temporary material) into an Emission
shader and bakes EMIT at 1 sample into a 32-bit float image: negative values survive, and the
values are exactly what the shader computed at Blender's bake sample points. Every scene,
object and material setting it changes is put back afterwards, and the temporary material and
image are removed.
"""

import time
from contextlib import contextmanager

import numpy as np

from ..addon.compat import new_material
from ..addon.node_builder import running_line  # noqa: F401 (the line whose bakes we model)
from ..addon.bake_console import quiet_bake
from ..addon.bake_uvs import uv_active
from ..addon.scene_state import NO_TEXTURE_LIMIT, SCENE_SETTINGS, restored, without_render_effects
from ..addon.bake_target import bake_target_problem, own_materials, visible_for_bake
from ..addon.exit_codes import BakeFailed
from ..addon.interrupts import native_call
from ..addon.normal_bake import blender_tile_path
from ..addon.far_precision import needs_precise_far, set_precise_far
from .graph import Graph


def exact_cycles(scene, device="CPU"):
    """Cycles on the CPU, one sample, no denoising or adaptivity, a fixed seed: every bake and
    render of the suite is exact and repeatable. device "GPU": on the GPU the preferences chose
    (cycles_device.selected), for --cycles-device. Returns scene.cycles."""
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = device
    cy.samples = 1
    cy.use_denoising = False
    cy.use_adaptive_sampling = False
    cy.seed = 0
    return cy


class BakeError(RuntimeError):
    """A bake could not run; the message names the object or setting and the fix."""


class BakeCancelled(BakeError, BakeFailed):
    """Blender's bake started and cancelled: a bake failure (exit code 1), not a refusal."""


@contextmanager
def _selection_kept(context):
    view_layer = context.view_layer
    active = view_layer.objects.active
    selected = [o for o in view_layer.objects if o.select_get()]
    try:
        yield
    finally:
        for o in view_layer.objects:
            o.select_set(o in selected)
        view_layer.objects.active = active


@contextmanager
def _temporary_material(obj, material):
    """Put `material` in every slot of obj (adding one slot if it has none); restore after.
    Assigning through the slot writes where the slot links (object or mesh data)."""
    saved = [slot.material for slot in obj.material_slots]
    added = not saved
    if added:
        obj.data.materials.append(material)
    else:
        for slot in obj.material_slots:
            slot.material = material
    try:
        problem = _other_materials_problem(obj, material)
        if problem:
            raise BakeError(problem)
        yield
    finally:
        if added:
            # The mesh had no materials: clear() (unlike pop) also drops the object's slot.
            obj.data.materials.clear()
        else:
            for slot, mat in zip(obj.material_slots, saved):
                slot.material = mat


def _other_materials_problem(obj, material):
    """None, or the refusal of an object whose modifiers give faces another material than
    `material` in its every slot (a Geometry Nodes Set Material, a Boolean transferring its
    cutter's): those faces bake with it, not with the graph (compare called a correct group
    180 degrees wrong there); or no material at all (geometry a Geometry Nodes tree makes or
    joins, which keeps none of the object's slots): Cycles renders those with its default
    surface (a correct group was called p99 180 degrees wrong, or Blender cancelled the bake)."""
    from ..addon.bake_uvs import read_as_baked

    def read(evaluated, _):
        slots = [s.material for s in evaluated.material_slots]
        others = sorted({m.original.name for m in slots
                         if m is not None and m.original != material})
        if not slots or all(m is not None for m in slots):
            return others, 0
        mesh = evaluated.to_mesh()
        try:
            index = np.zeros(len(mesh.polygons), np.int32)
            mesh.polygons.foreach_get("material_index", index)
        finally:
            evaluated.to_mesh_clear()
        empty = np.array([m is None for m in slots])[np.clip(index, 0, len(slots) - 1)]
        return others, int(np.count_nonzero(empty))

    others, bare = read_as_baked(obj, read)
    if others:
        return (f"object {obj.name!r} renders material(s) {others} on faces whatever its "
                f"material slots hold (a Geometry Nodes Set Material, or a Boolean modifier "
                f"transferring its cutter's materials): those faces would bake with them, not "
                f"with the method's groups; compare a copy without that modifier, or with the "
                f"Set Material node muted")
    if bare:
        nodes = [m.name for m in obj.modifiers if m.type == "NODES" and m.show_render]
        return (f"object {obj.name!r} renders {bare} face(s) with no material whatever its "
                f"material slots hold (geometry its modifier(s) {nodes or '(none)'} make or "
                f"join without one, which Cycles renders with its default surface): those "
                f"faces would bake flat, not with the method's groups; compare a copy without "
                f"those faces, or give them the object's material with a Set Material node "
                f"and compare that material's groups in the file itself")
    return None


def _check_target(obj, uv_map):
    import bpy
    problem = bake_target_problem(obj, bpy.context.view_layer)
    if problem:
        raise BakeError(problem)
    uv_names = [uv.name for uv in obj.data.uv_layers]
    if not uv_names:
        raise BakeError(f"object {obj.name!r} has no UV map; add one (UV > Unwrap) to bake")
    if uv_map is not None and uv_map not in uv_names:
        raise BakeError(f"object {obj.name!r} has no UV map named {uv_map!r}; it has "
                        f"{uv_names}")


def _tiled_float_image(name, width, height, tiles):
    """A UDIM image with the given tiles, every tile float, cleared to (0, 0, 0, 0). Tiles are
    added with image.tiles.new and each filled through its own active index (tile_add's poll
    fails once the first tile is renumbered away from 1001: that tile has no buffer yet)."""
    import bpy
    image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True, tiled=True)
    image.colorspace_settings.is_data = True
    image.generated_color = (0.0, 0.0, 0.0, 0.0)
    image.tiles[0].number = tiles[0]
    for number in tiles[1:]:
        image.tiles.new(tile_number=number)
    for index in range(len(image.tiles)):
        image.tiles.active_index = index
        with bpy.context.temp_override(edit_image=image):
            bpy.ops.image.tile_fill(color=(0, 0, 0, 0), generated_type="BLANK", width=width,
                                    height=height, float=True, alpha=True)
    return image


def _tile_pixels(image, tiles, width, height):
    """{tile: (pixels (H, W, 4) float32)} of a baked UDIM image. Python reads one tile's pixels
    only, so the tiles go through 32-bit OpenEXR files in a temporary folder."""
    import tempfile
    from pathlib import Path

    import bpy
    out = {}
    with tempfile.TemporaryDirectory(prefix="surfgrad_tiles_") as folder:
        image.filepath_raw = blender_tile_path(Path(folder) / "bake.<UDIM>.exr")   # ($TMPDIR: %)
        image.file_format = "OPEN_EXR"
        if hasattr(image, "use_half_precision"):
            image.use_half_precision = False
        image.save()
        for number in tiles:
            tile = bpy.data.images.load(str(Path(folder) / f"bake.{number}.exr"),
                                        check_existing=False)
            try:
                tile.colorspace_settings.is_data = True
                px = np.empty(width * height * 4, dtype=np.float32)
                tile.pixels.foreach_get(px)
                out[number] = px.reshape(height, width, 4)
            finally:
                bpy.data.images.remove(tile)
    return out


def bake_vector_tiles(obj, build, width, height, tiles, uv_map=None, log=None, device="CPU"):
    """bake_vector into a UDIM image with the given tiles (numbers, 1001 + u + 10 v): returns
    ({tile: (pixels (H, W, 3), coverage (H, W))}, seconds). Blender bakes each tile at its
    own UV offset (reference.tiles)."""
    import bpy
    _check_target(obj, uv_map)
    tiles = [int(t) for t in tiles]
    image = _tiled_float_image("surfgrad_bake_tiles", width, height, tiles)
    try:
        seconds = _bake_into(obj, build, image, uv_map, None, log, device)
        px = _tile_pixels(image, tiles, width, height)
        return {k: (v[..., :3].copy(), v[..., 3] > 0.5) for k, v in px.items()}, seconds
    finally:
        bpy.data.images.remove(image)


# Largest bake made in one piece: Cycles' bake buffers take about 190 bytes per texel (3.25 GB
# for a 4096^2 bake), so larger images are baked in pieces of this size (bake_vector_in_pieces).
PIECE_TEXELS = 2048
PIECE_UV_MAP = "surfgrad_bake_piece"      # the temporary UV map of a piece


def bake_vector_in_pieces(obj, build, width, height, uv_map=None, log=None,
                          piece=PIECE_TEXELS, rgba=False, device="CPU"):
    """bake_vector, with Cycles' memory bounded by a piece: an image larger than piece x piece
    is baked as a grid of pieces, each through a temporary UV map that scales the UV map by
    the (power-of-two) grid size and shifts the piece onto 0..1. The sample points and the
    bake differentials are the whole image's (the scale and shift are exact in float32 inside
    the piece), and a bake ignores UVs outside 0..1. Objects with modifiers (which may move
    UVs) and sizes that do not split into powers of two are baked whole. Returns what
    bake_vector returns (rgba: the baked RGBA, alpha 1 where written, no copy), the seconds
    summed over the pieces."""
    import bpy
    _check_target(obj, uv_map)
    nx, ny = _grid(width, piece), _grid(height, piece)
    if (nx == 1 and ny == 1) or len(obj.modifiers) or nx is None or ny is None:
        return bake_vector(obj, build, width, height, uv_map, log, rgba=rgba, device=device)
    mesh = obj.data
    name = uv_map or next(layer.name for layer in mesh.uv_layers if layer.active_render)
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers[name].uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    active = mesh.uv_layers.active_index
    render = next((layer.name for layer in mesh.uv_layers if layer.active_render), None)
    tmp = mesh.uv_layers.new(name=PIECE_UV_MAP, do_init=False)
    if tmp is None:                     # the mesh has the most UV maps Blender allows
        return bake_vector(obj, build, width, height, uv_map, log, rgba=rgba, device=device)
    pw, ph = width // nx, height // ny
    pixels = np.empty((height, width, 4), dtype=np.float32)
    buffer = np.empty((ph, pw, 4), dtype=np.float32)        # each piece's read-back
    seconds = 0.0
    try:
        mesh.uv_layers.active_index = active
        for j in range(ny):
            for i in range(nx):
                shifted = uv * np.array([nx, ny], dtype=np.float32) - np.array(
                    [i, j], dtype=np.float32)
                tmp.uv.foreach_set("vector", shifted.ravel())
                mesh.update()
                _, _, s = bake_vector(obj, build, pw, ph, tmp.name, rgba=True, out=buffer,
                                      device=device)
                pixels[j * ph:(j + 1) * ph, i * pw:(i + 1) * pw] = buffer
                seconds += s
                if log:
                    log(f"baked piece {j * nx + i + 1}/{nx * ny} of {obj.name}")
    finally:
        mesh.uv_layers.remove(mesh.uv_layers[PIECE_UV_MAP])
        mesh.uv_layers.active_index = active
        if render is not None:
            mesh.uv_layers[render].active_render = True
        mesh.update()
    return _result(pixels, rgba) + (seconds,)


def _result(px, rgba):
    """(RGB, coverage) of a baked RGBA image: the RGBA itself (no copy) when rgba."""
    covered = px[..., 3] > 0.5
    return (px if rgba else px[..., :3].copy()), covered


def _grid(size, piece):
    """Pieces along one side: the smallest power of two n with size / n <= piece that
    divides size, or None."""
    n = 1
    while size // n > piece or size % n:
        n *= 2
        if n > size:
            return None
    return n


def bake_vector(obj, build, width, height, uv_map=None, log=None, displacement=None,
                rgba=False, out=None, device="CPU"):
    """Bake the vector returned by `build(nodes, links)` (an output socket of a node created in
    the given temporary material's tree) over obj's UV map `uv_map` (default: the active one).

    Returns (pixels (height, width, 3) float32, coverage (height, width) bool, seconds), row 0
    at the bottom. `displacement(nodes, links)`, if given, returns a displacement vector for
    Cycles' true displacement of the surface during the bake. Texels the bake did not write
    are marked uncovered: the image is cleared to alpha 0 and the bake writes alpha 1.
    rgba: the pixels are the baked (height, width, 4) RGBA (read into `out` if given).
    device: scene.cycles.device for the bake ("GPU": the devices cycles_device.selected chose).
    """
    import bpy

    _check_target(obj, uv_map)
    image = bpy.data.images.new("surfgrad_bake", width, height, alpha=True, float_buffer=True)
    # Before the pixels are written: a colour-space change reloads the buffer.
    image.colorspace_settings.is_data = True
    try:
        # A cleared float image is (0, 0, 0, 0); baked texels get alpha 1.
        image.pixels.foreach_set(np.zeros(width * height * 4, dtype=np.float32))
        seconds = _bake_into(obj, build, image, uv_map, displacement, log, device)
        px = np.empty((height, width, 4), dtype=np.float32) if out is None else out
        image.pixels.foreach_get(px.reshape(-1))        # straight into the buffer
        return _result(px, rgba) + (seconds,)
    finally:
        bpy.data.images.remove(image)


def _bake_into(obj, build, image, uv_map, displacement, log, device="CPU"):
    """Bake the vector of `build` on obj into `image` (plain or UDIM); returns the seconds."""
    import bpy

    context = bpy.context
    scene = context.scene
    material = new_material("surfgrad_bake")
    try:
        tree = material.node_tree
        nodes, links = tree.nodes, tree.links
        nodes.clear()
        g = Graph(nodes, links)
        # Cycles' true displacement: the vector from `displacement` moves the surface.
        g.emission_material(build(nodes, links),
                            displacement(nodes, links) if displacement is not None else None)
        # As the operators do for the object they add groups for: the precise route far out
        # (never switched off here: a build may want it on near the origin too).
        if needs_precise_far(obj):
            set_precise_far(tree, True)
        if displacement is not None:
            if hasattr(material, "displacement_method"):
                material.displacement_method = "DISPLACEMENT"
            else:                                           # before 4.x's move
                material.cycles.displacement_method = "DISPLACEMENT"
        target = g.node("ShaderNodeTexImage")
        target.image = image
        nodes.active = target
        with restored(scene, SCENE_SETTINGS), _selection_kept(context), \
                visible_for_bake(obj, context.view_layer), own_materials(context.view_layer), \
                _temporary_material(obj, material):
            cy = exact_cycles(scene, device)
            cy.texture_limit_render = NO_TEXTURE_LIMIT
            without_render_effects(scene)
            cy.sample_clamp_direct = 0.0
            cy.sample_clamp_indirect = 0.0
            cy.bake_type = "EMIT"
            bake = scene.render.bake
            bake.margin = 0
            bake.use_clear = True
            bake.target = "IMAGE_TEXTURES"
            bake.use_selected_to_active = False
            for o in context.view_layer.objects:
                o.select_set(False)
            obj.select_set(True)
            context.view_layer.objects.active = obj
            t0 = time.perf_counter()
            kwargs = {"type": "EMIT", "margin": 0, "use_clear": False}
            if uv_map is not None:
                kwargs["uv_layer"] = uv_map
            with quiet_bake(), native_call(), uv_active(obj.data, uv_map):
                result = bpy.ops.object.bake(**kwargs)      # (a stop need not wait for it)
            seconds = time.perf_counter() - t0
            if result != {"FINISHED"}:
                from ..addon.cancel_reason import cancelled_text
                raise BakeCancelled("Cycles: " + cancelled_text(obj, result))
        if log:
            log(f"baked {obj.name} {image.size[0]}x{image.size[1]} in {seconds:.2f} s")
        return seconds
    finally:
        bpy.data.materials.remove(material)
