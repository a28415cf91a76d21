"""Bake an object's material (surface-gradient groups or anything else) into normal map files.

For pipeline TDs, headless:

    blender -b --disable-autoexec scene.blend \\
        --python-exit-code 1 --python surfgrad_addon/bake_normal_map.py \\
        -- --object Rock --output rock_normal.png --space tangent --resolution 2048
    python -m surfgrad_addon bake-normal-map --blend scene.blend --object Rock \\
        --output "rock_normal.<UDIM>.exr" --space object --samples 16 --depth half

Cycles (CPU) bakes type NORMAL through the object's own materials, saved as PNG (8- or 16-bit)
or OpenEXR (half or float) by the output's extension. An output name with `<UDIM>` bakes a
tiled image, one file per tile, holding only the tiles the UV map has faces in (or the tiles
asked for); without it the 0-1 UV square (tile 1001) is baked into one image, and a UV layout
with nothing there, or faces in other tiles too, is refused with the fix. More than one sample
per texel anti-aliases detail finer than a texel (Cycles jitters the sample in the texel).
Tangent space uses the chosen UV map's MikkTSpace tangents (it is made the active UV map for
the bake, then restored; where modifiers make another one active, through a copy of the render
mesh: tangent_uv.py). Everything the bake touches (render and image-output settings, active
UV map, active nodes) is put back; the temporary image and nodes are removed; files are written
under a temporary name and renamed when complete; an existing file is only replaced with
overwrite.
"""

import os
import re
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..reference import input_checks as IC
from ..reference import tiles as T
from . import interrupts
from .bake_closures import diffuse_stand_ins, holds_stand_ins
from .bake_console import heartbeat, quiet_bake
from .bake_target import (bake_target_problem, object_not_a_mesh, own_materials,
                          visible_for_bake)
from .bake_uvs import (baked_mesh, baked_uv_tiles, long_name_problem,  # noqa: F401
                       not_rendered_problem, one_read, rendered_materials, uv_active,
                       uv_tiles)  # (uv_tiles)
from .exit_codes import BakeFailed, MapNotWritten
from .linked_materials import is_linked, linked_user_problem, local_copies
from .material_inputs import missing_library_problem
from .precise_bake import precise_far
from .preview_links import preview_problem
from .publish_files import publish
from .tangent_uv import tangents_of
from .sculpt_normals import own_normals
from .scene_state import NO_TEXTURE_LIMIT, SCENE_SETTINGS, restored, without_render_effects

SPACES = {"tangent": "TANGENT", "object": "OBJECT"}
RESOLUTION_RANGE = (4, 16384)        # texels per side: a map, and an image Blender can hold
DEFAULT_RESOLUTION = 1024            # the one default of every bake entry (request, batch, freeze)
UDIM_TOKEN = T.UDIM_TOKEN
# extension -> (Blender file format, bit depths it takes, the default depth)
FORMATS = {".png": ("PNG", ("8", "16"), "8"), ".exr": ("OPEN_EXR", ("half", "float"), "float")}
# UDIM numbering: tile 1001 + u + 10 v for u in 0..9 (Blender's tiled images).
UDIM_FIRST, UDIM_COLUMNS, UDIM_LAST = T.UDIM_FIRST, T.UDIM_COLUMNS, T.UDIM_LAST
# Blender's other tile token (u<column+1>_v<row+1>): not filled in here, so refused.
UVTILE_TOKEN = T.UVTILE_TOKEN


def resolution_problem(resolution, lo, hi):
    """None for a whole number of texels in [lo, hi], else what is wrong with it."""
    if isinstance(resolution, bool) or not isinstance(resolution, int) or \
            not lo <= resolution <= hi:
        return f"resolution {resolution!r}: use a whole number of texels from {lo} to {hi}"
    return None


def cycles_problem():
    """None where the Cycles add-on is enabled, else the refusal: every bake renders with
    Cycles, and without the add-on the scene has no Cycles settings (a raw AttributeError,
    'Scene' object has no attribute 'cycles', from inside the bake)."""
    import bpy
    if bpy.context.preferences.addons.get("cycles") is not None:
        return None
    return ("the Cycles add-on is disabled in this Blender, and the bake renders with Cycles: "
            "enable it (Edit > Preferences > Add-ons > Cycles Render Engine, or in a script "
            "addon_utils.enable('cycles', default_set=True))")


class NormalBakeError(ValueError):
    """Bad input: the message names the thing and the fix. `outside`: for a refusal of the
    tiles asked (plan_tile_layout), the faces of the layout beyond the UDIM range, which a
    bake of any tiles refuses as well (the request names both, so one fix is not followed
    by another refusal)."""
    outside = 0


tile_path = T.tile_path
_tiles_text = T.tiles_text


