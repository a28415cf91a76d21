"""Bake a method's node groups with Cycles and compare them texel by texel with the reference.

    python -m surfgrad_addon compare --blend FILE --object NAME --method METHOD \\
        --resolution N --json OUT [--uv-map NAME] [--image PATH] [--variant V] [--tiles N ...]

Without --blend the procedural test scene (blender/scenes.py) is used. The bake and the
reference see the same mesh (the evaluated object with the normals Cycles shades with,
MikkTSpace tangents on its triangles), the same images (their pixels as Cycles reads them) and
the same parameters, and the same texels: the reference gives each texel the triangle the bake
gives it (the last one covering it), so contested texels of overlapping UV islands are compared
too, counted and named in a warning. Angular error is measured over every texel both cover; a
texel is excluded only for a stated reason (EXCLUSION_REASONS: within float32 rounding of a
triangle edge, covered by one side only, a shading normal facing away from its triangle),
counted per reason in the report and drawn in its own colour in the heat map. The mesh is the
one Cycles renders (modifiers at their render settings: render_mesh.py). A UV layout on UDIM
tiles is baked into a tiled image and compared tile by tile; one with faces beyond the UDIM
grid (tiling UVs) on the 0..1 square a plain image bakes, or on the tiles asked for, with the
faces outside counted.
"""

import errno
import json
import os
import sys
import time
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import reference as R
from ..addon.bake_console import heartbeat
from ..addon.bake_request import folder_problem, name_problem, zero_scale_problem
from ..addon.bake_target import bake_target_problem
from ..addon.bake_uvs import long_name_problem, not_rendered_problem, read_as_baked
from ..addon.cache_files import unread_cache_problems
from ..addon.exit_codes import BakeFailed
from ..addon.image_channels import path_channel_problem, running_facts
from ..addon import unrealized_instances as UI
from ..addon.memory_limit import (BYTES_PER_FURTHER_TILE_TEXEL, BYTES_PER_TEXEL,
                                  memory_problem)
from ..addon.normal_bake import (blend_relative_problem, cycles_problem, resolution_problem,
                                 whole_tile_move)
from ..addon.number_options import COMPARE_RESOLUTION_RANGE
from ..addon.object_names import missing_object_problem
from ..addon.precise_bake import precise_far
from ..addon.sculpt_normals import own_normals
from ..reference import image_sampling as IS
from ..reference import uv_overlap as UV
from ..reference import methods as M
from ..reference.agreement import angle_deg  # noqa: F401 (the bench and far import it here)
from . import bake as B
from . import compare_settings as CS
from .mesh_data import MeshDataError, mesh_arrays_from_object
from .no_area import (all_degenerate_problem, collapsed_problem, degenerate_triangles,
                      degenerate_warning, without_degenerate, world_positions)
from . import scale_limits
from .methods import (HEIGHT_IMAGE_SIZE, METHODS, NORMAL_IMAGE_SIZE, PARALLAX_SCALE, resolve_sg,
                      unavailable_reason)
from .flat_welds import unsure_problem, unsure_warning
from .facing_exclusions import backfacing_warning, grazing_warning
from .heat_map import write_heat_map
from .kernel_warm_up import load_kernels
# EXCLUSION_REASONS and CONTESTED (texel_report's) named here too for the tests that read them
# as compare's (tests/test_bake_compare.py, tests/test_real_assets.py).
from .texel_report import CONTESTED, EXCLUSION_REASONS  # noqa: F401
from .texel_report import ErrorImage, compare_tile, merge, sparse_warning

DETAIL_UV = "Detail"


RESOLUTION_RANGE = COMPARE_RESOLUTION_RANGE          # (8, 8192): addon/number_options.py


class CompareError(ValueError):
    """Bad input for a comparison: the message names the thing and the fix."""


@dataclass
class Inputs:
    """Everything a method needs, shared by its node graph and its reference."""
    obj: object
    uv_map: str
    detail_uv: str
    images: dict = field(default_factory=dict)      # name -> (numpy pixels (H, W, C), bpy image)
    variant: str = "hq"
    projector: object = None                         # a temporary decal projector (an empty)
    modifier: object = None                          # a temporary SG Displace modifier
    parallax_scale: float = None                     # None: methods.PARALLAX_SCALE
    relief_scale: float = None                       # None: 1 (method_registry.relief)
    read: set = field(default_factory=set)           # the images the reference read

    def pixels(self, name):
        self.read.add(name)
        return self.images[name][0]

    def bpy_image(self, name):
        return self.images[name][1]


# Inputs -----------------------------------------------------------------------------------------

def bpy_float_image(name, pixels):
    import bpy
    px = np.asarray(pixels, dtype=np.float32)
    if px.ndim == 2:
        px = np.repeat(px[..., None], 3, axis=-1)
    h, w = px.shape[:2]
    if px.shape[2] == 3:
        px = np.concatenate([px, np.ones((h, w, 1), np.float32)], axis=-1)
    img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    try:
        img.colorspace_settings.is_data = True
        img.pixels.foreach_set(px.ravel())
        img.pack()
    except BaseException:               # (Ctrl-C in a session: no half-made image left)
        bpy.data.images.remove(img)
        raise
    return img


