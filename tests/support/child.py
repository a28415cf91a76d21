"""The one way the suite runs a child interpreter: the same Python (so the same Blender line),
PYTHONPATH set to the checkout (and tests/ for the support package) unless told to leave it out
(an installed extension's session must not see the checkout), output captured."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def run_python(args, cwd=None, env=None, timeout=300, checkout=True):
    """Run `python ARGS`; returns the CompletedProcess. env: extra variables. checkout: put the
    repository (and tests/) on PYTHONPATH; False keeps the child from importing it."""
    full = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if checkout:
        full["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(ROOT / "tests")])
    full.update(env or {})
    return subprocess.run([sys.executable, *map(str, args)], cwd=str(cwd or ROOT), env=full,
                          capture_output=True, text=True, timeout=timeout)


# Python source that makes the child refuse bpy (and mathutils, bmesh) as a Python without
# Blender does (ModuleNotFoundError: pytest.importorskip skips): prefix it to `-c` code to prove
# something imports without Blender.
NO_BPY = ("import sys\n"
          "class Block:\n"
          "    def find_spec(self, name, path=None, target=None):\n"
          "        if name.split('.')[0] in ('bpy', 'mathutils', 'bmesh'):\n"
          "            raise ModuleNotFoundError('blocked: ' + name, name=name)\n"
          "sys.meta_path.insert(0, Block())\n")


def run_without_bpy(code, timeout=120):
    """Run `code` in a child that refuses bpy (NO_BPY first); returns its stdout, and fails the
    test unless it exited 0."""
    out = run_python(["-c", NO_BPY + code], timeout=timeout)
    assert out.returncode == 0, out.stderr
    return out.stdout
