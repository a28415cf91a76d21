"""`blender -c surfgrad ...`: the TD commands of the installed extension, registered with
Blender's own `bpy.utils.register_cli_command` (4.2 and later).

    blender -c surfgrad bake-normal-map --blend scene.blend --object Rock \\
        --output rock_normal.exr [--space tangent|object] [--resolution 2048] [--uv-map NAME] \\
        [--margin 16] [--samples 16] [--depth 8|16|half|float] [--tiles 1001-1004] [--overwrite]
    blender -c surfgrad bake-batch assets/*.blend --output "maps/{file}/{object}.<UDIM>.png" \\
        [--objects NAME ...] [--collections NAME ...] [--settings per_asset.json] \\
        [--workers 4] [--force] [--manifest FILE] [the bake settings above]

Bad input prints one line naming the thing and the fix and returns a non-zero exit code
(addon/exit_codes.py: 2 refused before baking, 1 a bake or a batch asset failed), no
traceback. The two subcommands (SHIPPED) are also `python -m surfgrad_addon`'s, where the
proving harness's commands (compare, bench, demo) run from a checkout; their bake options come
from the bake request's fields (bake_options.py).
"""

import sys
from pathlib import Path

from . import bake_options as BO
from . import command_line as CL
from . import number_options as NO

COMMAND = "surfgrad"
_handle = None

# The request's settings, in the order --help lists them.
NORMAL_MAP_OPTIONS = ("space", "resolution", "uv_map", "margin", "overwrite", "samples", "depth",
                      "tiles", "allow_partial")
BATCH_SETTINGS = ("space", "resolution", "uv_map", "margin", "samples", "depth", "tiles",
                  "allow_partial")


def bake_normal_map_arguments(p):
    p.add_argument("--blend", default=None, help=".blend file to open (default: the file "
                                                 "Blender opened; needed where none is, as "
                                                 "with python -m or blender -c)")
    p.add_argument("--object", required=True, help="mesh object to bake")
    # The depth is --depth's (PNG 8 or 16, EXR half or float): this said ".png (8-bit)".
    p.add_argument("--output", required=True,
                   help="file to write: .png or .exr (bit depth: --depth); with <UDIM> in the "
                        "name, one file per UDIM tile (rock_nrm.<UDIM>.png)")
    BO.add(p, NORMAL_MAP_OPTIONS)


def bake_batch_arguments(p):
    p.add_argument("blends", nargs="*", metavar="FILE.blend[:OBJECT]",
                   help=".blend files to bake, optionally naming one object each")
    p.add_argument("--asset-list", default=None,
                   help="text file of FILE.blend[:OBJECT] lines (relative to the list)")
    p.add_argument("--asset-index", type=int, default=None,
                   help="bake only this line of --asset-list (0-based; a farm task)")
    p.add_argument("--open-file", action="store_true",
                   help="bake the file Blender opened (a farm task started with the file)")
    p.add_argument("--output", required=True,
                   help="output pattern: {file}, {object}, {uv} and <UDIM> tokens, ending in "
                        ".png or .exr, e.g. maps/{file}/{object}_normal.<UDIM>.png")
    p.add_argument("--objects", nargs="+", default=None,
                   help="object names (shell wildcards) to bake in every file (default: every "
                        "mesh object with a material)")
    p.add_argument("--collections", nargs="+", default=None,
                   help="collections whose mesh objects to bake")
    p.add_argument("--settings", default=None,
                   help='JSON of per-asset settings: {"defaults": {...}, "assets": {"file.blend'
                        ':Object" or "Object" (wildcards): {"resolution": 4096, ...}}}')
    # Left unset here, so that a settings file's defaults apply before the request's.
    BO.add(p, BATCH_SETTINGS, unset=True, helps={
        "tiles": "only these UDIM tiles, e.g. 1001-1002",
        "allow_partial": "bake UV layouts with faces outside the UDIM range, with a warning "
                         "(default: that asset is refused; settings key allow_partial)"})
    BO.add(p, ("empty_tiles",), helps={
        "empty_tiles": "a tile asked for with no UVs of an asset: refuse or skip (farm tasks "
                       "over asset x tile)"})
    p.add_argument("--workers", type=NO.whole(*NO.WORKERS_RANGE), default=1,
                   help="separate Blender processes baking at once (0: this process)")
    p.add_argument("--worker-timeout", type=NO.seconds(NO.WORKER_TIMEOUT_MAX), default=None,
                   metavar="SECONDS",
                   help="seconds one scan or bake may take in a worker before the worker is "
                        "taken as hung, killed and the asset failed (default: 5 minutes plus "
                        "10 s per million texel-samples of the bake)")
    BO.add(p, ("threads",), helps={"threads": "Cycles threads per bake (default: every core, "
                                              "shared out between workers)"})
    p.add_argument("--force", action="store_true", help="bake assets whose inputs and "
                                                        "settings are unchanged too")
    BO.add(p, ("overwrite",), helps={
        "overwrite": "replace existing files the manifest does not record as ours"})
    p.add_argument("--manifest", default=None,
                   help="manifest JSON (default: surfgrad-bake-manifest.json in the output "
                        "pattern's fixed folder)")


