"""The Flamenco job type (tools/farm/flamenco/surfgrad-bake.js) compiled with node against
flamenco_compile.js's stand-in for the Manager, and a compiled task run as a worker would."""

import json
import shutil
import subprocess

import pytest

from .child import ROOT, run_python

JOB_TYPE = ROOT / "tools" / "farm" / "flamenco" / "surfgrad-bake.js"


def compile_job(settings, script=JOB_TYPE):
    """The job (or {"error": ...}) the job type compiles from `settings`; skips without node."""
    node = shutil.which("node")
    if not node:
        pytest.skip("node is not installed (the Flamenco job type is JavaScript)")
    res = subprocess.run([node, str(ROOT / "tests" / "support" / "flamenco_compile.js"),
                          str(script), json.dumps(settings)], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def run_task_as_worker(task):
    """Run a compiled task's one command as a worker's Blender would (the farm's copy opened,
    the extension's commands module loaded, the arguments on sys.argv), with the bpy module;
    returns the CompletedProcess."""
    p = task["commands"][0]["parameters"]
    expr = p["args"][p["args"].index("--python-expr") + 1]
    code = ("import sys, bpy\n"
            f"bpy.ops.wm.open_mainfile(filepath={p['blendfile']!r})\n"
            "import surfgrad_addon.addon.commands\n"
            f"sys.argv = ['blender', '-b', '-y', {p['blendfile']!r}] + {p['args']!r}\n"
            f"exec({expr!r})\n")
    return run_python(["-c", code])
