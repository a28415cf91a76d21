"""One bake request, checked once, before anything is baked.

Every way in (`python -m surfgrad_addon bake-normal-map`, `blender -c surfgrad`, api, settings
files and the bake-batch planner) builds a BakeRequest and runs the same checks up front:

- settings: each one's type and range (settings_problems; no bpy, so the batch planner checks
  a settings file before any Blender file is opened);
- the object and its evaluated mesh: a mesh that can be baked, finite positions, faces with
  area; far from the origin and overlapping UV islands (contested texels) are warnings;
- the UV map and its tiles (reference.tiles): finite UVs with area, a layout the output covers;
  faces outside the UDIM range are an error unless allow_partial, then a printed warning;
- every image the object's materials read (from the Material Output Cycles renders, into node
  groups): packed or on disk, loadable, and with finite pixels when float (image_checks.py);
- the output: format and bit depth, a folder that exists and takes a file (a probe file is
  created and removed), no file replaced unless overwrite, never an image the materials read.

check() raises BakeRequestError naming every problem found and its fix; nothing has been
written and the .blend is as it was (images loaded for the check are freed again). Warnings
are printed to stderr (where a user looks), and returned.
"""

import errno
import os
import sys
import tempfile
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from ..reference import input_checks as IC
from ..reference import tiles as T
from ..reference import uv_overlap as UV
from . import normal_bake as NB
from . import input_stamps
from . import unrealized_instances as UI
from .bake_closures import stand_in_warnings
from .bake_console import heartbeat
from .bake_uvs import baked_mesh, one_read
from .cache_files import unread_cache_problems
from .facing_away import facing_away_warning
from .flat_frames import frame_mismatch_warning
from .empty_slots import empty_slot_problem
from .exit_codes import BakeFailed, MapNotWritten
from .float_pixels import one_pixel_read
from .foreign_nodes import foreign_node_problems
from .header_reads import one_header_read
from .image_checks import (checked_materials, image_problems, muted_output_warnings,
                           one_tile_write, output_input_problems)
from .image_memory import images_memory
from .material_uv_maps import read_uv_map_problems
from .memory_limit import bake_memory_problem
from .normal_map_checks import (colour_space_warnings, normal_map_warnings,
                                raw_image_normal_warnings)
from .object_names import missing_object_problem
from .object_space_scale import object_space_scale_problem
from .deformed_mesh import posed_armature_warning, shape_key_warning
from .parallax_heights import parallax_height_warnings
from .small_objects import small_object_messages

OVERLAP_CHECK_SIZE = 512     # texels a side the overlap warning counts at (cost bound)
FAR_FROM_ORIGIN_M = 1000.0     # beyond this float32 positions cost Bump-node precision
SAMPLES_RANGE = (1, 65536)
THREADS_RANGE = (1, 1024)
MARGIN_RANGE = (0, 1024)
DEPTHS = ("auto", "8", "16", "half", "float")


class BakeRequestError(NB.NormalBakeError):
    """The request cannot be baked; `problems` lists each (the thing and the fix)."""

    def __init__(self, problems):
        self.problems = list(problems)
        text = self.problems[0] if len(self.problems) == 1 else \
            f"{len(self.problems)} problems:\n  - " + "\n  - ".join(self.problems)
        super().__init__(text)


def whole_number_problem(name, value, lo, hi, unit=""):
    """None for a whole number in [lo, hi], else the message naming the setting and the fix."""
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        return f"{name} {value!r}: use a whole number{unit} from {lo} to {hi}"
    return None


# The settings a request takes (and a settings file may give per asset): name -> its check.
def _space(v):
    return None if v in NB.SPACES else f"space {v!r}: use one of {', '.join(sorted(NB.SPACES))}"


def _depth(v):
    return None if v is None or str(v) in DEPTHS else \
        f"depth {v!r}: use one of {', '.join(DEPTHS)} (8/16 for .png, half/float for .exr)"


def _uv_map(v):
    return None if v is None or (isinstance(v, str) and v) else \
        f"uv_map {v!r}: give a UV map's name (text), or leave it out for the active one"


def _flag(name):
    return lambda v: None if isinstance(v, bool) else f"{name} {v!r}: use true or false"


