"""`blender -c surfgrad ...`: the TD commands of the installed extension, registered with
Blender's own `bpy.utils.register_cli_command` (4.2 and later).

    blender -c surfgrad bake-normal-map --blend scene.blend --object Rock \\
        --output rock_normal.exr [--space tangent|object] [--resolution 2048] [--uv-map NAME] \\
        [--margin 16] [--overwrite]

Bad input prints one line naming the thing and the fix and returns a non-zero exit code, no
traceback. The proving harness's commands (compare, bench, demo) run from a checkout:
`python -m surfgrad_addon ...`.
"""

import argparse
import sys

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
    return nb


def parser():
    p = argparse.ArgumentParser(prog=f"blender -c {COMMAND}",
                                description="surfgrad commands for pipelines")
    add_bake_normal_map(p.add_subparsers(dest="command", required=True))
    return p


def run_bake_normal_map(args):
    """bake-normal-map with parsed options: open --blend (if given), bake --object. Raises
    ValueError (or NormalBakeError) naming the problem."""
    import bpy
    from .normal_bake import bake_normal_map
    if args.blend:
        from pathlib import Path
        if not Path(args.blend).is_file():
            raise ValueError(f".blend file {args.blend!r} does not exist")
        bpy.ops.wm.open_mainfile(filepath=args.blend)
    obj = bpy.data.objects.get(args.object)
    if obj is None:
        raise ValueError(f"no object named {args.object!r}; objects: "
                         f"{sorted(o.name for o in bpy.data.objects)}")
    return bake_normal_map(obj, args.output, args.space, args.resolution, args.uv_map,
                           args.margin, overwrite=args.overwrite)


def execute(argv):
    """Run a command; returns the exit code (what Blender's -c passes back)."""
    try:
        args = parser().parse_args(list(argv))
    except SystemExit as ex:                    # argparse printed the usage line
        return ex.code if isinstance(ex.code, int) else 2
    try:
        run_bake_normal_map(args)
    except (ValueError, KeyError, RuntimeError, FileExistsError) as err:
        print(f"surfgrad: error: {err}", file=sys.stderr)
        return 2
    return 0


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