def _load_image(path):
    """An image file as Cycles will read it (Non-Color), and its pixels for the reference."""
    import bpy
    path = Path(path)
    if path.is_dir():
        raise CompareError(f"image {str(path)!r} is a folder, not an image file; give an "
                           f"image file to --image")
    if not path.is_file():
        raise CompareError(f"image {str(path)!r} does not exist; give an existing file to "
                           f"--image")
    # Channels Blender loads undefined or not as the file's colours: the reference would read
    # one load's pixels and Cycles another's (a correct group reported tens of degrees off).
    problem = path_channel_problem(f"image {str(path)!r}", path, running_facts())
    if problem:
        raise CompareError(problem)
    try:
        img = bpy.data.images.load(str(path.resolve()), check_existing=False)
    except RuntimeError as err:
        raise CompareError(f"image {str(path)!r} could not be read ({err})") from err
    try:        # (Ctrl-C while a large map is read, 2 s at 4096^2, left it in bpy.data)
        return _read_loaded(img, path)
    except BaseException:
        bpy.data.images.remove(img)
        raise


def _read_loaded(img, path):
    img.colorspace_settings.is_data = True
    w, h = img.size
    if w == 0 or h == 0:
        raise CompareError(f"image {str(path)!r} is empty or unreadable; give an image file "
                           f"Blender can open (PNG, EXR, ...)")
    px = np.empty(w * h * img.channels, dtype=np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, img.channels).astype(np.float64)
    problem = R.input_checks.pixels_problem(f"image {str(path)!r}", px)
    if problem:
        raise CompareError(problem)
    return px[..., :3] if img.channels >= 3 else px[..., 0], img


def prepare_inputs(obj, uv_map=None, image=None, variant="hq"):
    import bpy
    problem = bake_target_problem(obj, bpy.context.view_layer) or \
        zero_scale_problem(obj, obj.matrix_world)      # the same words as the bake's check
    if problem:
        raise CompareError(problem)
    names = [uv.name for uv in obj.data.uv_layers]
    if not names:
        raise CompareError(f"object {obj.name!r} has no UV map; add one (UV > Unwrap)")
    if uv_map is None:
        active = [uv.name for uv in obj.data.uv_layers if uv.active_render]
        uv_map = active[0] if active else names[0]
    elif uv_map not in names:
        raise CompareError(f"object {obj.name!r} has no UV map named {uv_map!r}; it has "
                           f"{names}")
    problem = long_name_problem(obj.name, uv_map)
    if problem:
        raise CompareError(problem)
    detail = DETAIL_UV if DETAIL_UV in names else uv_map
    inp = Inputs(obj=obj, uv_map=uv_map, detail_uv=detail, variant=variant)
    try:
        _make_images(inp, image)
    except BaseException:
        # A failure or Ctrl-C (KeyboardInterrupt in a TD's session) while the images were
        # made left those made so far in bpy.data, one more set per interrupted compare.
        remove_images(inp)
        raise
    return inp


def remove_images(inp):
    """Remove the images prepare_inputs made (each once)."""
    import bpy
    images, inp.images = list(inp.images.values()), {}
    for _, img in images:
        bpy.data.images.remove(img)


def _make_images(inp, image):
    if isinstance(image, np.ndarray):       # pixels given directly (the stability suite)
        # uint8 / uint16 (a PNG as imageio loads it) as Blender reads the file: both sides
        # took 0..255 before, agreeing about a map no file holds.
        image = R.image_sampling.image_values(image)
        inp.images["normal"] = (image[..., :3].astype(np.float32).astype(np.float64),
                                bpy_float_image("sg_normal", image))
    elif image is not None:
        px, img = _load_image(image)
        inp.images["normal"] = (px, img)
    else:
        px = R.images.hemisphere_tile_image(NORMAL_IMAGE_SIZE)
        inp.images["normal"] = (px.astype(np.float32).astype(np.float64),
                                bpy_float_image("sg_normal", px))
    px = R.images.hemisphere_tile_image(NORMAL_IMAGE_SIZE, tiles=8, radius=0.6)
    inp.images["detail"] = (px.astype(np.float32).astype(np.float64),
                            bpy_float_image("sg_detail", px))
    h = R.images.wave_height_image(HEIGHT_IMAGE_SIZE)
    inp.images["height"] = (h.astype(np.float32).astype(np.float64),
                            bpy_float_image("sg_height", h))


# The comparison -----------------------------------------------------------------------------------

