"""Run surfgrad's command line inside Blender:

    blender -b --disable-autoexec FILE \\
        --python-exit-code 1 --python surfgrad_addon/blender_cli.py -- compare ...

Arguments after `--` are those of `python -m surfgrad_addon`. Without --blend, `compare` works
on the file Blender opened.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from surfgrad_addon.addon.command_line import end_script  # noqa: E402
from surfgrad_addon.harness.cli import main  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
end_script(main(argv, in_blender=True), __file__)