SETTING_CHECKS = {
    "uv_map": _uv_map,
    "space": _space,
    "resolution": lambda v: NB.resolution_problem(v, *NB.RESOLUTION_RANGE),
    "samples": lambda v: whole_number_problem("samples", v, *SAMPLES_RANGE),
    "margin": lambda v: whole_number_problem("margin", v, *MARGIN_RANGE, " of texels"),
    "depth": _depth,
    "allow_partial": _flag("allow_partial"),
}


def settings_problems(settings, where=""):
    """Problems with a dict of settings (unknown names, wrong types, out of range); no bpy.
    `where` prefixes each (e.g. the settings file and block)."""
    prefix = f"{where}: " if where else ""
    out = []
    unknown = sorted(set(settings) - set(SETTING_CHECKS))
    if unknown:
        out.append(f"{prefix}unknown setting(s) {', '.join(map(str, unknown))}; the settings "
                   f"are {', '.join(SETTING_CHECKS)}")
    for key, check in SETTING_CHECKS.items():
        if key in settings:
            problem = check(settings[key])
            if problem:
                out.append(prefix + problem)
    return out


def _option(default, help, **argument):
    """A request field: its default, and for the command line (addon/bake_options.py) its
    help, its range or choices, and the option's name where it is not the field's."""
    return field(default=default, metadata={"help": help, **argument})


@dataclass
class BakeRequest:
    """What to bake: one object into one output name (with <UDIM>: one file per tile)."""
    object: str
    output: str
    space: str = _option("tangent", "the normal map's space", choices=tuple(NB.SPACES))
    resolution: int = _option(NB.DEFAULT_RESOLUTION, "texels per side", range=NB.RESOLUTION_RANGE)
    uv_map: str = _option(None, "UV map (default: the active render one)")
    margin: int = _option(16, "texels to extend past UV borders", range=MARGIN_RANGE)
    samples: int = _option(1, "Cycles samples per texel: more anti-alias detail finer than a "
                              "texel", range=SAMPLES_RANGE)
    depth: str = _option(None, "bit depth: 8 or 16 for .png (default 8), half or float for "
                               ".exr (default float)", choices=DEPTHS)
    tiles: list = _option(None, "UDIM tiles to bake, e.g. 1001,1002 or 1001-1010 (default: "
                                "every tile the UV map has faces in; needs <UDIM> in --output "
                                "for more than 1001)", type=str)
    empty_tiles: str = _option("error", "a tile asked for with no UVs of the object: refuse "
                                        "or skip", choices=("error", "skip"),
                               option="--if-tile-empty")
    overwrite: bool = _option(False, "replace an existing file")
    allow_partial: bool = _option(False, "bake a UV layout with faces outside the UDIM range "
                                         f"({T.UDIM_SPAN}); those faces are left out, with a "
                                         "warning (default: refused)")
    threads: int = _option(None, "Cycles threads per bake (default: every core)")

    @classmethod
    def from_settings(cls, obj_name, output, settings, **more):
        """A request from a settings dict (bake-batch, settings files); unknown keys refused."""
        problems = settings_problems(settings)
        if problems:
            raise BakeRequestError(problems)
        known = {f.name for f in fields(cls)}
        return cls(object=obj_name, output=str(output),
                   **{k: v for k, v in {**settings, **more}.items() if k in known})

    def settings(self):
        return {k: v for k, v in asdict(self).items() if k in SETTING_CHECKS}

    def own_problems(self):
        """Problems of the request itself (no bpy): settings, output name, tiles, depth."""
        out = settings_problems(self.settings())
        if self.empty_tiles not in ("error", "skip"):
            out.append(f"empty tiles {self.empty_tiles!r}: use 'error' or 'skip'")
        problem = self.threads is not None and whole_number_problem("threads", self.threads,
                                                                    *THREADS_RANGE)
        if problem:
            out.append(problem)
        try:
            self.tiles = T.parse_tiles(self.tiles)
        except ValueError as err:
            out.append(str(err))
        try:
            NB.check_output(self.output)
            if not _depth(self.depth):
                NB.depth_for(self.output, self.depth)
        except NB.NormalBakeError as err:
            out.append(str(err))
        return out


@dataclass
class CheckedRequest:
    """A request that passed every check, with what the checks found."""
    request: BakeRequest
    uv_map: str
    tiles: list
    tiles_with_uvs: list
    depth: str
    finals: dict = field(default_factory=dict)      # tile -> the file it will be written to
    warnings: list = field(default_factory=list)
    input_stamps: dict = field(default_factory=dict)    # input_stamps.stamps at the check