def unread_image_problem(method, image):
    """None, or why --image is refused for `method`: it reads no normal map (a height map,
    noise), so the image would be taken, dropped, and the procedural comparison pass, exit 0.
    Said before the bake (and before the file opens), from what the registry says the method
    reads (tests/test_faults_reads53a.py and _trust53a.py hold that to what its reference and
    graph read)."""
    if image is None or method not in METHODS or "normal" in METHODS[method].reads:
        return None
    takes = ", ".join(sorted(k for k, m in METHODS.items() if "normal" in m.reads
                             and m.unavailable_reason() is None))
    return (f"method {method!r} reads no normal map, so --image would change nothing: leave "
            f"--image out, or pick a method that reads one ({takes})")


def compare_object(obj, method, resolution, uv_map=None, image=None, variant=None, log=print,
                   tiles=None, device="CPU", settings=None):
    """Bake `method` on obj and compare with the reference (variant None: "hq" for the
    height maps, the method's first otherwise, e.g. the box decal). `tiles`: the UDIM tiles
    to bake and compare (None: what target_tiles picks, as Blender's bake would fill).
    device: scene.cycles.device for the bake ("GPU" inside cycles_device.selected).
    settings: {parameter: value} and "directx": True, on both sides (compare_settings.py).
    Returns (report dict, per-texel error image (H, W) with NaN where not compared)."""
    if method not in METHODS:
        raise CompareError(f"method {method!r} is not available; use one of "
                           f"{sorted(METHODS)}")
    problem = resolution_problem(resolution, *RESOLUTION_RANGE) or cycles_problem()
    if problem:
        raise CompareError(problem)
    reason = unavailable_reason(method)
    if reason is not None:
        raise CompareError(f"method {method!r} is not available in this Blender: {reason}")
    m = METHODS[method]
    if variant is None:
        variant = "hq" if "hq" in m.variants else m.variants[0]
    if variant not in m.variants and len(m.variants) > 1:
        raise CompareError(f"method {method!r} has no variant {variant!r}; use one of "
                           f"{list(m.variants)}")
    if variant not in m.variants:
        # A method of one variant took any --variant and compared its own, exit 0 (a
        # `decal-overwrite --variant sphere` compared the box decal).
        takes = sorted(k for k, other in METHODS.items() if len(other.variants) > 1)
        raise CompareError(f"method {method!r} has no variants, so --variant {variant!r} would "
                           f"change nothing: leave --variant out (it is for "
                           f"{', '.join(takes)})")
    problem = unread_image_problem(method, image)
    if problem:
        raise CompareError(problem)
    try:
        values, directx = CS.split(m, settings)
    except CS.SettingsError as err:
        raise CompareError(str(err)) from None
    m = m.at(**values)
    problem = (scale_limits.small_object_problem(obj, method)   # before any image is made
               or scale_limits.noise_reach_problem(obj, method, dict(m.values)))
    if problem:
        raise CompareError(problem)
    inp = prepare_inputs(obj, uv_map, image, variant)
    try:      # (from here: a note's log that raises, Ctrl-C, all leave no image)
        if directx:
            CS.turn_green(inp, m)
        inp.parallax_scale, depth_note = scale_limits.parallax_depth(obj, PARALLAX_SCALE)
        m, inp.relief_scale = scale_limits.scaled_relief(obj, m)
        # (After the relief is scaled: the graph binds the method's values as the reference does.)
        graph = CS.with_directx_on(m.graph) if directx else m.graph
        notes = [depth_note] if depth_note and m.reference is METHODS["parallax"].reference else []
        if inp.relief_scale < 1.0:
            notes.append(f"relief for the comparison: x {inp.relief_scale:.3g}, scaled to the "
                         f"half-size of {obj.name!r} (a scaled copy of the unit object)")
        for note in notes:
            if log:
                log(f"note: {note}")
        # Far out: a second user keeps the mesh in object space (before the mesh is read).
        # A GPU bake's Linear lookups use the texture unit's 8-bit weights: so does its
        # reference (without, every normal-map method is ~0.2 degrees p99 off on the GPU).
        gpu = device == "GPU"
        with own_normals(obj), m.scene(obj, inp), precise_far(obj, log), \
                (IS.gpu_texture_filter() if gpu else nullcontext()):
            try:
                report, heat = compare_graph(inp, obj, graph, m.reference, resolution, log=log,
                                             tiles=tiles, device=device, spread=m.spread)
            except CS.SettingsError as err:     # DirectX asked of a graph without the switch
                raise CompareError(str(err)) from None
        report["reference_texture_filter"] = (
            f"GPU texture unit ({IS.GPU_FILTER_WEIGHT_BITS}-bit weights)" if gpu else "exact")
        limit = scale_limits.float32_coordinate_warning(obj, method, NORMAL_IMAGE_SIZE)
        unbaked = UI.may_instance(obj) and UI.compare_warning(
            read_as_baked(obj, UI.read_instances), obj)
        # Warned, not refused: bake and reference read the same stored mesh, so the figures
        # hold for it; only the shape is not the one the asset renders with its cache.
        stale = [f"{p}; compared: the stored mesh" for p in unread_cache_problems(obj)]
        for w in (limit, unbaked, *stale):
            if w:
                report["warnings"].append(w)
                if log:
                    log(f"warning: {w}")
        report["notes"] = notes
        report["method"] = method
        report["variant"] = inp.variant if len(m.variants) > 1 else None
        if settings:
            report["settings"] = dict(settings)
        return report, heat
    finally:
        remove_images(inp)