# What the temporary file beside the output adds to its name: ".", ".part", a process id,
# "-" and the process's token (interrupts.partial_path).
TEMP_NAME_EXTRA = 1 + len(".part") + 7 + 1 + interrupts.PART_TOKEN_LENGTH


# Blender keeps a file path in a buffer of 1024 bytes with its closing zero (FILE_MAX, every
# line): a longer one is cut short, and the map was saved under the cut path (a stray file
# named by part of a folder's name), then "Blender wrote no file", exit 1 (the batch, for
# several tiles: "the disk may be full").
BLENDER_PATH_MAX = 1023


def blender_path_problem(output, what="output"):
    """None, or why Blender cannot save the map for `output` by its full path: the temporary
    file it saves beside it (the longest: a half EXR's copy, '%' doubled for a tiled image's
    format) would pass BLENDER_PATH_MAX bytes."""
    output = Path(os.path.abspath(output))
    temp = output.parent / (f".{output.stem}.half{output.suffix}")   # (with the part name:)
    n = len(os.fsencode(blender_tile_path(temp))) + TEMP_NAME_EXTRA
    if n <= BLENDER_PATH_MAX:
        return None
    shown = str(output) if len(str(output)) <= 120 else f"{str(output)[:60]}...{output.name}"
    return (f"{what} {shown!r} is too long a path for Blender: the file the bake saves beside "
            f"it may have {n} bytes with its folder, and Blender takes {BLENDER_PATH_MAX} "
            f"(it cuts a longer path short and saves elsewhere); give a folder or name "
            f"{n - BLENDER_PATH_MAX} bytes shorter")


def check_output(output, overwrite_check=True):
    """The output name's format and its folder: raises NormalBakeError naming the fix."""
    if str(output).endswith(("/", os.sep)):     # Path() drops the slash: `n.png/` wrote n.png
        raise NormalBakeError(f"output {str(output)!r} is a folder: give a file name in it")
    output = Path(output)
    try:
        return _check_output(output)
    except OSError as err:        # what the file system says of the name (the OS's words)
        raise NormalBakeError(f"output {str(output)!r} cannot be used ({err.strerror}): give "
                              f"a shorter or plainer file name") from None


def _name_max(folder):
    """The longest file name, in bytes, the file system under `folder` takes (255 where it
    does not say)."""
    while not folder.exists() and folder.parent != folder:
        folder = folder.parent
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (AttributeError, OSError, ValueError):
        return 255


def blend_relative_problem(output, what="output"):
    """What is wrong with an output path written Blender's way, '//maps/n.png' for 'beside the
    .blend file': a path given to a command or the API is a file-system path, where it names
    the root folder ('/maps/n.png'). bake-normal-map, bake-batch (its pattern and
    --manifest) and compare refuse it. None for any other path, and on Windows (where
    //server/share is a network path)."""
    text = str(output)
    if os.name == "nt" or not text.startswith("//") or text.startswith("///"):
        return None
    return (f"{what} {text!r} starts with '//', Blender's 'beside the .blend file', which a "
            f"path given here does not mean (it would be written in the root: "
            f"{'/' + text.lstrip('/')!r}): "
            f"give the folder itself, absolute or relative to the current folder")


# Tile tokens as other tools or a hurried hand spell them (Blender fills in '<UDIM>' only,
# case and all; Mari writes '$UDIM'): each was written into the file's name.
OTHER_TILE_TOKENS = re.compile(r"<udim>|<uvtile>|\$udim", re.IGNORECASE)


# A '{name}' in an output name: the batch's tokens, or Blender 5's path templates
# ('{blend_name}'), which Blender fills in for renders and File Output nodes, not here.
BRACE_TOKEN = re.compile(r"\{[^}]*\}")


def brace_token_problem(output, by="bake-normal-map", batch="bake-batch"):
    """A single bake (`by`: bake-normal-map, api.bake_normal_map, Freeze's Save As) fills in no
    '{...}' token: one was kept literally (a file named '{blend_name}_nrm.png', exit 0), where
    the batch refuses an unknown one (red teams 43a, 44c). `batch`: the batch to point to, or
    None."""
    found = BRACE_TOKEN.findall(str(output))
    if not found:
        return None
    return (f"output {str(output)!r} has {found[0]}, which {by} does not fill in "
            f"(neither Blender's path templates such as {{blend_name}} nor the batch's "
            f"tokens; it would be a file named with it): write the name itself" +
            (f", or bake with {batch}, whose output pattern fills in {{file}}, {{object}} and "
             f"{{uv}}" if batch else ""))