def warn_stderr(message):
    print(f"surfgrad: warning: {message}", file=sys.stderr, flush=True)


def check(request, obj=None, warn=warn_stderr):
    """Check everything about `request` before baking; returns a CheckedRequest (its warnings
    already passed to `warn`) or raises BakeRequestError naming every problem and its fix."""
    # one read of the mesh, of each image file's header, and of each image's pixels
    with one_read(), one_header_read(), one_pixel_read(), one_tile_write():
        return _check(request, obj, warn)


def _check(request, obj, warn):
    problems = request.own_problems()
    if problems:                  # a bad option: name it before looking at the scene
        raise BakeRequestError(problems)
    problem = NB.cycles_problem()
    if problem:                   # (each check below may read the scene's Cycles settings)
        raise BakeRequestError([problem])
    import bpy
    if obj is None:
        obj = bpy.data.objects.get(request.object)
        if obj is None:
            raise BakeRequestError([missing_object_problem(request.object, where=False)])
    warnings = []
    try:
        uv_map, tiles, with_uvs, tile_warnings, outside = NB.plan_tile_layout(
            obj, request.output, request.uv_map, request.tiles, request.empty_tiles)
    except NB.NormalBakeError as err:
        also = [outside_problem(err.outside, request.uv_map or _render_uv(obj), obj.name)] \
            if err.outside and not request.allow_partial else []
        raise BakeRequestError(_only_instances(obj) or [str(err)] + also) from None
    problems += mesh_problems(obj, uv_map, warnings, tiles, request.resolution,
                              tangent=request.space == "tangent")
    baked = baked_mesh(obj)
    if request.space == "object":        # Blender writes it bent under an uneven scale
        problem = object_space_scale_problem(obj, baked.matrix)
        problems += [problem] if problem else []
        posed = posed_armature_warning(obj, bpy.context.evaluated_depsgraph_get())
        warnings += [posed] if posed else []
        keys = shape_key_warning(obj)
        warnings += [keys] if keys else []
    more, notes = UI.instance_problems(baked.instances, obj, baked.triangle_uvs.get(uv_map),
                                       uv_map, tiles, request.resolution, request.allow_partial)
    problems += more
    warnings += notes
    if outside and not request.allow_partial:
        problems.append(outside_problem(outside, uv_map, obj.name))
    else:
        warnings += tile_warnings
    if not any(s.material for s in obj.material_slots):
        problems.append(f"object {obj.name!r} has no material to bake: give it one")
    else:
        problem = empty_slot_problem(obj.name, baked.face_materials, baked.filled_slots,
                                     obj)
        problems += [problem] if problem else []
    problems += foreign_node_problems(obj)          # a newer line's nodes: baked as zero
    problem = NB.linked_group_problem(obj)          # a copy cannot stand in for it
    problems += [problem] if problem else []
    small, notes = small_object_messages(obj)      # float32 derivatives on a tiny object
    problems += small
    warnings += notes
    stamped = input_stamps.stamps(obj)              # before the checks read the files
    # Before the image checks load the images: one too large for the process crashed the load,
    # so where they do not fit they are not loaded (nor checked further).
    problem = bake_memory_problem(request.resolution, len(tiles), images_memory(obj, tiles))
    problems += [problem] if problem else image_problems(obj, tiles, warnings=warnings)
    warnings += colour_space_warnings(obj) + muted_output_warnings(obj)
    warnings += raw_image_normal_warnings(obj)      # an image in a Normal input, undecoded
    warnings += stand_in_warnings(checked_materials(obj))   # maps Cycles renders otherwise
    if not problem:
        warnings += normal_map_warnings(obj, covered=tiles)     # grey files, -1..1 floats
        warnings += parallax_height_warnings(obj, covered=tiles)
    depth = NB.depth_for(request.output, request.depth)
    finals = {t: T.tile_path(request.output, t) for t in tiles}
    problems += output_problems(request.output, finals, request.overwrite)
    problems += output_input_problems(obj, finals)
    if problems:
        raise BakeRequestError(problems)
    for w in warnings:
        warn(w)
    return CheckedRequest(request, uv_map, tiles, with_uvs, depth, finals, warnings, stamped)


