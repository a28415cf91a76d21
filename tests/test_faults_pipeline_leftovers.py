"""Fault injection, red team 30b: what red team 29b left. A batch killed with SIGKILL left
each worker's empty surfgrad-worker-* folder in $TMPDIR; a map the disk cut short was baked a
second time in a fresh process; a grey, grey+alpha or -1..1 float image feeding a Normal Map
baked without a word."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

from support.child import ROOT  # noqa: E402

pytestmark = pytest.mark.tier("bake")

# A batch's pool in miniature: start one worker, wait until it is ready (idle, reading its
# input), say where its folders are, and wait to be killed.
IDLE_PARENT = (
    "import sys, time\n"
    "from surfgrad_addon.addon.batch import workers\n"
    "from surfgrad_addon.addon.batch.worker_main import RESULT_MARK\n"
    "w = workers.Worker(workers.worker_command())\n"
    "while '\"ready\"' not in (line := w.lines.get(timeout=120)):\n"
    "    pass\n"
    "print(w.proc.pid, w.tempdir, flush=True)\n"
    "time.sleep(600)\n")


def _gone(pid, within_s):
    t0 = time.monotonic()
    while time.monotonic() - t0 < within_s:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return True
        if state == "Z":
            return True
        time.sleep(0.1)
    return False


@pytest.mark.tier("child")
@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="reads /proc")
def test_an_idle_worker_whose_batch_was_killed_removes_its_temp_folder(tmp_path):
    """The batch SIGKILLed while its worker waits for work: the worker's input ends and it
    exits. Before: its empty surfgrad-worker-* folder stayed in $TMPDIR (the batch removes it
    only once the worker has ended, and a killed batch never does). A folder the worker was not
    given stays."""
    temp = tmp_path / "tmp"
    temp.mkdir()
    (temp / "surfgrad-worker-not-mine").mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(ROOT), TMPDIR=str(temp))
    parent = subprocess.Popen([sys.executable, "-c", IDLE_PARENT], cwd=str(ROOT), env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    worker = None
    try:
        pid, folder = parent.stdout.readline().split()
        worker = int(pid)
        assert Path(folder).parent == temp and Path(folder).is_dir()
        assert any(p.name.startswith("blender_") for p in Path(folder).iterdir())
        parent.kill()
        parent.wait(10)
        assert _gone(worker, 10), "the worker outlived its batch by 10 s"
    finally:
        parent.kill()
        if worker is not None and not _gone(worker, 0.1):
            os.kill(worker, signal.SIGKILL)
    left = sorted(p.name for p in temp.iterdir())
    assert [n for n in left if n.startswith("surfgrad-worker-")] == \
        ["surfgrad-worker-not-mine"], left
