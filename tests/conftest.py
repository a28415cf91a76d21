"""Shared test helpers: the `fresh` file fixture, the tiers (tests/support/tiers.py), and the
report directory that `bash run.sh test` collects per Blender line.

`bash run.sh test` runs this suite once per supported Blender line, each in its own venv, and
sets SURFGRAD_REPORT_DIR; tests that produce figures for the lines' summary
(tools/lines_summary.py) write them there as <name>-<line>.json. Without the variable nothing
is written. The tiers' hooks write durations-<line>.json there (seconds and tests per tier).
"""

import json
import os
from pathlib import Path

import pytest

# The tiers (numpy, blender, bake, child, eevee): each test's declared tier becomes its marker,
# a guard fails a test that does more than its tier allows, durations per tier are recorded.
from support.tiers import (pytest_collection_finish, pytest_collection_modifyitems,  # noqa: F401
                           pytest_configure, pytest_runtest_call, pytest_runtest_logreport,
                           pytest_runtest_setup, pytest_sessionfinish)


def line_name():
    """The running Blender's line ("5.2", "4.2", ...), or None without bpy."""
    try:
        import bpy
    except ImportError:
        return None
    from surfgrad_addon.reference.blender_lines import facts_for
    return facts_for(bpy.app.version).line


def write_report(name, data):
    """Write data as <SURFGRAD_REPORT_DIR>/<name>-<line>.json when the variable is set."""
    folder = os.environ.get("SURFGRAD_REPORT_DIR")
    if not folder:
        return None
    import bpy
    path = Path(folder) / f"{name}-{line_name()}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"blender": bpy.app.version_string, "line": line_name(),
                                **data}, indent=1))
    return path


@pytest.fixture
def fresh():
    """An empty Blender file (factory settings, no objects): the state a test starts from."""
    bpy = pytest.importorskip("bpy")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy
