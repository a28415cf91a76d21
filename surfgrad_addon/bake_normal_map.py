"""Bake an object's material into a normal map file, inside Blender:

    blender -b --disable-autoexec scene.blend \\
        --python-exit-code 1 --python surfgrad_addon/bake_normal_map.py \\
        -- --object Rock --output rock_normal.png [--space tangent|object] [--resolution 2048] \\
        [--uv-map NAME] [--margin 16] [--overwrite]

The same as `python -m surfgrad_addon bake-normal-map --blend scene.blend ...` with the bpy
module. See surfgrad_addon/addon/normal_bake.py. --disable-autoexec comes before the file:
Blender opens it before this script runs, with the user's Auto Run preference otherwise, so
the file's text blocks and Python drivers would run.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from surfgrad_addon.addon.command_line import end_script  # noqa: E402
from surfgrad_addon.harness.cli import main  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
end_script(main(["bake-normal-map", *argv], in_blender=True), __file__)
