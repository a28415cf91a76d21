"""A stop and the files a command puts in place (interrupts.committing / placed).

CI once found compare-all's output folder left behind after Ctrl-C: the watcher thread ran
the clean-up (remove this run's heat maps, then the folders) while the main thread went on
and wrote one more heat map, so the folder was not empty. Now a stop waits for a commit under
way, parks the main thread (it runs no more Python), and removes what the command placed.
These tests make the race certain: the clean-up is slow and the main thread would go on
writing meanwhile."""

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from support.child import ROOT

pytestmark = pytest.mark.tier("child")

# The child: a commit of two files with the signal arriving between them, a slow clean-up
# (like killing workers), and a main thread that asks for commits all the while.
CHILD = r"""
import os, sys, time
from pathlib import Path
from surfgrad_addon.addon import interrupts
out, keep = Path(sys.argv[1]), sys.argv[2] == "keep"

def cleanup(name):
    os.write(2, ("clean-up saw " + ",".join(sorted(p.name for p in out.iterdir())) + "\n")
             .encode())
    time.sleep(1.5)

with interrupts.stoppable("the test", keep_placed=keep), interrupts.on_stop(cleanup):
    (out / "before").write_text("not placed")
    with interrupts.committing():
        for name in ("a", "b"):
            interrupts.placed(out / name)
            (out / name).write_text(name)
            if name == "a":
                print("ready", flush=True)
                time.sleep(1.0)                    # the signal arrives here
    for i in range(300):
        with interrupts.committing():
            interrupts.placed(out / f"late{i}")
            (out / f"late{i}").write_text("late")
        time.sleep(0.01)
print("finished", flush=True)
"""


def _stop_mid_commit(tmp_path, keep):
    out = tmp_path / "out"
    out.mkdir()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(out),
                              "keep" if keep else "remove"], cwd=ROOT, env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "ready"
    child.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    stdout, stderr = child.communicate(timeout=60)
    return child.returncode, time.monotonic() - t0, sorted(p.name for p in out.iterdir()), \
        stdout, stderr


def test_a_stop_waits_for_the_commit_then_removes_what_was_placed(tmp_path):
    code, elapsed, left, stdout, stderr = _stop_mid_commit(tmp_path, keep=False)
    assert code == 130, stderr
    assert "surfgrad: interrupted by SIGINT: stopped the test" in stderr
    assert "finished" not in stdout and "Traceback" not in stderr
    # The placed files went before the clean-up ran, and no commit came after it.
    assert "clean-up saw before\n" in stderr, stderr
    assert left == ["before"]
    assert 1.5 <= elapsed < 10, elapsed                 # the commit, then the slow clean-up


def test_keep_placed_leaves_the_whole_commit_and_nothing_after_it(tmp_path):
    """A batch keeps the maps it baked; the clean-up still sees the commit whole."""
    code, _elapsed, left, _stdout, stderr = _stop_mid_commit(tmp_path, keep=True)
    assert code == 130, stderr
    assert "clean-up saw a,b,before\n" in stderr, stderr
    assert left == ["a", "b", "before"]


def test_placed_records_nothing_outside_a_stoppable_block(tmp_path):
    """The Python API and the operators have no stop handling: nothing is recorded."""
    from surfgrad_addon.addon import interrupts
    before = list(interrupts._state["placed"])
    with interrupts.committing():
        interrupts.placed(tmp_path / "x")
    assert interrupts._state["placed"] == before == []


# The child: a main thread writing a file every millisecond outside any commit (as the demo's
# stages do), and a slow clean-up that counts the files at its start and at its end.
WRITER = r"""
import os, sys, time
from pathlib import Path
from surfgrad_addon.addon import interrupts
out = Path(sys.argv[1])

def cleanup(name):
    first = len(list(out.iterdir()))
    time.sleep(1.0)
    os.write(2, f"clean-up saw {first} then {len(list(out.iterdir()))}\n".encode())

with interrupts.stoppable("the test"), interrupts.on_stop(cleanup):
    print("ready", flush=True)
    for i in range(100000):
        (out / f"f{i}").write_text("x")
        time.sleep(0.001)
"""


def test_a_stop_parks_the_main_thread_before_the_clean_ups(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    child = subprocess.Popen([sys.executable, "-c", WRITER, str(out)], cwd=ROOT,
                             env=dict(os.environ, PYTHONPATH=str(ROOT)),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "ready"
    time.sleep(0.3)                                     # some files written
    child.send_signal(signal.SIGTERM)
    _stdout, stderr = child.communicate(timeout=60)
    assert child.returncode == 143, stderr
    first, last = map(int, re.search(r"clean-up saw (\d+) then (\d+)", stderr).groups())
    assert first > 10 and last == first, stderr         # nothing written during the clean-up