def udim_token_problem(output, what="output"):
    """<UDIM> in a folder (never filled in), or more than once in the file name: Blender fills
    in the first only, the second became a stray number and the bake's temporary files were
    left behind, exit 1. <UVTILE> anywhere: it was written as a file named with it; so were
    '<udim>' (another case) and '$UDIM' (red team 42b)."""
    path = Path(str(output))
    other = [t for t in OTHER_TILE_TOKENS.findall(str(output)) if t != UVTILE_TOKEN and
             t != UDIM_TOKEN]
    if other:
        return (f"{what} {str(output)!r} has {other[0]!r}, a tile token this bake does not "
                f"fill in (it would be a file named with it): write {UDIM_TOKEN}, in capitals, "
                f"in the file name")
    if UVTILE_TOKEN in str(output):
        return (f"{what} {str(output)!r} has {UVTILE_TOKEN}, which this bake does not fill in "
                f"(it would be a file named with it): put {UDIM_TOKEN} in the file name "
                f"instead (tile 1001 + u + 10 v)")
    if UDIM_TOKEN in str(path.parent):
        return f"{what} {str(output)!r}: put {UDIM_TOKEN} in the file name, not a folder"
    count = path.name.count(UDIM_TOKEN)
    if count > 1:
        return (f"{what} {str(output)!r} has {UDIM_TOKEN} {count} times: Blender puts the tile "
                f"number in the first only; put {UDIM_TOKEN} in the file name once")
    return None


def _check_output(output):
    problem = blend_relative_problem(output)
    if problem:
        raise NormalBakeError(problem)
    problem = blender_path_problem(output)
    if problem:
        raise NormalBakeError(problem)
    longest = _name_max(output.parent) - TEMP_NAME_EXTRA
    if len(os.fsencode(output.name)) > longest:
        raise NormalBakeError(f"output file name {output.name[:40]!r}... is "
                              f"{len(os.fsencode(output.name))} bytes: the folder's file system "
                              f"takes {longest} for it (the bake writes a temporary file with a "
                              f"longer name beside it first); give a shorter name")
    if output.is_dir():
        raise NormalBakeError(f"output {str(output)!r} is a folder: give a file name in it")
    if output.suffix.lower() not in FORMATS:
        raise NormalBakeError(f"output {str(output)!r}: use a .png or .exr file name")
    problem = udim_token_problem(output)
    if problem:
        raise NormalBakeError(problem)
    if output.parent.exists() and not output.parent.is_dir():
        raise NormalBakeError(f"output folder {str(output.parent)!r} is a file, not a folder: "
                              f"give an output in a folder")
    if not output.parent.is_dir():
        link = os.path.islink(output.parent) and \
            f" (it is a symbolic link to {os.readlink(output.parent)!r}, which does not exist: " \
            f"an unmounted share or a moved folder?)"
        raise NormalBakeError(f"output folder {str(output.parent)!r} does not exist"
                              f"{link or ''}: create it first")
    return output


def depth_for(output, depth):
    """The bit depth for `output`'s format ('8'/'16' for PNG, 'half'/'float' for EXR)."""
    suffix = Path(output).suffix.lower()
    _, allowed, default = FORMATS[suffix]
    depth = default if depth in (None, "", "auto") else str(depth)
    if depth not in allowed:
        raise NormalBakeError(f"bit depth {depth!r} does not go with {suffix}: use one of "
                              f"{', '.join(allowed)}")
    return depth


def modifier_uv_problem(name, uv_map):
    """A UV map only a modifier makes: it renders, but Blender's bake takes its UV map from
    the mesh data (it refuses a name the data lacks)."""
    return (f"object {name!r} has UV map {uv_map!r} only from a modifier; Blender's bake needs "
            f"the UV map on the mesh data: apply the modifier (Object > Apply), or add a UV "
            f"map of that name to the mesh (Object Data > UV Maps) and unwrap it")


def unslotted_problem(obj, only):
    """None, or the refusal of a bake of material `only`'s faces alone (Freeze) on obj,
    which renders materials none of its slots holds (a Geometry Nodes Set Material gives
    them): Blender's bake finds them no image of their own and wrote their faces into the map
    of `only`, over its own where their UVs overlap (measured: 196 of 256 texels up to 103
    degrees off; Freeze wired that map in)."""
    own = {s.material for s in obj.material_slots}
    unslotted = [m.name for m in rendered_materials(obj) if m not in own]
    if not unslotted:
        return None
    return (f"object {obj.name!r} renders material(s) {unslotted} that none of its material "
            f"slots holds (a Geometry Nodes Set Material gives them): Blender's bake writes "
            f"their faces into the map of material {only.name!r}, over its faces where their "
            f"UVs overlap; add them to the object's material slots (Material Properties > +)")



def linked_group_problem(obj):
    """None, or the refusal of a linked material with BSDFs to stand in that a linked node
    group of obj's modifiers gives it (linked_materials.linked_user_problem): bake_request
    checks it with the rest of the request, and the bake (Freeze's too) again."""
    return linked_user_problem(obj, [m for m in rendered_materials(obj) if is_linked(m) and
                                     m.node_tree is not None and holds_stand_ins(m.node_tree)])


