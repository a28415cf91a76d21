"""Tests whose subject is the same on every Blender line, run on the main line only.

`bash run.sh test` runs the suite once per line, one line after another. A few tests check
this project's own code or tools with nothing of Blender's line in what they assert (the
layering of imports, the instruction bench whose figures come from the main line) and take
minutes each; the older lines skip them, saying why. The line is read from the venv's bpy
wheel without importing bpy, so numpy-tier modules may use this too."""

from importlib import metadata

import pytest

from surfgrad_addon.reference.blender_lines import MAIN_LINE


def installed_line():
    """The line of this venv's bpy wheel ("5.2", "4.2", ...), or None without one."""
    try:
        version = metadata.version("bpy")
    except metadata.PackageNotFoundError:
        return None
    return ".".join(version.split(".")[:2])


def main_line_only(why):
    """Skip on an older line; `why` says what makes the test's subject line-independent."""
    line = installed_line()
    return pytest.mark.skipif(line is not None and line != MAIN_LINE.line,
                              reason=f"main line ({MAIN_LINE.line}) only: {why}")
