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
traceback. The proving harness's commands (compare, bench, demo) run from a checkout:
`python -m surfgrad_addon ...`.
"""

import argparse
import sys
from pathlib import Path

from .exit_codes import OK, code_for

COMMAND = "surfgrad"
_handle = None


def add_bake_normal_map(sub):
    """The bake-normal-map subcommand and its options (also python -m surfgrad_addon's)."""
    nb = sub.add_parser("bake-normal-map", help="bake an object's material into a normal map "
                                                "file (PNG or EXR)")
    nb.add_argument("--blend", default=None, help=".blend file to open (default: the file "
                                                  "Blender opened)")
    nb.add_argument("--object", required=True, help="mesh object to bake")
    nb.add_argument("--output", required=True, help="file to write: .png (8-bit) or .exr "
                                                    "(float)")
    nb.add_argument("--space", default="tangent", choices=("tangent", "object"))
    nb.add_argument("--resolution", type=int, default=1024)
    nb.add_argument("--uv-map", default=None, help="UV map (default: the active render one)")
    nb.add_argument("--margin", type=int, default=16, help="texels to extend past UV borders")
    nb.add_argument("--overwrite", action="store_true", help="replace an existing file")
    nb.add_argument("--samples", type=int, default=1,
                    help="Cycles samples per texel: more anti-alias detail finer than a texel "
                         "(default 1)")
    nb.add_argument("--depth", default=None, choices=("auto", "8", "16", "half", "float"),
                    help="bit depth: 8 or 16 for .png (default 8), half or float for .exr "
                         "(default float)")
    nb.add_argument("--tiles", default=None,
                    help="UDIM tiles to bake, e.g. 1001,1002 or 1001-1010 (default: every tile "
                         "the UV map has faces in; needs <UDIM> in --output for more than 1001)")
    nb.add_argument("--allow-partial", action="store_true",
                    help="bake a UV layout with faces outside the UDIM range (u 0..10, v >= "
                         "0); those faces are left out, with a warning (default: refused)")
    return nb


def add_bake_batch(sub):
    """The bake-batch subcommand (also python -m surfgrad_addon's)."""
    bb = sub.add_parser("bake-batch", help="bake many objects, collections or .blend files "
                                           "into normal maps (UDIM tiles, several processes)")
    bb.add_argument("blends", nargs="*", metavar="FILE.blend[:OBJECT]",
                    help=".blend files to bake, optionally naming one object each")
    bb.add_argument("--asset-list", default=None,
                    help="text file of FILE.blend[:OBJECT] lines (relative to the list)")
    bb.add_argument("--asset-index", type=int, default=None,
                    help="bake only this line of --asset-list (0-based; a farm task)")
    bb.add_argument("--open-file", action="store_true",
                    help="bake the file Blender opened (a farm task started with the file)")
    bb.add_argument("--output", required=True,
                    help="output pattern: {file}, {object}, {uv} and <UDIM> tokens, ending in "
                         ".png or .exr, e.g. maps/{file}/{object}_normal.<UDIM>.png")
    bb.add_argument("--objects", nargs="+", default=None,
                    help="object names (shell wildcards) to bake in every file (default: every "
                         "mesh object with a material)")
    bb.add_argument("--collections", nargs="+", default=None,
                    help="collections whose mesh objects to bake")
    bb.add_argument("--settings", default=None,
                    help='JSON of per-asset settings: {"defaults": {...}, "assets": {"file.blend'
                         ':Object" or "Object" (wildcards): {"resolution": 4096, ...}}}')
    bb.add_argument("--space", default=None, choices=("tangent", "object"))
    bb.add_argument("--resolution", type=int, default=None, help="texels per side (default "
                                                                 "1024)")
    bb.add_argument("--uv-map", default=None, help="UV map (default: the active render one)")
    bb.add_argument("--margin", type=int, default=None, help="texels past UV borders (16)")
    bb.add_argument("--samples", type=int, default=None, help="samples per texel (default 1)")
    bb.add_argument("--depth", default=None, choices=("auto", "8", "16", "half", "float"),
                    help="8/16 for .png, half/float for .exr")
    bb.add_argument("--tiles", default=None, help="only these UDIM tiles, e.g. 1001-1002")
    bb.add_argument("--allow-partial", action="store_true", default=None,
                    help="bake UV layouts with faces outside the UDIM range, with a warning "
                         "(default: that asset is refused; settings key allow_partial)")
    bb.add_argument("--if-tile-empty", default="error", choices=("error", "skip"),
                    help="a tile asked for with no UVs of an asset: refuse (default) or skip "
                         "(farm tasks over asset x tile)")
    bb.add_argument("--workers", type=int, default=1,
                    help="separate Blender processes baking at once (0: this process)")
    bb.add_argument("--worker-timeout", type=float, default=None, metavar="SECONDS",
                    help="seconds one scan or bake may take in a worker before the worker is "
                         "taken as hung, killed and the asset failed (default: 5 minutes plus "
                         "10 s per million texel-samples of the bake)")
    bb.add_argument("--threads", type=int, default=None,
                    help="Cycles threads per bake (default: every core, shared out between "
                         "workers)")
    bb.add_argument("--force", action="store_true", help="bake assets whose inputs and "
                                                         "settings are unchanged too")
    bb.add_argument("--overwrite", action="store_true",
                    help="replace existing files the manifest does not record as ours")
    bb.add_argument("--manifest", default=None,
                    help="manifest JSON (default: surfgrad-bake-manifest.json in the output "
                         "pattern's fixed folder)")
    return bb


def parser():
    p = argparse.ArgumentParser(prog=f"blender -c {COMMAND}",
                                description="surfgrad commands for pipelines")
    sub = p.add_subparsers(dest="command", required=True)
    add_bake_normal_map(sub)
    add_bake_batch(sub)
    return p


def run_bake_batch(args, log=print):
    """bake-batch with parsed options; returns the exit code: 0 when every asset was baked or
    skipped, 1 when any failed (each named in the log and the manifest)."""
    from . import batch, interrupts
    with interrupts.stoppable("the batch"):
        return _bake_batch(batch, args, log)


def _bake_batch(batch, args, log):
    blends = list(args.blends)
    if args.asset_list:
        listed = batch.read_asset_list(args.asset_list)
        if args.asset_index is not None:
            if not 0 <= args.asset_index < len(listed):
                raise ValueError(f"asset index {args.asset_index}: the list "
                                 f"{args.asset_list} has {len(listed)} entries (0 to "
                                 f"{len(listed) - 1})")
            listed = [listed[args.asset_index]]
        blends += listed
    elif args.asset_index is not None:
        raise ValueError("--asset-index needs --asset-list")
    defaults = {k: getattr(args, k) for k in batch.SETTING_KEYS}
    report = batch.bake_batch(blends, args.output, args.objects, args.collections, defaults,
                              args.settings, args.workers, args.force, args.overwrite,
                              args.manifest, args.tiles, args.if_tile_empty, args.open_file,
                              log=log, threads=args.threads,
                              worker_timeout=getattr(args, "worker_timeout", None))
    failed = [a for a in report["assets"].values() if a.get("status") == "failed"]
    for a in failed:
        print(f"surfgrad: error: {Path(a['file']).name}:{a.get('object') or '*'}: "
              f"{a['error']}", file=sys.stderr)
    return 1 if failed else 0


def run_bake_normal_map(args):
    """bake-normal-map with parsed options: open --blend (if given), bake --object. Raises
    ValueError (or NormalBakeError) naming the problem."""
    from . import interrupts
    # Ctrl-C / SIGTERM: the bake stops, its temporary files go, exit 130 / 143 (interrupts.py).
    with interrupts.stoppable("the bake"), interrupts.partials_of(args.output):
        return _bake_normal_map(args)


def _bake_normal_map(args):
    import bpy
    from .bake_request import BakeRequest, bake
    if args.blend:
        if not Path(args.blend).is_file():
            raise ValueError(f".blend file {args.blend!r} does not exist")
        from .open_blend import open_mainfile
        open_mainfile(args.blend)          # scripts off, whatever the Preferences say
    request = BakeRequest(args.object, args.output, args.space, args.resolution, args.uv_map,
                          args.margin, args.samples, args.depth, args.tiles,
                          overwrite=args.overwrite, allow_partial=args.allow_partial)
    bake(request)
    return Path(args.output)


def execute(argv):
    """Run a command; returns the exit code (what Blender's -c passes back)."""
    try:
        args = parser().parse_args(list(argv))
    except SystemExit as ex:                    # argparse printed the usage line
        return ex.code if isinstance(ex.code, int) else 2
    try:
        if args.command == "bake-batch":
            return run_bake_batch(args)
        run_bake_normal_map(args)
    except (ValueError, KeyError, RuntimeError, FileExistsError) as err:
        print(f"surfgrad: error: {err}", file=sys.stderr)
        return code_for(err)
    return OK


def register():
    global _handle
    import bpy
    if _handle is None and hasattr(bpy.utils, "register_cli_command"):
        _handle = bpy.utils.register_cli_command(COMMAND, execute)


def unregister():
    global _handle
    import bpy
    if _handle is not None:
        bpy.utils.unregister_cli_command(_handle)
        _handle = None


def is_registered():
    return _handle is not None