@contextmanager
def _stand_ins(obj, materials, copies):
    """For the bake, the BSDFs of the slots' materials, of those a Geometry Nodes Set Material
    gives the object (Cycles bakes their faces too) and of the local `copies` of linked ones
    (local_copies) stand in (bake_closures.py)."""
    added = [m for m in rendered_materials(obj) if m not in materials and
             m.node_tree is not None]
    with diffuse_stand_ins([m.node_tree for m in materials + added + list(copies.values())
                            if not is_linked(m)]):
        yield


def _linked_given(obj):
    """The linked materials with BSDFs to stand in that a Set Material gives obj."""
    slots = {s.material for s in obj.material_slots}
    return [m for m in rendered_materials(obj) if is_linked(m) and m not in slots and
            m.node_tree is not None and holds_stand_ins(m.node_tree)]


def no_tile_problem(obj_name, uv_map, uvs=None, others=None):
    """Why a UV map whose faces lie in no UDIM tile bakes nothing, and the fix (whole_tile_move
    where it lies whole in one square off the grid). `uvs`: the UV triangles (T, 3, 2), or
    just the UVs' span; triangles with no area at all (an importer's UVs on one line or
    point, even inside the square) are refused as such: no move puts them in a tile.
    `others`: {name: UV triangles} of the object's other UV maps; one with area is named as
    the other fix (a glTF whose TEXCOORD_0 is collapsed and TEXCOORD_1 unwrapped)."""
    if uvs is not None and np.ndim(uvs) == 3:
        collapsed = IC.collapsed_uv_problem(uv_map, obj_name, uvs)
        if collapsed:
            usable = [name for name, tris in (others or {}).items() if name != uv_map
                      and tris is not None and not IC.collapsed_uv_problem(name, obj_name, tris)]
            return collapsed + (f", or bake with its UV map {usable[0]!r}, which has area "
                                f"(--uv-map {usable[0]!r}; api: uv_map=)" if usable else "")
    text = f"UV map {uv_map!r} of object {obj_name!r} has no faces in any UDIM tile"
    fix = "move its islands into the 0-1 square (tile 1001) or onto UDIM tiles"
    uv = None if uvs is None else np.asarray(uvs, dtype=np.float64).reshape(-1, 2)
    if uv is not None and len(uv) and np.isfinite(uv).all():
        lo, hi = uv.min(0), uv.max(0)
        text += (f" (its UVs span u {lo[0]:.3g}..{hi[0]:.3g}, v {lo[1]:.3g}..{hi[1]:.3g}; "
                 f"the tiles are {T.UDIM_SPAN})")
        move = whole_tile_move(uv)
        fix = f"{move}, or {fix}" if move else fix
    return f"{text}, so nothing would be baked: {fix}"


def whole_tile_move(uvs):
    """For UVs (..., 2) lying whole in one square off the UDIM grid (a glTF's UVs offset by
    whole tiles, which its Repeat textures wrap: Khronos' DamagedHelmet lies in v -1..0 as
    imported), the whole tiles that move them into tile 1001, which keeps the islands as they
    are (mirrored halves stacked included; Pack Islands would undo that); else None."""
    uv = np.asarray(uvs, dtype=np.float64).reshape(-1, 2)
    if not len(uv) or not np.isfinite(uv).all():
        return None
    lo, hi = uv.min(0), uv.max(0)
    cell = np.floor(lo)
    if not (np.floor(hi - T.BORDER_EPS) == cell).all() or not cell.any():
        return None
    du, dv = (int(-c) for c in cell)
    return (f"move its UVs by whole tiles, {du:+d} in u and {dv:+d} in v, into tile "
            f"{T.UDIM_FIRST} (UV > Transform > Move; its islands stay as they are, and image "
            f"textures set to Repeat read the same)")


def plan_tiles(obj, output, uv_map=None, tiles=None, empty_tiles="error"):
    """(uv_map, tiles to bake, tiles with UVs, warnings) for obj and the output name, or a
    NormalBakeError naming what is wrong. empty_tiles='skip' drops asked-for tiles that hold
    no UVs (a farm's asset x tile task) instead of refusing them."""
    return plan_tile_layout(obj, output, uv_map, tiles, empty_tiles)[:4]