def bake(request, obj=None, log=print, warn=warn_stderr, before_publish=None):
    """Check `request`, then bake it (normal_bake.bake_normal_tiles; before_publish: see
    there). Returns its result dict
    (paths, tiles, uv_map, depth, warnings, timings). Raises BakeRequestError before anything
    is written, or BakeFailed when the bake itself fails."""
    import bpy
    r = request
    raised = []                           # the caller's own log errors: theirs, not the bake's

    def said(line):
        try:
            log(line)
        except Exception as err:
            raised.append(err)
            raise
    with one_read():                      # the bake plans its tiles from the checked read
        # Silent for seconds per million faces (the mesh as it renders, its UV tiles).
        with heartbeat(log, f"      still checking {obj.name if obj else r.object}"):
            checked = check(request, obj, warn)
        obj = obj or bpy.data.objects[request.object]
        try:
            result = NB.bake_normal_tiles(obj, r.output, r.space, r.resolution,
                                          checked.uv_map, r.margin, r.samples, checked.depth,
                                          r.tiles, r.empty_tiles, overwrite=r.overwrite,
                                          log=said, threads=r.threads,
                                          verify=lambda: _inputs_unchanged(checked),
                                          before_publish=before_publish)
        except RuntimeError as err:       # the bake operator or the image write
            if any(err is e for e in raised):
                raise
            # (MapNotWritten keeps its kind: a batch does not retry it)
            failed = MapNotWritten if isinstance(err, MapNotWritten) else BakeFailed
            raise failed(f"the bake of {obj.name!r} failed: {err}") from None
    result["warnings"] = list(dict.fromkeys(checked.warnings + result.get("warnings", [])))
    return result


def outside_problem(outside, uv_map, obj_name):
    """The refusal of a layout with `outside` faces beyond the UDIM range."""
    return (f"{outside} face(s) of UV map {uv_map!r} of object {obj_name!r} lie outside the "
            f"UDIM range ({T.UDIM_SPAN}) and would not be baked: move them into tiles (UV > "
            f"Pack Islands), or bake the rest on purpose with --allow-partial (api: "
            f"allow_partial=True; settings file: \"allow_partial\": true)")


def _render_uv(obj):
    """The UV map a bake of obj takes when none is asked (plan_tile_layout's choice)."""
    layers = obj.data.uv_layers
    return next((uv.name for uv in layers if uv.active_render), layers[0].name)


def _only_instances(obj):
    """[the problem] when obj renders all its faces as instances (the layout's error then
    blames its UV map), else []."""
    if obj.type != "MESH":
        return []
    try:
        return UI.only_instances_problems(baked_mesh(obj), obj)
    except RuntimeError:                    # what the layout check met: its error stands
        return []


def _inputs_unchanged(checked):
    problem = input_stamps.changed_problem(checked.input_stamps)
    if problem:
        raise BakeFailed(problem)


# The checks ---------------------------------------------------------------------------------