def asked_tiles(tiles):
    """`--tiles` / `tiles=` as bake-normal-map takes them: numbers, or text such as
    "1001-1004" or "1001,1003" (each word of the command line), into sorted tile numbers or
    None. Before, `--tiles 1001-1002` was argparse's "invalid int value" and the API's
    tiles="1001-1002" read each character as a tile ("tile 1")."""
    if isinstance(tiles, (list, tuple)) and any(isinstance(t, str) for t in tiles):
        tiles = ",".join(str(t) for t in tiles)
    try:
        return R.tiles.parse_tiles(tiles)
    except ValueError as ex:
        raise CompareError(str(ex)) from None


def target_tiles(mesh, uv_map, name, tiles=None):
    """What a bake of `uv_map` fills, as Blender's bake does it: (tiles, faces outside, note).
    [1001] is the
    plain 0..1 image. Asked-for `tiles`: those UDIM tiles. Otherwise a layout whose every face
    lies on the UDIM grid (u 0..10, v 0..100) is a UDIM layout: every tile its faces cover; a
    layout with faces beyond it (tiling UVs, negative tiles) is baked as a plain image bakes
    it, the 0..1 square. Faces outside: how many lie (partly) outside the target, whose parts
    there a bake does not write (no wrap) and the comparison cannot see; `note` says so, or
    is None.
    Raises CompareError when nothing lies inside the target."""
    uv = mesh.uv(uv_map)
    faces = mesh.triangle_faces if mesh.triangle_faces is not None else \
        np.arange(len(mesh.triangles))
    lo, hi = uv.reshape(-1, 2).min(0), uv.reshape(-1, 2).max(0)
    span = f"u {lo[0]:.3g}..{hi[0]:.3g}, v {lo[1]:.3g}..{hi[1]:.3g}"
    with_uvs = R.tiles.tiles_with_uvs(uv)
    tiles = asked_tiles(tiles)
    if tiles:
        bad = [t for t in tiles if not R.tiles.UDIM_FIRST <= t <= R.tiles.UDIM_LAST]
        if bad:
            raise CompareError(f"tile {bad[0]}: UDIM tiles are numbered {R.tiles.UDIM_FIRST} "
                               f"to {R.tiles.UDIM_LAST}")
        empty = [t for t in tiles if t not in with_uvs]
        if empty:
            raise CompareError(f"tile(s) {', '.join(map(str, empty))} hold no UVs of UV map "
                               f"{uv_map!r} of {name!r} (its UVs span {span}, on tiles "
                               f"{', '.join(map(str, with_uvs)) or 'none'}); ask for tiles "
                               f"that hold UVs")
        where = f"UDIM tile(s) {', '.join(map(str, tiles))}"
    elif not R.tiles.triangles_outside(uv).any() and with_uvs:
        tiles, where = with_uvs, None
    else:
        tiles, where = [R.tiles.UDIM_FIRST], "the 0..1 UV square (a plain image)"
        if R.tiles.UDIM_FIRST not in with_uvs:
            move = whole_tile_move(uv)
            fix = (f"{move}, or ask for the UDIM tiles to compare (--tiles)" if move else
                   "move the islands into the UV square (UV > Pack Islands), onto UDIM tiles, "
                   "or ask for the UDIM tiles to compare (--tiles)")
            raise CompareError(
                f"UV map {uv_map!r} of {name!r} puts nothing inside the bake target: its UVs "
                f"span {span}, with faces outside the UDIM tiles ({R.tiles.UDIM_SPAN}), so a bake "
                f"fills the 0..1 square as a plain image does, and nothing lies there (a bake "
                f"does not wrap); {fix}")
    outside = np.unique(faces[R.tiles.triangles_outside(uv, tiles)])
    note = None
    if len(outside) and where:
        n_faces = len(np.unique(faces))
        note = (f"UV map {uv_map!r} of {mesh.name!r}: {len(outside)} of {n_faces} faces lie "
                f"(partly) outside {where} (its UVs span {span}); a bake writes only what "
                f"lies inside (no wrap), so only that is compared")
    return tiles, len(outside), note