def plan_tile_layout(obj, output, uv_map=None, tiles=None, empty_tiles="error"):
    """plan_tiles, and how many faces of the UV map lie outside the UDIM range. The tiles are
    those of the mesh the bake renders (bake_uvs.py: modifiers can move UVs)."""
    import bpy
    if obj is None:
        raise NormalBakeError("pick a mesh object to bake (--object NAME)")
    missing = missing_library_problem(obj)    # its placeholder is an empty: say why
    if missing:
        raise NormalBakeError(missing)
    if obj.type != "MESH":
        raise NormalBakeError(object_not_a_mesh(obj, "pick a mesh object to bake (--object "
                                                     "NAME)"))
    problem = bake_target_problem(obj, bpy.context.view_layer)
    if problem:
        raise NormalBakeError(problem)
    mesh = obj.data
    names = [uv.name for uv in mesh.uv_layers]
    if uv_map and uv_map not in names and uv_map in baked_uv_tiles(obj):
        raise NormalBakeError(modifier_uv_problem(obj.name, uv_map))
    if not names:
        raise NormalBakeError(f"object {obj.name!r} has no UV map; unwrap it first")
    uv_map = uv_map or next((uv.name for uv in mesh.uv_layers if uv.active_render), names[0])
    if uv_map not in names:
        raise NormalBakeError(f"object {obj.name!r} has no UV map {uv_map!r}; it has {names}")
    problem = long_name_problem(obj.name, uv_map)
    if problem:
        raise NormalBakeError(problem)
    with uv_active(mesh, uv_map):       # read as the bake renders it (tangent_uv.py)
        layout = baked_uv_tiles(obj)
        every_uv = baked_mesh(obj).triangle_uvs
        uvs = every_uv.get(uv_map)
    if uv_map not in layout:
        raise NormalBakeError(not_rendered_problem(obj.name, uv_map, layout, obj,
                                                   len(baked_mesh(obj).face_materials)))
    with_uvs, outside = layout[uv_map]
    warnings = []
    if outside:
        warnings.append(f"{outside} face(s) of UV map {uv_map!r} lie outside the UDIM range "
                        f"({T.UDIM_SPAN}) and are not baked")
    where = f"UV map {uv_map!r} of object {obj.name!r}"
    if not with_uvs:
        # Another map named as the fix only where a bake with it goes on: on the mesh data
        # (not a modifier's), a name the bake takes, faces in a UDIM tile.
        others = {name: every_uv.get(name) for name in names if layout.get(name, ((),))[0]
                  and not long_name_problem(obj.name, name)}
        raise NormalBakeError(no_tile_problem(obj.name, uv_map, uvs, others))
    try:
        tiles = _chosen_tiles(output, tiles, with_uvs, where, empty_tiles)
    except NormalBakeError as err:
        err.outside = outside
        raise
    return uv_map, tiles, with_uvs, warnings, outside


def _chosen_tiles(output, tiles, with_uvs, where, empty_tiles):
    """The tiles to bake of a layout with UVs in tiles `with_uvs`: those asked, or every one
    for an output with <UDIM>, or tile 1001 alone for a single image."""
    udim = UDIM_TOKEN in Path(output).name
    if tiles:
        tiles = sorted({int(t) for t in tiles})
        bad = [t for t in tiles if not UDIM_FIRST <= t <= UDIM_LAST]
        if bad:
            raise NormalBakeError(f"tile {bad[0]}: UDIM tiles are numbered {UDIM_FIRST} to "
                                  f"{UDIM_LAST}")
        empty = [t for t in tiles if t not in with_uvs]
        if empty and empty_tiles != "skip":
            raise NormalBakeError(f"tile(s) {_tiles_text(empty)} hold no UVs of {where} "
                                  f"(its UVs are in {_tiles_text(with_uvs)}): ask for tiles "
                                  f"that hold UVs, or fix the UV layout")
        tiles = [t for t in tiles if t in with_uvs]
        if not udim and tiles not in ([], [UDIM_FIRST]):
            raise NormalBakeError(f"output {Path(output).name!r} has no {UDIM_TOKEN}: only tile "
                                  f"1001 goes into a single image; put {UDIM_TOKEN} in the "
                                  f"name for tiles {_tiles_text(tiles)}")
    elif udim:
        tiles = with_uvs
    else:
        if UDIM_FIRST not in with_uvs:
            raise NormalBakeError(f"{where} puts nothing inside the 0-1 UV square (tile 1001) "
                                  f"that a single image covers; its UVs are in tiles "
                                  f"{_tiles_text(with_uvs)}: put {UDIM_TOKEN} in the output "
                                  f"name to bake those tiles, or fix the UV layout")
        if len(with_uvs) > 1:
            raise NormalBakeError(f"{where} spans UDIM tiles {_tiles_text(with_uvs)} but the "
                                  f"output {Path(output).name!r} has no {UDIM_TOKEN}: put "
                                  f"{UDIM_TOKEN} in the name (one file per tile), or ask for "
                                  f"tile 1001 alone")
        tiles = [UDIM_FIRST]
    return tiles


