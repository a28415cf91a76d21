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