def run_bake_batch(args, log=print):
    """bake-batch with parsed options; returns the exit code: 0 when every asset was baked or
    skipped, 1 when any failed (each named in the log and the manifest). Inside Blender
    without files or a list it bakes the open file."""
    from . import batch, interrupts
    if getattr(args, "in_blender", False) and not args.blends and not args.asset_list:
        args.open_file = True
    # The asset list first, without Blender: a list that is wrong anyway is told so at once
    # (since bpy is loaded up front, below, it was told only after Blender had started).
    blends, list_tasks = _listed_blends(batch, args)
    # A stop keeps the maps already baked: the manifest records them (run.py).
    # (bpy loaded with the signals held: the batch itself scans the files, any --workers)
    with interrupts.stoppable("the batch", keep_placed=True, load_blender=True):
        return _bake_batch(batch, args, log, blends, list_tasks)


def _listed_blends(batch, args):
    """(.blend paths, list_tasks) of the request: --blends and this task's --asset-list
    entry; a list or index that names none is a ValueError."""
    blends, list_tasks = list(args.blends), None
    if args.asset_list:
        listed = batch.read_asset_list(args.asset_list)
        if args.asset_index is not None:
            if not listed:
                raise ValueError(f"asset index {args.asset_index}: the list "
                                 f"{args.asset_list} has no entries: add one .blend path a "
                                 f"line")
            if not 0 <= args.asset_index < len(listed):
                raise ValueError(f"asset index {args.asset_index}: the list "
                                 f"{args.asset_list} has {len(listed)} entries (0 to "
                                 f"{len(listed) - 1})")
            # the other entries are other tasks: one output file of two is refused
            list_tasks = (args.asset_list, [(i, e) for i, e in enumerate(listed)
                                            if i != args.asset_index])
            listed = [listed[args.asset_index]]
        blends += listed
    elif args.asset_index is not None:
        raise ValueError("--asset-index needs --asset-list")
    return blends, list_tasks


def _bake_batch(batch, args, log, blends, list_tasks):
    defaults = {k: getattr(args, k) for k in batch.SETTING_KEYS}
    report = batch.bake_batch(blends, args.output, args.objects, args.collections, defaults,
                              args.settings, args.workers, args.force, args.overwrite,
                              args.manifest, args.tiles, args.empty_tiles, args.open_file,
                              log=log, threads=args.threads,
                              worker_timeout=getattr(args, "worker_timeout", None),
                              list_tasks=list_tasks,
                              # (a file Blender's command line opened, no script between)
                              session_edits=False)
    failed = [a for a in report["assets"].values() if a.get("status") == "failed"]
    for a in failed:
        print(f"surfgrad: error: {Path(a['file']).name}:{a.get('object') or '*'}: "
              f"{a['error']}", file=sys.stderr)
    return 1 if failed else 0


def run_bake_normal_map(args):
    """bake-normal-map with parsed options: open --blend (if given, inside Blender too), bake
    --object. Raises ValueError (or NormalBakeError) naming the problem."""
    from . import interrupts
    from .normal_bake import brace_token_problem
    problem = brace_token_problem(args.output)
    if problem:                     # before --blend is opened: nothing has run
        raise ValueError(problem)
    # Ctrl-C / SIGTERM: the bake stops, its temporary files go, exit 130 / 143 (interrupts.py).
    with interrupts.stoppable("the bake", load_blender=True), \
            interrupts.partials_of(args.output):
        _bake_normal_map(args)


def _bake_normal_map(args):
    from .bake_request import BakeRequest, bake
    if args.blend:
        if not Path(args.blend).exists():      # a folder: open_mainfile names it
            raise ValueError(f".blend file {args.blend!r} does not exist")
        from .open_blend import open_mainfile
        open_mainfile(args.blend)          # scripts off, whatever the Preferences say
    request = BakeRequest(args.object, args.output,
                          **{name: getattr(args, name) for name in NORMAL_MAP_OPTIONS})
    import bpy
    if not args.blend and not bpy.data.filepath and not request.own_problems():
        # No file opened: Blender's startup scene is open (`python -m surfgrad_addon`, or
        # `blender -c`), whose 'Cube' baked with exit 0 for a --blend left out.
        raise ValueError(f"no --blend given and no saved .blend is open (Blender's startup "
                         f"scene is, so its {args.object!r} would be baked): give the file "
                         f"with --blend FILE.blend")
    bake(request)


SHIPPED = (
    CL.Subcommand("bake-normal-map", "bake an object's material into a normal map file (PNG or "
                  "EXR)", bake_normal_map_arguments, run_bake_normal_map, stops_itself=True),
    CL.Subcommand("bake-batch", "bake many objects, collections or .blend files into normal "
                  "maps (UDIM tiles, several processes)", bake_batch_arguments, run_bake_batch,
                  stops_itself=True),
)


def parser():
    return CL.parser(SHIPPED, f"blender -c {COMMAND}", "surfgrad commands for pipelines")


def execute(argv):
    """Run a command; returns the exit code (what Blender's -c passes back)."""
    try:
        args = parser().parse_args(list(argv))
    except SystemExit as ex:                    # argparse printed the usage line
        return ex.code if isinstance(ex.code, int) else 2
    return CL.run(SHIPPED, args)


def _execute_and_leave(argv):
    """execute for Blender's -c, after which Blender exits (command_line.leave)."""
    return CL.leave(execute(argv))


def register():
    global _handle
    import bpy
    if _handle is None and hasattr(bpy.utils, "register_cli_command"):
        _handle = bpy.utils.register_cli_command(COMMAND, _execute_and_leave)


def unregister():
    global _handle
    import bpy
    if _handle is not None:
        bpy.utils.unregister_cli_command(_handle)
        _handle = None


def is_registered():
    return _handle is not None