def bake_normal_tiles(obj, output, space="tangent", resolution=DEFAULT_RESOLUTION, uv_map=None,
                      margin=16, samples=1, depth=None, tiles=None, empty_tiles="error",
                      overwrite=False, log=print, threads=None, verify=None, only=None,
                      before_publish=None):
    """Bake obj's materials into normal map file(s) at `output` (with <UDIM>: one file per
    tile); with `only` (one of them), that material's faces alone (the others bake into a
    throwaway image: where their UVs overlap its faces', they would overwrite them).
    threads: CPU threads for Cycles (None: Blender's own choice, every core; a batch of
    several processes gives each its share). Materials linked from a library bake through
    temporary local copies (linked_materials.py). verify(): called once the files are written
    and checked, before they are put in place (it raises to publish nothing);
    before_publish({tile: (final Path, its complete temporary file)}): called after it (a batch
    records what it is about to publish). Returns a dict: paths {tile: Path}, tiles, uv_map,
    depth, warnings, bake_s, save_s."""
    import bpy
    given = []
    if any(is_linked(m) for m in bpy.data.materials):   # (else no render-mode pass for it)
        with one_read():            # (a Set Material's, before its users use the copies)
            given = _linked_given(obj)
    # one render-mode pass: the plan, the tangents
    with local_copies(obj, given) as copies, one_read():
        return _bake_tiles(obj, output, space, resolution, uv_map, margin, samples, depth,
                           tiles, empty_tiles, overwrite, log, threads, verify, only,
                           before_publish, copies)