def _stacked_pairs(mesh, uv_map, td, contested, faces):
    """Every pair of faces on a contested texel: the rasteriser keeps a texel's last two
    claimants alone, so a box whose six sides share the UV square was named as one pair of
    six faces ('(1 pairs): 4/5'); the faces under those two are found by their UV triangles
    (uv_overlap.claimants) at the contested texels, on a grid of at most STACK_GRID^2 (a
    heavily mirrored 2048^2 compare paid 6.5 s at full size, 0.15 s so; a stack smaller than
    a texel of that grid keeps its top pair alone)."""
    if not contested.any():
        return set()
    size = min(td.width, td.height, STACK_GRID)
    y, x = np.nonzero(contested)
    coarse = np.unique((y * size // td.height) * size + x * size // td.width)
    texel, tri = UV.claimants(mesh.uv(uv_map), size, coarse, td.uv_offset)
    if not len(texel):
        return set()
    stacks = np.unique(np.stack([texel, faces[tri]], axis=1), axis=0)
    starts = np.flatnonzero(np.r_[True, stacks[1:, 0] != stacks[:-1, 0]])
    ends = np.r_[starts[1:], len(stacks)]
    # Stacks of three or more alone: a two-deep stack's pair is the winner and the other
    # claimant, named at full size already (the grid's centres, between those texels'
    # centres, would add pairs that touch at no texel centre of the compare).
    seen = {tuple(stacks[s:e, 1].tolist()) for s, e in zip(starts, ends) if e - s > 2}
    return {(x, y) for stack in seen for i, x in enumerate(stack) for y in stack[i + 1:]}


STACK_GRID = 256


def overlap_warning(mesh, uv_map, td_list):
    """A warning naming the faces of overlapping UV islands (a few, with the count), or None."""
    pairs = set()
    texels = 0
    for td in td_list:
        c = td.contested & (td.other_triangle >= 0)
        texels += int(td.contested.sum())
        faces = mesh.triangle_faces if mesh.triangle_faces is not None else \
            np.arange(len(mesh.triangles))
        a, b = faces[td.triangle[c]], faces[td.other_triangle[c]]
        pairs |= {(int(min(x, y)), int(max(x, y))) for x, y in zip(a, b) if x != y}
        pairs |= _stacked_pairs(mesh, uv_map, td, c, faces)
    if not texels:
        return None
    shown = ", ".join(f"{x}/{y}" for x, y in sorted(pairs)[:6])
    more = f" and {len(pairs) - 6} more" if len(pairs) > 6 else ""
    return (f"UV map {uv_map!r} of {mesh.name!r}: {texels} texels are claimed by more than one "
            f"face (overlapping UV islands, e.g. mirrored halves stacked on each other); a bake "
            f"keeps only the face last in mesh order there (so does the reference). "
            f"Overlapping faces ({len(pairs)} pairs): {shown}{more}.")


def compare_graph(inp, obj, graph, reference, resolution, log=None, tiles=None, device="CPU",
                  spread=None):
    """Bake graph(inp, nodes, links) on obj and compare with reference(inp, td): the report
    and the per-texel error image (an ErrorImage; tiles side by side in tile order). spread:
    a view-dependent method's spread(inp, td) (its "grazing" texels are left out)."""
    method = getattr(graph, "__name__", "graph")
    try:
        mesh = mesh_arrays_from_object(obj)
    except MeshDataError as err:
        raise CompareError(str(err)) from err
    if inp.uv_map not in mesh.uv_maps:
        raise CompareError(not_rendered_problem(obj.name, inp.uv_map, mesh.uv_maps, obj))
    if inp.detail_uv not in mesh.uv_maps:
        # A modifier removes it in renders: the detail layer reads the UV map, as on a mesh
        # without one (before: a KeyError's text, exit 2).
        inp.detail_uv = inp.uv_map
    world = world_positions(mesh)
    problem = collapsed_problem(mesh, world, obj, inp.uv_map)
    if problem:
        raise CompareError(problem)
    tiles, faces_outside, tile_note = target_tiles(mesh, inp.uv_map, obj.name, tiles)
    facts = B.running_line()
    degenerate = degenerate_triangles(mesh, world, facts)
    problem = all_degenerate_problem(obj, degenerate)
    if problem:
        raise CompareError(problem)
    degenerate_texels = 0
    unsure = mesh.unsure_welds.get(inp.uv_map, np.zeros(len(mesh.triangles), dtype=bool))
    unsure_texels = unsure_covered = 0

    def rasterized(number):
        """(TexelData, seconds) of one tile: reference time. After the bake, not before it:
        Cycles' freed buffers are pages this process already holds, where fresh ones cost
        more than the scan itself on a virtual machine (a first 128 MB np.full 0.35 s, a
        second 0.02 s), and the peak memory is the bake's. Not in a thread beside the bake:
        numba compiling its kernels (a cold cache) while Cycles bakes crashed Blender 4.5
        (segfault, 1 run in 4 or 5)."""
        t0 = time.perf_counter()
        td = R.rasterize(mesh, inp.uv_map, resolution, resolution, facts=facts,
                         uv_offset=R.tiles.tile_uv_offset(number), as_baked=True)
        return td, time.perf_counter() - t0

    def build(nodes, links):
        out = graph(inp, nodes, links)
        # Graphs return a surface gradient to resolve against the shading normal, or (post-
        # resolve) an already resolved normal.
        return out if out.name == "Normal" else resolve_sg(nodes, links, out)
    # Compiled kernels load once per process (like an import), reported apart from the timing.
    load_seconds = load_kernels(mesh, inp.uv_map, lambda block: M.resolve(reference(inp, block)),
                                facts)
    problem = compare_memory_problem(resolution, len(tiles))
    if problem:                         # after the kernels load: their memory is counted
        raise CompareError(problem)
    if tiles == [R.tiles.UDIM_FIRST]:
        # RGBA as read back (no copy): the comparison reads channels 0-2.
        pixels, covered, bake_seconds = B.bake_vector_in_pieces(
            obj, build, resolution, resolution, uv_map=inp.uv_map, rgba=True, device=device)
        baked_tiles = {tiles[0]: (pixels, covered)}
    else:
        baked_tiles, bake_seconds = B.bake_vector_tiles(obj, build, resolution, resolution,
                                                        tiles, uv_map=inp.uv_map, device=device)
    reference_seconds = 0.0
    baked_any = False
    tile_reports, heats, tds = [], [], []
    for number in tiles:
        td, seconds = rasterized(number)
        reference_seconds += seconds
        pixels, covered = baked_tiles.pop(number)
        baked_any = baked_any or bool(covered.any())
        if not td.covered.any() and not covered.any():
            continue            # the tile only touches a triangle's bounding box
        tds.append(td)
        kept = without_degenerate(td, covered, degenerate)
        if kept is not covered:
            degenerate_texels += int(np.count_nonzero(covered & ~kept))
            covered = kept
        kept = without_degenerate(td, covered, unsure)      # flat_welds.py
        if kept is not covered:
            unsure_texels += int(np.count_nonzero(covered & ~kept))
            covered = kept
        unsure_covered += int(np.count_nonzero(covered))
        r, heat, seconds = compare_tile(td, lambda block: M.resolve(reference(inp, block)),
                                        pixels, covered, spread and (lambda b: spread(inp, b)))
        reference_seconds += seconds
        r["tile"] = number
        tile_reports.append(r)
        heats.append(heat)
    if not tile_reports:
        raise CompareError(f"UV map {inp.uv_map!r} of {obj.name!r} covers no texel centre at "
                           f"{resolution}^2 (its islands are thinner than a texel or outside "
                           f"the UV square); raise --resolution or unwrap again")
    problem = unsure_problem(obj.name, inp.uv_map, unsure_texels, unsure_covered, facts.line)
    if problem:
        raise CompareError(problem)
    report = merge(tile_reports)
    if not baked_any and report["excluded"]["outside"]:
        # Not "raise --resolution": Cycles left the object out (a setting unknown to
        # visible_for_bake and without_render_effects), a failed bake.
        raise BakeFailed(f"Cycles baked no texel of {obj.name!r}, whose UVs cover "
                         f"{sum(int(td.covered.sum()) for td in tds)} at {resolution}^2: it "
                         f"left the object out of its render (a setting of the file that the "
                         f"bake does not lift); nothing was compared")
    if report["texels_compared"] == 0:
        raise CompareError(f"no texel of {obj.name!r} could be compared at {resolution}^2 "
                           f"(excluded: {report['excluded']}); raise --resolution")
    warnings = [w for w in [tile_note, overlap_warning(mesh, inp.uv_map, tds),
                            backfacing_warning(mesh, report),
                            grazing_warning(mesh, report),
                            degenerate_warning(mesh, degenerate, degenerate_texels),
                            unsure_warning(mesh, unsure, unsure_texels, facts.line),
                            sparse_warning(obj.name, report["texels_compared"], resolution,
                                           RESOLUTION_RANGE[1])] if w]
    for w in warnings:
        if log:
            log(f"warning: {w}")
    report.update({"method": method, "object": obj.name, "uv_map": inp.uv_map,
                   "resolution": resolution, "bake_seconds": bake_seconds,
                   "faces_outside": faces_outside,
                   "reference_seconds": reference_seconds, "warnings": warnings,
                   "compiled_kernels": R.compiled.enabled(),
                   "compiled_load_seconds": load_seconds,
                   "tiles": tile_reports if len(tile_reports) > 1 or tiles != [1001] else None})
    if len(heats) == 1:
        return report, heats[0]             # one image: no copy of it
    error = np.concatenate(heats, axis=1)
    reasons = np.concatenate([h.reasons for h in heats], axis=1)
    return report, ErrorImage(error, reasons)


# What a compare holds per texel beyond the bake (the read-back pixels, coverage, reference
# and error images), measured on 5.2.3: from 2048^2 to 4096^2 its peak virtual size grew by 26
# bytes a texel and its peak resident size by 23 (a normal-map compare, one tile); rounded down.
COMPARE_BYTES_PER_TEXEL = 20


def compare_memory_problem(resolution, tiles):
    """None, or the problem when a compare of `tiles` tiles at resolution^2 cannot fit this
    process's address-space limit or the machine's memory (memory_limit.py). Before: under
    `ulimit -v` it crashed inside Blender (exit 139, no line), or ended in a raw MemoryError
    or OpenBLAS traceback. One tile bakes in pieces of at most B.PIECE_TEXELS^2 (the bake's
    bytes per texel counted for a piece); several tiles bake whole."""
    texels = int(resolution) ** 2
    if tiles > 1:
        bake = texels * (BYTES_PER_TEXEL + BYTES_PER_FURTHER_TILE_TEXEL * (tiles - 1))
    else:
        bake = min(texels, B.PIECE_TEXELS ** 2) * BYTES_PER_TEXEL
    return memory_problem(bake + texels * tiles * COMPARE_BYTES_PER_TEXEL,
                          f"a {resolution}x{resolution} compare of {tiles} tile(s)", "compare")


def compare(obj, method, resolution=64, variant=None, uv_map=None, image=None,
            with_heat_map=False, tiles=None, device="CPU"):
    """The public comparison (surfgrad_addon.harness.api.compare): compare_object, quiet, with
    the node groups the bake added removed again (the file is the user's)."""
    import bpy
    before = set(bpy.data.node_groups)
    with _file_groups_aside():
        try:
            report, heat = compare_object(obj, method, R.input_checks.plain_number(resolution),
                                          uv_map=uv_map, image=image, variant=variant,
                                          log=lambda *_: None, tiles=tiles, device=device)
        finally:
            # The groups the bake needed go again (users first).
            for tree in [t for t in bpy.data.node_groups if t not in before][::-1]:
                bpy.data.node_groups.remove(tree)
    return (report, heat) if with_heat_map else report


@contextmanager
def _file_groups_aside():
    """The file's own groups under surfgrad's names renamed aside for the duration, so the
    comparison builds and judges surfgrad's groups: reused, an older surfgrad's was rebuilt in
    place (the user's file changed, an edit inside it lost) and one the artist edited was
    judged (a muted node inside SG Normal Map: the method 90 degrees off). Their nodes keep
    using them; the names come back after."""
    import bpy
    aside = [(g, g.name) for g in bpy.data.node_groups
             if g.library is None and g.name.startswith(("SG ", ".SG "))]
    for i, (group, _) in enumerate(aside):
        group.name = f".surfgrad compare aside {i}"
    try:
        yield
    finally:
        for group, name in aside:
            group.name = name


def check_output_path(path, overwrite, what="output"):
    """Refuse, before anything is baked, an output path that cannot be written: a folder,
    an existing file without --overwrite, a parent that is a file or not writable."""
    problem = blend_relative_problem(path, what) or name_problem(path, what)
    if problem:                 # (a name too long: Path.is_dir raised a raw OSError)
        raise CompareError(problem)
    p = Path(path)
    if p.is_dir():
        raise CompareError(f"{what} {str(p)!r} is a folder; give a file path (e.g. "
                           f"{str(p / 'report.json')!r})")
    # lexists: a symbolic link to a file not there yet is a file the report would replace
    # too (exists() follows it: the compare ran in full, then said the report 'appeared
    # while this compare ran', rt57a).
    if os.path.lexists(p) and not overwrite:
        raise CompareError(f"{p} exists; pass --overwrite to replace it")
    if p.exists() and not p.is_file():
        raise CompareError(f"{what} {str(p)!r} is not a regular file; give a file path")
    if p.is_symlink() and not p.exists() and not Path(os.path.realpath(p)).parent.is_dir():
        # (the report is written through the link: it failed after the compare, as "the disk
        # may be full")
        raise CompareError(f"cannot write {what} {str(p)!r}: it is a symbolic link to "
                           f"{os.path.realpath(p)!r}, in a folder that does not exist; make "
                           f"that folder, or give another path")
    parent = p.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise CompareError(f"cannot write {what} {str(p)!r}: {str(parent)!r} is a file, not a "
                           f"folder; give a path inside a folder")
    # tried with a probe file: os.access says yes to root in /sys or /proc, and a dangling
    # link on the way stopped the folder's mkdir with a bare "[Errno 17] File exists"
    problem = folder_problem(p.parent)
    if problem:
        raise CompareError(f"cannot write {what} {str(p)!r}: {problem}")


def _not_an_input(path, *inputs):
    """Refuse an output that is one of the files the compare reads (--blend, --image): with
    --overwrite, `--json scene.blend` replaced the user's .blend with the report, exit 0."""
    for source in inputs:
        if source and path.exists() and Path(source).exists() and os.path.samefile(path, source):
            raise CompareError(f"output {str(path)!r} is the file {str(source)!r} this compare "
                               f"reads; give another --json")


def _write_report(json_out, report, heat_path, heat, overwrite):
    """The JSON and its heat map, both or neither: a stop (Ctrl-C) waits for the pair and
    then removes it, and the folders made for it (interrupts.committing, placed). Without
    overwrite a file that appeared since the check (another compare writing the same report)
    is left as it is and this one fails: before, the second compare replaced the first's
    JSON, met its heat map, then removed both as its own ("the disk may be full"), and the
    first had exited 0 with nothing left."""
    from ..addon import interrupts
    with interrupts.committing():
        made = [d for d in (json_out.parent, *json_out.parent.parents) if not d.exists()]
        for d in reversed(made):
            d.mkdir()
            interrupts.placed(d)
        ours = []                        # what this compare wrote (and removes on a failure)
        try:
            with open(json_out, "w" if overwrite else "x") as f:
                ours.append(json_out)
                interrupts.placed(json_out)
                f.write(json.dumps(report, indent=2))
            if not overwrite and os.path.lexists(heat_path):
                raise FileExistsError(errno.EEXIST, "exists", str(heat_path))
            ours.append(heat_path)
            interrupts.placed(heat_path)
            write_heat_map(heat_path, heat, overwrite)
        except OSError as err:           # a full disk: no cut-off file left as the report
            for path in (*ours, *made):
                if path.is_file():
                    path.unlink()
                elif path.is_dir() and not any(path.iterdir()):
                    path.rmdir()
            if isinstance(err, FileExistsError):
                raise BakeFailed(f"{err.filename!r} appeared while this compare ran (another "
                                 f"compare writing the same report?) and is left as it is: "
                                 f"give another --json, or pass --overwrite") from None
            raise BakeFailed(f"could not write {str(json_out)!r} and its heat map ({err}): "
                             f"free space in {str(json_out.parent)!r} (the disk may be full) "
                             f"or check the folder's permissions, and compare again") from None


def run(blend, object_name, method, resolution, json_out, uv_map=None, image=None,
        variant=None, overwrite=False, log=print, from_open_file=False, tiles=None,
        cycles_device="CPU"):
    """The command: load, bake, compare, write the JSON and the heat map, print a summary.
    cycles_device: CPU, CUDA or OPTIX (cycles_device.py; refused before the load without one)."""
    import bpy
    from . import cycles_device as D
    if str(json_out).endswith(("/", os.sep)):
        # Path() drops the slash: `--json reports/` wrote a file `reports` and `reports_error.png`.
        raise CompareError(f"--json {str(json_out)!r} ends in '/', a folder: give a file name "
                           f"in it (e.g. {os.path.join(json_out, 'report.json')!r})")
    json_out = Path(json_out)
    heat_path = json_out.with_name(json_out.stem + "_error.png")
    tiles = asked_tiles(tiles)              # refused before the file is opened
    problem = unread_image_problem(method, image)
    if problem:
        raise CompareError(problem)
    for p in (json_out, heat_path):
        check_output_path(p, overwrite)
        _not_an_input(p, blend, image)
    D.check(cycles_device)
    if blend:
        if not Path(blend).exists():           # a folder: open_mainfile names it
            raise CompareError(f".blend file {blend!r} does not exist")
        from ..addon.open_blend import open_mainfile
        open_mainfile(blend)               # scripts off, whatever the Preferences say
    elif not from_open_file:
        from . import scenes
        scenes.new_scene()
    obj = bpy.data.objects.get(object_name)
    if obj is None:
        raise CompareError(missing_object_problem(object_name, where=False))
    # A large mesh takes a minute and more (1M faces at 32^2: 69 s) that said nothing. On
    # stderr: the bake holds stdout while it runs (bake_console.quiet_bake).
    with D.selected(bpy.context.scene, cycles_device) as chosen, \
            heartbeat(_to_stderr, f"surfgrad: still comparing {method} on {obj.name}"):
        report, heat = compare(obj, method, resolution, variant, uv_map, image,  # the public one
                               with_heat_map=True, tiles=tiles, device=chosen.scene_device)
    report["cycles_device"] = chosen.description
    _write_report(json_out, report, heat_path, heat, overwrite)
    log(f"{method} on {obj.name} at {resolution}^2: {report['texels_compared']} texels, "
        f"mean {report['mean_deg']:.4f} p99 {report['p99_deg']:.4f} max "
        f"{report['max_deg']:.4f} deg ({report['texels_contested']} contested); excluded "
        f"{report['texels_excluded']} ({_excluded_text(report)}); bake "
        f"{report['bake_seconds']:.2f} s, reference {report['reference_seconds']:.2f} s")
    for t in report["tiles"] or []:
        log(f"  tile {t['tile']}: {t['texels_compared']} texels, p99 {t['p99_deg']} max "
            f"{t['max_deg']} deg; excluded {t['excluded']}")
    for w in report["warnings"]:
        log(f"warning: {w}")
    for note in report.get("notes", []):
        log(f"note: {note}")
    return report


def _to_stderr(text):
    print(text, file=sys.stderr, flush=True)


def _excluded_text(report):
    return ", ".join(f"{k} {v}" for k, v in report["excluded"].items())