def mesh_problems(obj, uv_map, warnings, tiles=(), resolution=None, only=None, tangent=True):
    """The evaluated mesh as the bake sees it (bake_uvs.baked_mesh: modifiers at their
    render settings): its mesh caches read (cache_files.py), finite positions, faces with
    area, finite UVs with area in `uv_map`, finite UVs in the maps its materials (or material
    `only`) read; far from the origin, and texels of `tiles` that overlapping UV islands
    contest at `resolution`, add warnings; so do faces a `tangent`-space map renders off on
    (flat_frames.py)."""
    stale = unread_cache_problems(obj)      # (the mesh read would be the import's, not the cache's)
    if stale:
        return stale
    baked = baked_mesh(obj)
    positions, tris, matrix = baked.positions, baked.triangles, baked.matrix
    uv = baked.triangle_uvs.get(uv_map) if uv_map else None
    nt = len(tris)
    what = f"mesh {obj.data.name!r} of object {obj.name!r}"
    out = []
    fix = "fix or remove those vertices (a bad import or script often leaves them)"
    problem = IC.finite_problem(f"the vertex positions of {what}", positions, fix) or \
        IC.finite_problem(f"the transform of object {obj.name!r}", matrix,
                          "reset it (Object > Clear > Location/Rotation/Scale)")
    if problem:
        return [problem]
    if nt == 0:
        return [f"{what} has no faces to bake; add geometry"]
    problem = zero_scale_problem(obj, matrix)
    if problem:
        return [problem]
    if baked.nonfinite_normals:           # free normals (4.5 and later) are stored as given
        out.append(f"the normals of {what} are not numbers (NaN or Inf) at "
                   f"{baked.nonfinite_normals} face corner(s), where Cycles shades with a "
                   f"stand-in: fix what wrote them (a Set Mesh Normal node, a script, an "
                   f"importer), or clear them (Object Data > Geometry Data > Clear Custom "
                   f"Split Normals Data)")
    away = facing_away_warning(what, baked.facing_away_faces)
    warnings += [away] if away else []
    frames = tangent and frame_mismatch_warning(what, baked.frame_faces,
                                                baked.vertex_normals_shaded)
    warnings += [frames] if frames else []
    world = positions @ matrix[:3, :3].T + matrix[:3, 3]
    problem = IC.collapsed_mesh_problem(what, world, tris)
    if problem:
        out.append(problem)
    if uv is not None:
        problem = IC.finite_problem(f"the UVs of UV map {uv_map!r} of object {obj.name!r}",
                                    uv, "unwrap it again (UV > Unwrap)")
        if problem:
            out.append(problem)
        else:
            problem = IC.collapsed_uv_problem(uv_map, obj.name, uv)
            if problem:
                out.append(problem)
            else:
                hole = IC.collapsed_uv_faces_warning(uv_map, obj.name, uv, world, tris,
                                                     baked.triangle_faces)
                warnings += [hole] if hole else []
    out += read_uv_map_problems(obj, baked.triangle_uvs, uv_map, only)
    far = float(np.max(np.linalg.norm(world, axis=1))) if len(world) else 0.0  # Euclidean
    if far > FAR_FROM_ORIGIN_M:
        warnings.append(f"object {obj.name!r} reaches {far:.0f} m from the origin: the bake "
                        f"keeps its mesh in object space for precision (addon/precise_bake.py), "
                        f"but renders of it there lose precision in bump-derived normals; "
                        f"keep the scene near the origin for renders")
    if uv is not None and tiles and resolution:
        warnings += overlap_warnings(uv, tiles, resolution, f"UV map {uv_map!r} of object "
                                                            f"{obj.name!r}")
    return out


def zero_scale_problem(obj, matrix):
    """An object whose world matrix squashes an axis to nothing (a zero scale axis): its
    normals cannot be transformed (a singular matrix), the map would be garbage."""
    m = np.asarray(matrix, dtype=np.float64)[:3, :3]
    lengths = np.linalg.norm(m, axis=0)
    sv = np.linalg.svd(m, compute_uv=False)
    if lengths.min() > 0 and sv.min() > 1e-12 * max(sv.max(), 1e-300):
        return None
    scale = tuple(round(float(v), 6) for v in obj.scale)
    # Its own scale may be whole while the delta scale, a parent or a constraint zeroes an axis.
    where = "" if 0.0 in scale else (": the zero comes from its delta scale, a parent or a "
                                     "constraint")
    return (f"object {obj.name!r}: its scale has a zero axis (scale {scale}, its world matrix "
            f"is singular{where}), so its normals cannot be baked: apply a non-zero scale on "
            f"every axis")


def overlap_warnings(uv, tiles, resolution, what):
    """A warning per tile whose texels overlapping UV islands contest (counted at up to
    OVERLAP_CHECK_SIZE texels a side, which bounds its cost)."""
    size = min(int(resolution), OVERLAP_CHECK_SIZE)
    out = []
    for tile in tiles:
        n = UV.contested_texels(uv, size, T.tile_uv_offset(tile))
        if n:
            out.append(f"{what}: {_percent(n, size ** 2)}% of tile {tile}'s texels lie "
                       f"under more than one face (overlapping UV islands, e.g. mirrored "
                       f"halves stacked); the map keeps only the face last in mesh order "
                       f"there: give each island its own UV space if both sides differ")
    return out


def _percent(n, total):
    """n of total as a percentage of at most two significant digits, never in exponent form
    (Python's 2g wrote 100% as "1e+02%") and 100 only when all of them are."""
    share = 100.0 * n / total
    if share < 10:
        return f"{share:.2g}"
    return "100" if n == total else f"{min(round(share), 99)}"