def _bake_tiles(obj, output, space, resolution, uv_map, margin, samples, depth, tiles,
                empty_tiles, overwrite, log, threads, verify=None, only=None,
                before_publish=None, copies=None):
    import bpy

    output = check_output(output)
    problem = resolution_problem(resolution, *RESOLUTION_RANGE)
    if problem:
        raise NormalBakeError(problem)
    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= 65536:
        raise NormalBakeError(f"samples {samples!r}: use a whole number from 1 to 65536")
    if isinstance(margin, bool) or not isinstance(margin, int) or not 0 <= margin <= 1024:
        raise NormalBakeError(f"margin {margin!r}: use a whole number of texels from 0 to 1024")
    if space not in SPACES:
        raise NormalBakeError(f"space {space!r}: use one of {sorted(SPACES)}")
    depth = depth_for(output, depth)
    uv_map, tiles, with_uvs, warnings = plan_tiles(obj, output, uv_map, tiles, empty_tiles)
    result = {"paths": {}, "tiles": tiles, "tiles_with_uvs": with_uvs, "uv_map": uv_map,
              "depth": depth, "warnings": warnings, "bake_s": 0.0, "save_s": 0.0}
    if not tiles:
        log(f"      {obj.name}: no UVs in the asked-for tile(s); nothing to bake")
        return result
    udim = UDIM_TOKEN in output.name
    finals = {t: tile_path(output, t) for t in tiles}
    existing = [str(p) for p in finals.values() if p.exists()]
    if existing and not overwrite:
        raise NormalBakeError(f"{existing[0]} exists; pass --overwrite to replace it")
    mesh = obj.data
    # Each material once: one in two slots (joined objects) would take two image nodes, and
    # putting back the second's "previous active" would name the first, removed one.
    materials = list(dict.fromkeys(s.material for s in obj.material_slots
                                   if s.material is not None))
    if not materials:
        raise NormalBakeError(f"object {obj.name!r} has no material to bake")
    if only is not None and only not in materials:
        raise NormalBakeError(f"object {obj.name!r} does not render material {only.name!r}")
    problem = only is not None and unslotted_problem(obj, only)
    if problem:
        raise NormalBakeError(problem)
    problem = linked_group_problem(obj) or preview_problem(materials)
    if problem:
        raise NormalBakeError(problem)
    fmt, _, _ = FORMATS[output.suffix.lower()]
    is_float = depth != "8"
    scene = bpy.context.scene
    log(f"[1/3] preparing {obj.name}: {space} space, {resolution}x{resolution}, UV map "
        f"{uv_map!r}, tile(s) {_tiles_text(tiles)}, {samples} sample(s), {len(materials)} "
        f"material(s)")
    image = bpy.data.images.new(f"{obj.name}_normal", resolution, resolution, alpha=False,
                                float_buffer=is_float, tiled=udim)
    image.colorspace_settings.is_data = True
    # Blender's bake needs an image in every material; the ones not asked for get this one.
    others = None if only is None or materials == [only] else \
        bpy.data.images.new(f"{obj.name}_other_materials", 8, 8, tiled=udim)
    added, temps = [], {}
    settings = SCENE_SETTINGS + ("render.bake.normal_space", "render.threads_mode",
                                 "render.threads")
    try:
        if udim:
            _make_tiles(bpy, image, tiles, resolution, is_float)
        for mat in materials:
            tree = mat.node_tree
            node = tree.nodes.new("ShaderNodeTexImage")
            node.image = image if only in (None, mat) else others
            added.append((tree, node, tree.nodes.active))
            tree.nodes.active = node
        with restored(scene, settings), visible_for_bake(obj, bpy.context.view_layer), \
                own_normals(obj), own_materials(bpy.context.view_layer), \
                _stand_ins(obj, materials, copies or {}), \
                tangents_of(obj, uv_map, space), \
                precise_far(obj, log):           # far out: as precise as at the origin
            mesh = obj.data         # either may stand a copy of the render mesh in for it
            scene.render.engine = "CYCLES"
            scene.cycles.device = "CPU"
            scene.cycles.samples = samples
            scene.cycles.use_denoising = False
            scene.cycles.texture_limit_render = NO_TEXTURE_LIMIT
            without_render_effects(scene)
            if threads:
                scene.render.threads_mode = "FIXED"
                scene.render.threads = threads
            scene.render.bake.target = "IMAGE_TEXTURES"
            scene.render.bake.use_selected_to_active = False
            with uv_active(mesh, uv_map):     # none active: the bake refuses the mesh
                selection = [o for o in bpy.context.view_layer.objects if o.select_get()]
                active_obj = bpy.context.view_layer.objects.active
                try:
                    for o in bpy.context.view_layer.objects:
                        o.select_set(o == obj)
                    bpy.context.view_layer.objects.active = obj
                    log("[2/3] baking with Cycles (CPU) ...")
                    t0 = time.perf_counter()
                    with quiet_bake() as say, heartbeat(say, "      still baking"), \
                            interrupts.native_call():
                        # The swizzle given: unset, the operator takes the file's own bake
                        # settings (a DirectX -Y left from a game export flips green).
                        outcome = bpy.ops.object.bake(type="NORMAL", normal_space=SPACES[space],
                                                      normal_r="POS_X", normal_g="POS_Y",
                                                      normal_b="POS_Z", uv_layer=uv_map,
                                                      margin=margin, use_clear=True)
                    result["bake_s"] = time.perf_counter() - t0
                    log(f"      baked in {result['bake_s']:.2f} s")
                finally:
                    for o in bpy.context.view_layer.objects:
                        o.select_set(o in selection)
                    bpy.context.view_layer.objects.active = active_obj
        if outcome != {"FINISHED"}:
            from .cancel_reason import cancelled_text
            raise BakeFailed(cancelled_text(obj, outcome))
        t0 = time.perf_counter()
        temp = interrupts.partial_path(output)
        temps = {t: tile_path(temp, t) for t in tiles}
        image.filepath_raw = blender_tile_path(temp.resolve()) if udim else str(temp.resolve())
        image.file_format = fmt
        try:
            image.save()
        except RuntimeError as err:
            raise _not_written(output, err) from None
        missing = [str(p) for p in temps.values() if not p.is_file()]
        if missing:
            raise BakeFailed(f"Blender wrote no file {missing[0]}")
        if depth == "half":
            try:
                _to_half_exr(bpy, temps.values())
            except RuntimeError as err:     # (its own temporary file: the user's output named)
                raise _not_written(output, err) from None
        for t in tiles:
            _check_written(bpy, temps[t], finals[t], resolution)
        if verify is not None:
            verify()
        if before_publish is not None:
            before_publish({t: (finals[t], temps[t]) for t in tiles})
        with interrupts.committing():             # a stop sees every tile or none
            _publish_all(temps, finals, tiles, overwrite, result["paths"])
        result["save_s"] = time.perf_counter() - t0
        written = ', '.join(str(p) for p in finals.values())
        try:
            log(f"[3/3] wrote {written}")
        except Exception as err:                  # the caller's log, after the map is in place
            err.add_note(f"surfgrad: raised by the log callback after the bake; the map is "
                         f"written and complete: {written}")
            raise
        return result
    finally:
        for tree, node, previous in reversed(added):
            tree.nodes.remove(node)
            tree.nodes.active = previous
        bpy.data.images.remove(image)
        if others is not None:
            bpy.data.images.remove(others)
        for p in temps.values():              # a failed save leaves nothing half-written
            if p.exists():
                p.unlink()


def blender_tile_path(path):
    """`path` (with <UDIM>) as a tiled image's file path for Blender to save: Blender fills in
    the token by printf formatting (it becomes %d), so a '%' elsewhere in the path (a folder
    '100%', an object 'Rock%s') was read as a format: tiles written into other folders, or a
    crash. Doubled, it stays one '%' (tests/test_faults_pipeline37.py, every line)."""
    return str(path).replace("%", "%%")


