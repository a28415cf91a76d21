"""The operator tests' child sessions: the test file runs itself as a script in a fresh Blender
with its own BLENDER_USER_RESOURCES (nothing registered in the pytest process, nothing written to
the real user folder), writes report.json and prints a marker; the pytest side runs it and reads
the report."""

import json
import time
from pathlib import Path

REPORT = "report.json"


def write_report(work, report, marker):
    """The session's last step: the report where the pytest side reads it, then the marker."""
    (Path(work) / REPORT).write_text(json.dumps(report, indent=1))
    print(marker, flush=True)


def run_session(script, tmp_path_factory, name, marker):
    """Run `script WORK` in a child; returns its report with the child's stdout, stderr and
    wall time added. Skips without bpy; fails unless the child exits 0 having printed `marker`."""
    import pytest

    from support.child import run_python

    pytest.importorskip("bpy")
    user = tmp_path_factory.mktemp(f"user_{name}")
    work = tmp_path_factory.mktemp(name)
    t0 = time.perf_counter()
    out = run_python([Path(script).resolve(), work], cwd=work, timeout=300,
                     env={"BLENDER_USER_RESOURCES": str(user)})
    assert out.returncode == 0 and marker in out.stdout, \
        f"{name} session failed:\n{out.stdout[-3000:]}\n{out.stderr[-5000:]}"
    report = json.loads((work / REPORT).read_text())
    report.update(stdout=out.stdout, stderr=out.stderr, seconds=time.perf_counter() - t0)
    return report