def output_problems(output, finals, overwrite):
    """The output's folder takes a file (probed: created and removed) and no file it would
    write exists unless overwrite."""
    out = []
    folder = Path(output).parent
    problem = folder_problem(folder)
    if problem:
        out.append(problem)
    # A named pipe, a device or a socket (or a link to one, such as /dev/null) where a file
    # goes: the finished map was renamed over it, exit 0, even as compare refuses one (red
    # team 56c). Not a file the user asked to replace; --overwrite does not change that.
    odd = [p for p in finals.values() if p.exists() and not p.is_file() and not p.is_dir()]
    if odd:
        link = f", through a symbolic link to {os.readlink(odd[0])!r}" \
            if odd[0].is_symlink() else ""
        out.append(f"output {str(odd[0])!r} is not a regular file (a named pipe, device or "
                   f"socket{link}): a "
                   f"bake would replace it with the map, even with --overwrite; give a file "
                   f"path")
    # A symbolic link to nothing (an unmounted share, a moved file): it "existed" only at the
    # publish, after the bake ("exists; pass --overwrite", exit 2), and --overwrite replaced
    # the link with the map (exit 0), the share's file never written. Named with its target.
    dangling = [p for p in finals.values() if p.is_symlink() and not p.exists()]
    if dangling:
        out.append(f"output {str(dangling[0])!r} is a symbolic link to "
                   f"{os.readlink(dangling[0])!r}, which does not exist (an unmounted share "
                   f"or a moved file?): mount or restore it, or remove the link, and bake "
                   f"again")
    # lexists: a link to a file not there yet is a file the bake would replace too; exists()
    # follows it, and the bake ran in full before placing the map refused it (rt57a).
    existing = [str(p) for p in finals.values()
                if os.path.lexists(p) and p not in odd and p not in dangling]
    if existing and not overwrite:
        out.append(f"{existing[0]} exists; pass --overwrite (api: overwrite=True) to replace "
                   f"it")
    return out


def _exists(path):
    """Whether `path` exists; OSError for one the file system cannot name (too long), which
    Path.exists takes as "no" on some Python versions (the folder was then made later and the
    batch stopped with a traceback)."""
    try:
        os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return False
    return True


def name_problem(path, what="output"):
    """None, or why the file system will not take `path` as a name (too long): asked before a
    command that writes it at the end has done its work."""
    try:
        _exists(path)
    except OSError as err:
        shown = str(path) if len(str(path)) <= 120 else f"{str(path)[:120]}..."
        return (f"{what} {shown!r} ({len(os.fsencode(str(path)))} bytes) cannot be used "
                f"({err.strerror}): give a shorter name (most file systems take 255 bytes a "
                f"name, 4096 a path)")
    return None


def folder_problem(folder):
    """None when a file can be created in `folder` (tried: a probe file is made and removed),
    else what is wrong and the fix. A missing folder is checked at its nearest existing parent
    (bake-batch creates the rest)."""
    folder = Path(folder) if str(folder) else Path(".")
    probe_in = folder
    try:
        while not _exists(probe_in) and probe_in.parent != probe_in:
            if os.path.islink(probe_in):    # mkdir would stop at it: File exists
                return (f"output folder {str(folder)!r}: {str(probe_in)!r} is a symbolic "
                        f"link to {os.readlink(probe_in)!r}, which does not exist (an "
                        f"unmounted share or a moved folder?): mount or create it, or give "
                        f"another folder")
            probe_in = probe_in.parent
        # a folder still to be made whose name the file system will not take (the lookup
        # of a missing parent stops before the name's length is checked)
        name_max = NB._name_max(probe_in)
        if any(len(os.fsencode(part)) > name_max for part in folder.parts):
            raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG))
    except OSError as err:     # a path or a folder name too long for the file system
        if err.errno == errno.ELOOP:
            return (f"output folder {str(folder)!r} cannot be used (a loop of symbolic links: "
                    f"{err.strerror}): fix the links, or give another folder")
        shown = str(folder) if len(str(folder)) <= 120 else f"{str(folder)[:120]}..."
        return (f"output folder {shown!r} ({len(os.fsencode(folder))} bytes) cannot be used "
                f"({err.strerror}): give a shorter folder path (most file systems take 255 "
                f"bytes a name, 4096 a path)")
    if not probe_in.is_dir():
        return f"output folder {str(folder)!r}: {str(probe_in)!r} is a file, not a folder"
    try:
        fd, name = tempfile.mkstemp(prefix=".surfgrad-probe-", dir=probe_in)
        try:
            os.close(fd)
        finally:    # (Ctrl-C in a session between the two left the probe in the output folder)
            os.unlink(name)
    except OSError as err:
        return (f"output folder {str(probe_in)!r} is not writable ({err.strerror}): pick a "
                f"folder you can write to, or fix its permissions")
    return None
