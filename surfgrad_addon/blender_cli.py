"""Run surfgrad's command line inside Blender:

    blender -b --disable-autoexec FILE \\
        --python-exit-code 1 --python surfgrad_addon/blender_cli.py -- compare ...

Arguments after `--` are those of `python -m surfgrad_addon`. Without --blend, `compare` works
on the file Blender opened.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from surfgrad_addon.addon.command_line import blender_exits_next, leave  # noqa: E402
from surfgrad_addon.harness.cli import main  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
code = main(argv, in_blender=True)
# (Blender goes on after a script that returns 0 with its UI or the arguments that follow
# it: leave, which ignores the stop signals, only where it exits next)
if code:
    sys.exit(leave(code))
import bpy  # noqa: E402  (Blender's, as the script runs in it)
if blender_exits_next(sys.argv, bpy.app.background, __file__):
    leave(code)
