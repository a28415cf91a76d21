"""The main job's output folder is written whole or not at all (harness/staged_folder.py): a
failure or a stop leaves the folder as it was (a stopped rerun used to leave 241 files of a
half run, or a mix of two runs under the old page), and a finished run replaces only the
entries it wrote."""

import os
import signal
import subprocess
import sys
import time

import pytest

from support.child import ROOT
from surfgrad_addon.harness.staged_folder import problem, staged

pytestmark = pytest.mark.tier("child")


def _state(folder):
    """{relative path: (size, mtime_ns)} of every file, and the folders, under `folder`."""
    found = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            p = os.path.join(root, name)
            st = os.stat(p)
            found[os.path.relpath(p, folder)] = (st.st_size, st.st_mtime_ns)
    return found


def _siblings(folder):
    return sorted(p.name for p in folder.parent.iterdir() if p.name != folder.name)


def test_a_finished_run_replaces_its_own_entries_and_keeps_the_others(tmp_path):
    final = tmp_path / "demo"
    (final / "compare").mkdir(parents=True)
    (final / "compare" / "stale.png").write_text("old heat map")
    (final / "index.html").write_text("old page")
    (final / "notes.txt").write_text("the user's")
    with staged(final, overwrite=True) as work:
        assert work.parent == tmp_path and work.name.startswith(".demo.partial-")
        (work / "compare").mkdir()
        (work / "compare" / "new.png").write_text("new heat map")
        (work / "index.html").write_text("new page")
    assert (final / "index.html").read_text() == "new page"
    assert sorted(p.name for p in (final / "compare").iterdir()) == ["new.png"]
    assert (final / "notes.txt").read_text() == "the user's"
    assert _siblings(final) == []                       # no working or old folder left


def test_a_new_folder_and_its_parents_appear_only_at_the_end(tmp_path):
    final = tmp_path / "a" / "b" / "demo"
    with staged(final, overwrite=False) as work:
        (work / "x.npy").write_text("x")
        assert not final.exists()
    assert (final / "x.npy").read_text() == "x"


def test_a_failure_leaves_the_folder_as_it_was(tmp_path):
    final = tmp_path / "demo"
    final.mkdir()
    (final / "index.html").write_text("last complete run")
    before = _state(final)
    with pytest.raises(RuntimeError, match="stage 3 failed"):
        with staged(final, overwrite=True) as work:
            (work / "index.html").write_text("half a run")
            raise RuntimeError("stage 3 failed")
    assert _state(final) == before and _siblings(final) == []
    # A folder made for the run goes too, with the parents made for it.
    fresh = tmp_path / "new" / "deeper" / "demo"
    with pytest.raises(KeyboardInterrupt):
        with staged(fresh, overwrite=False) as work:
            (work / "x").write_text("x")
            raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]


def test_only_a_write_the_disk_refused_becomes_the_full_disk_message(tmp_path):
    """A full disk mid-run is one line naming the folder (BakeFailed); an OSError of the run's
    own, a missing input, passes unchanged, and neither leaves anything."""
    import errno
    from surfgrad_addon.addon.exit_codes import BakeFailed
    final = tmp_path / "demo"
    with pytest.raises(BakeFailed, match="free space on that disk"):
        with staged(final, overwrite=False):
            raise OSError(errno.ENOSPC, "No space left on device")
    with pytest.raises(FileNotFoundError, match="input.exr"):
        with staged(final, overwrite=False):
            raise FileNotFoundError(errno.ENOENT, "No such file", "input.exr")
    assert list(tmp_path.iterdir()) == []


def test_refused_before_anything_is_made(tmp_path):
    final = tmp_path / "demo"
    final.mkdir()
    (final / "summary.json").write_text("{}")
    assert "exists; pass --overwrite" in problem(final, overwrite=False)
    assert problem(final, overwrite=True) is None
    assert problem(tmp_path / "empty-or-missing", overwrite=False) is None
    (tmp_path / "file").write_text("")
    assert "is a file" in problem(tmp_path / "file", overwrite=True)
    with pytest.raises(FileExistsError):
        with staged(final, overwrite=False):
            pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo", "file"]


def test_a_stopped_rerun_of_the_main_job_leaves_the_last_run_as_it_was(tmp_path):
    out = tmp_path / "demo"
    args = [sys.executable, "-m", "surfgrad_addon", "demo", "--out", str(out), "--no-bake",
            "--resolution", "96"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    first = subprocess.run(args, cwd=ROOT, env=env, capture_output=True, text=True,
                           timeout=300)
    assert first.returncode == 0, first.stderr[-2000:]
    before = _state(out)
    assert "index.html" in before and len(before) > 50
    run = subprocess.Popen(args + ["--overwrite"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    for line in run.stdout:                             # the reference stage is writing
        if "rasterised" in line:
            break
    time.sleep(0.2)
    run.send_signal(signal.SIGINT)
    _stdout, stderr = run.communicate(timeout=60)
    assert run.returncode == 130, stderr[-2000:]
    assert "surfgrad: interrupted by SIGINT: stopped demo" in stderr
    assert _state(out) == before and _siblings(out) == []