def _make_tiles(bpy, image, tiles, resolution, is_float):
    """Give the tiled image exactly `tiles`, each with a buffer Cycles can bake into (a
    renumbered first tile loses its buffer, so every tile is filled)."""
    image.tiles[0].number = tiles[0]
    for number in tiles[1:]:
        image.tiles.new(tile_number=number)
    for index in range(len(image.tiles)):
        image.tiles.active_index = index
        with bpy.context.temp_override(edit_image=image):
            bpy.ops.image.tile_fill(color=(0.5, 0.5, 1.0, 1.0), width=resolution,
                                    height=resolution, float=is_float, alpha=False)


def _not_written(output, err):
    """The refusal for a save of the map for `output` Blender raised `err` for (its two lines:
    "Could not write ...: EINVAL"; a full disk, a folder in the way of a temporary file)."""
    reason = str(err).strip().splitlines()[0].removeprefix("Error: ")
    return MapNotWritten(f"Blender could not write the map for {str(output)!r} ({reason}): "
                         f"free space in {str(output.parent)!r} (the disk may be full), "
                         f"check that the folder still takes files, and bake again")


def _to_half_exr(bpy, paths):
    """Rewrite float EXR files as half EXR (Image.save keeps a float buffer at 32 bits; a
    scene's output settings choose 16). Through a scene of its own, removed after: the file's
    Output colour management is not applied to the map's data (on 4.2 an Override to another
    linear space converted it, 18 degrees off: test_faults_images35), nor changed (putting an
    Override back copied the scene's view into it: the user's own view, look, exposure, gamma
    and linear space there were lost, red team 39a)."""
    scene = bpy.data.scenes.new(".surfgrad half EXR")
    try:
        settings = scene.render.image_settings
        settings.color_management = "FOLLOW_SCENE"
        settings.file_format = "OPEN_EXR"
        settings.color_mode = "RGB"
        settings.color_depth = "16"
        settings.exr_codec = "ZIP"
        for path in paths:
            img = bpy.data.images.load(str(path))
            try:
                img.colorspace_settings.is_data = True     # data: no colour conversion
                half = path.with_name(path.stem + ".half" + path.suffix)
                try:
                    img.save_render(str(half), scene=scene)
                except RuntimeError:
                    if half.is_file():          # a half-written copy (a full disk)
                        half.unlink()
                    raise
                os.replace(half, path)
            finally:
                bpy.data.images.remove(img)
    finally:
        bpy.data.scenes.remove(scene)


# A PNG's last 12 bytes: its IEND chunk (length 0, type, CRC), which libpng writes last.
PNG_END = b"\x00\x00\x00\x00IEND\xaeB`\x82"


def _check_written(bpy, temp, final, resolution):
    """Check a written file before it is put in place: Blender's image writers do not report
    a failed write (a full disk, a file-size limit), and leave a cut-off file that would be
    published as the map with exit code 0. A PNG is whole when it ends with its IEND chunk
    (12 bytes read; reading a 4096^2 16-bit map back took 0.77 s); an EXR is read back."""
    if temp.suffix.lower() == ".png":
        with open(temp, "rb") as f:
            whole = f.seek(0, os.SEEK_END) >= len(PNG_END) and \
                f.seek(-len(PNG_END), os.SEEK_END) >= 0 and f.read() == PNG_END
    else:
        probe = None
        try:
            probe = bpy.data.images.load(str(temp), check_existing=False)
            whole = tuple(probe.size) == (resolution, resolution)
        except RuntimeError:
            whole = False
        finally:
            if probe is not None:
                bpy.data.images.remove(probe)
    if not whole:
        raise MapNotWritten(
            f"the file written for {str(final)!r} is incomplete (cut off after "
            f"{temp.stat().st_size} bytes): the disk is full or a file-size limit (ulimit -f) "
            f"was hit; free space in "
            f"{str(final.parent)!r} (or raise the limit) and bake again")


def _publish_all(temps, finals, tiles, overwrite, paths):
    """Put every tile's file in place, or none (publish_files.py): without overwrite a tile
    file that appeared since the checks (another bake of the same names) stops the publish."""
    publish([(temps[t], finals[t]) for t in tiles], overwrite, _exists)
    for t in tiles:
        interrupts.placed(finals[t])
        paths[t] = finals[t]


def _exists(final):
    return NormalBakeError(f"{final} exists; pass --overwrite to replace it")


def _publish(temp, final, overwrite):
    """Move a complete file to its name; without overwrite never replace one that appeared."""
    publish([(temp, final)], overwrite, _exists)


def bake_normal_map(obj, output, space="tangent", resolution=DEFAULT_RESOLUTION, uv_map=None,
                    margin=16, samples=1, overwrite=False, log=print, depth=None, tiles=None):
    """Bake obj's materials to a normal map file at `output` (with <UDIM> in the name: one
    file per tile that holds UVs). Returns the written path (the name with <UDIM> for tiles)."""
    bake_normal_tiles(obj, output, space, resolution, uv_map, margin, samples, depth, tiles,
                      overwrite=overwrite, log=log)
    return Path(output)
