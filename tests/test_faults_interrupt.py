"""Fault injection, issue 20 item 2: interrupts and workers.

Ctrl-C (SIGINT) and SIGTERM stop `bake-normal-map` and `bake-batch` (worker processes, and
--workers 0 as farm tasks run it) within seconds: exit 130 / 143, one line and no traceback,
no output and no temporary file, no retry, no process left behind, the .blend files unchanged,
the manifest claiming nothing unfinished. A hung worker times out; entries naming the same
file are merged; every Blender command line the project documents or emits exits non-zero on a
Python error (--python-exit-code)."""

import hashlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import batch, interrupts  # noqa: E402
from surfgrad_addon.addon.batch import session  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from support.child import ROOT  # noqa: E402

pytestmark = pytest.mark.tier("child")


# A bake of this size takes ~25 s on the 2-core test machine (1024^2 x 64 samples), far more
# than the stop may take.
BIG = ["--resolution", "1024", "--samples", "64"]
STOP_WITHIN_S = 10.0


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class Run:
    """`python -m surfgrad_addon ARGS` in the background, its output collected line by line."""

    def __init__(self, args, cwd, env=None):
        full = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        full.update(PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1", **(env or {}))
        self.proc = subprocess.Popen([sys.executable, "-m", "surfgrad_addon", *map(str, args)],
                                     cwd=str(cwd), env=full, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self.out, self.err = [], []
        self.threads = [threading.Thread(target=self._pump, args=(s, b), daemon=True)
                        for s, b in ((self.proc.stdout, self.out), (self.proc.stderr, self.err))]
        for t in self.threads:
            t.start()
        self.seen = set()

    @staticmethod
    def _pump(stream, into):
        for line in stream:
            into.append(line)

    def wait_for(self, predicate, timeout=120):
        """Wait until predicate() holds (noting the processes under this one meanwhile)."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            self.seen |= descendants(self.proc.pid)
            if predicate():
                return
            assert self.proc.poll() is None, "".join(self.out + self.err)[-3000:]
            time.sleep(0.1)
        raise AssertionError(f"timed out; output:\n{''.join(self.out + self.err)[-3000:]}")

    def stop(self, signum):
        """Send `signum`; returns (exit code, seconds to exit)."""
        self.seen |= descendants(self.proc.pid)
        t0 = time.monotonic()
        self.proc.send_signal(signum)
        try:
            code = self.proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self.kill()
            raise
        elapsed = time.monotonic() - t0
        for t in self.threads:
            t.join(5)
        return code, elapsed

    def finish(self, timeout=300):
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise
        for t in self.threads:
            t.join(5)
        return code

    def kill(self):
        for pid in descendants(self.proc.pid) | {self.proc.pid}:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass

    @property
    def stdout(self):
        return "".join(self.out)

    @property
    def stderr(self):
        return "".join(self.err)


def _stat(pid):
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()
    return fields[0], int(fields[1])              # state, parent pid


def descendants(pid):
    """The pids of every live process under `pid` (from /proc)."""
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            st = _stat(int(entry))
            if st:
                children.setdefault(st[1], []).append(int(entry))
    out, todo = set(), [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.add(c)
            todo.append(c)
    return out


def alive(pids):
    """Those of `pids` still running (not gone, not zombies)."""
    return sorted(p for p in pids if (_stat(p) or ("X",))[0] not in ("X", "Z"))


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in Path(folder).rglob("*") if p.is_file())


@pytest.fixture
def assets(tmp_path):
    a = BA.write_asset(tmp_path / "in" / "a.blend", ("Rock", "Stone"), tiles=(1001,),
                       image_size=32)
    b = BA.write_asset(tmp_path / "in" / "b.blend", ("Tree",), tiles=(1001,), image_size=32,
                       seed=4)
    return a, b


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_stops_bake_normal_map(assets, tmp_path, signum):
    blend = assets[0]
    before = _sha(blend)
    out = tmp_path / "out"
    out.mkdir()
    temp = _fresh_tmpdir(tmp_path)
    run = Run(["bake-normal-map", "--blend", blend, "--object", "Rock", "--output",
               out / "rock.png", *BIG], tmp_path, env={"TMPDIR": str(temp)})
    run.wait_for(lambda: "[2/3] baking" in run.stdout)
    time.sleep(1.0)                               # inside Cycles' bake
    assert [p.name[:8] for p in temp.iterdir()] == ["blender_"]      # Blender's session one
    code, elapsed = run.stop(signum)
    print(f"{signum.name}: bake-normal-map stopped in {elapsed:.2f} s")
    assert code == interrupts.exit_code(signum) == {signal.SIGINT: 130,
                                                     signal.SIGTERM: 143}[signum]
    assert elapsed < STOP_WITHIN_S, elapsed
    assert f"surfgrad: interrupted by {signum.name}: stopped the bake" in run.stderr
    assert "Traceback" not in run.stdout + run.stderr
    assert "[3/3]" not in run.stdout                  # nothing written ...
    assert _files(out) == []                          # ... not even a temporary file
    assert _sha(blend) == before
    assert alive(run.seen) == []
    assert list(temp.iterdir()) == []                 # its temp folder went too


def _fresh_tmpdir(tmp_path):
    """An empty folder for the command's TMPDIR: what a stop leaves there is seen."""
    temp = tmp_path / "tmp"
    temp.mkdir()
    return temp


def test_sigint_stops_a_batch_of_worker_processes(assets, tmp_path):
    a, b = assets
    before = {p: _sha(p) for p in assets}
    out = tmp_path / "maps"
    temp = _fresh_tmpdir(tmp_path)
    run = Run(["bake-batch", a, b, "--output", out / "{file}_{object}.png", "--workers", "2",
               *BIG], tmp_path, env={"TMPDIR": str(temp)})
    manifest = out / batch.MANIFEST_NAME
    # Both files scanned (the manifest is written after each scan), two workers baking.
    run.wait_for(lambda: manifest.is_file() and
                 len(json.loads(manifest.read_text())["files"]) == 2 and
                 len(descendants(run.proc.pid)) >= 2)
    time.sleep(2.0)
    workers = set(run.seen)
    # Blender's session folders: the batch's own, one inside each worker's folder.
    assert sorted(p.name[:8] for p in temp.iterdir()) == ["blender_", "surfgrad", "surfgrad"]
    assert all(any(q.name.startswith("blender_") for q in p.iterdir())
               for p in temp.iterdir() if p.name.startswith("surfgrad-worker-"))
    code, elapsed = run.stop(signal.SIGINT)
    print(f"SIGINT: bake-batch --workers 2 stopped in {elapsed:.2f} s; workers {workers}")
    assert code == 130 and elapsed < STOP_WITHIN_S, (code, elapsed, run.stderr[-2000:])
    assert len(workers) >= 2
    assert alive(workers) == [] and alive(run.seen) == []        # no orphan
    text = run.stdout + run.stderr
    assert "Traceback" not in text and "KeyboardInterrupt" not in text
    assert "retrying" not in text
    assert "surfgrad: interrupted by SIGINT: stopped the batch" in run.stderr
    assert "[batch] SIGINT: stopped 2 worker process(es); 3 asset(s) not baked" in run.stderr
    assert _files(out) == [batch.MANIFEST_NAME]                  # no map, no temporary
    m = json.loads(manifest.read_text())
    assert m["interrupted"] == "SIGINT"
    assert sorted((e["object"], e["status"]) for e in m["assets"].values()) == [
        ("Rock", "interrupted"), ("Stone", "interrupted"), ("Tree", "interrupted")]
    assert {p: _sha(p) for p in assets} == before
    assert list(temp.iterdir()) == []                 # no temp folder left, workers' neither
    # A rerun bakes them (nothing is taken as done).
    code = Run(["bake-batch", a, "--output", out / "{file}_{object}.png", "--workers", "0",
                "--resolution", "16"], tmp_path).finish()
    assert code == 0
    assert sorted(_files(out)) == ["a_Rock.png", "a_Stone.png", batch.MANIFEST_NAME]


def test_sigterm_stops_a_farm_task_baking_in_its_own_process(assets, tmp_path):
    """--workers 0 (the farm templates' tasks): the bake runs in the command's process."""
    a, _ = assets
    before = _sha(a)
    out = tmp_path / "maps"
    run = Run(["bake-batch", a, "--output", out / "{file}_{object}.png", "--workers", "0",
               *BIG], tmp_path)
    manifest = out / batch.MANIFEST_NAME
    run.wait_for(lambda: manifest.is_file())       # scanned; the first bake starts
    time.sleep(2.0)
    code, elapsed = run.stop(signal.SIGTERM)
    print(f"SIGTERM: bake-batch --workers 0 stopped in {elapsed:.2f} s")
    assert code == 143 and elapsed < STOP_WITHIN_S, (code, elapsed, run.stderr[-2000:])
    assert "Traceback" not in run.stdout + run.stderr
    assert "surfgrad: interrupted by SIGTERM: stopped the batch" in run.stderr
    assert _files(out) == [batch.MANIFEST_NAME]
    m = json.loads(manifest.read_text())
    assert sorted(e["status"] for e in m["assets"].values()) == ["interrupted"] * 2
    assert _sha(a) == before and alive(run.seen) == []


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_stops_compare(assets, tmp_path, signum):
    """compare's bake used to swallow Ctrl-C (Cycles logs the KeyboardInterrupt and goes on):
    it now stops like bake-normal-map, writing no report, no heat map, no temp folder."""
    blend = assets[0]
    before = _sha(blend)
    out = tmp_path / "out"
    out.mkdir()
    temp = _fresh_tmpdir(tmp_path)
    run = Run(["compare", "--blend", blend, "--object", "Rock", "--method", "layered",
               "--resolution", "2048", "--json", out / "c.json"], tmp_path,
              env={"TMPDIR": str(temp)})
    run.wait_for(lambda: "Read blend" in run.stdout + run.stderr)
    time.sleep(2.0)                               # baking or comparing, far from done
    assert [p.name[:8] for p in temp.iterdir()] == ["blender_"]
    code, elapsed = run.stop(signum)
    print(f"{signum.name}: compare stopped in {elapsed:.2f} s")
    assert code == {signal.SIGINT: 130, signal.SIGTERM: 143}[signum], run.stderr[-2000:]
    assert elapsed < STOP_WITHIN_S, elapsed
    assert f"surfgrad: interrupted by {signum.name}: stopped compare" in run.stderr
    assert "Traceback" not in run.stdout + run.stderr
    assert _files(out) == [] and list(temp.iterdir()) == []
    assert _sha(blend) == before and alive(run.seen) == []


def test_sigint_stops_compare_all_and_removes_its_heat_maps(tmp_path):
    """compare-all writes a heat map per case as it goes: a stop takes back this run's (the
    heat maps written so far, the folders it made)."""
    out = tmp_path / "cmp"
    temp = _fresh_tmpdir(tmp_path)
    run = Run(["compare-all", "--out", out, "--resolution", "32"], tmp_path,
              env={"TMPDIR": str(temp)})
    # (into a hidden sibling of heat/, moved in at the end: red team 44c)
    run.wait_for(lambda: len(list(out.glob(".heat.partial-*/heat/*.png"))) >= 2, timeout=240)
    code, elapsed = run.stop(signal.SIGINT)
    assert code == 130 and elapsed < STOP_WITHIN_S, (code, elapsed, run.stderr[-2000:])
    assert "surfgrad: interrupted by SIGINT: stopped compare-all" in run.stderr
    assert "Traceback" not in run.stdout + run.stderr
    assert not out.exists()                       # the folders it made, and their maps, gone
    assert list(temp.iterdir()) == [] and alive(run.seen) == []


def test_a_hung_worker_times_out_without_retry_and_the_rest_bakes(assets, tmp_path):
    a, b = assets
    out = tmp_path / "maps"
    t0 = time.monotonic()
    run = Run(["bake-batch", a, b, "--output", out / "{file}_{object}.png", "--workers", "2",
               "--resolution", "16", "--worker-timeout", "20"], tmp_path,
              env={session.FAULT_ENV: "hang:Stone"})
    run.wait_for(lambda: run.proc.poll() is not None, timeout=180)
    code = run.finish()
    elapsed = time.monotonic() - t0
    assert code == 1, run.stderr[-2000:]
    assert 20 <= elapsed < 120, elapsed
    m = json.loads((out / batch.MANIFEST_NAME).read_text())
    status = {e["object"]: e for e in m["assets"].values()}
    assert status["Rock"]["status"] == status["Tree"]["status"] == "baked"
    stone = status["Stone"]
    assert stone["status"] == "failed" and stone["kind"] == "timeout"
    assert len(stone["attempts"]) == 1                            # not retried
    assert "no reply from its worker process in 20 s: taken as hung and killed" in \
        stone["error"]
    assert "a.blend:Stone: no reply from its worker process in 20 s" in run.stderr
    assert "Traceback" not in run.stdout + run.stderr
    assert sorted(_files(out)) == ["a_Rock.png", "b_Tree.png", batch.MANIFEST_NAME]
    assert alive(run.seen) == []                                  # the hung one killed


def test_a_worker_stopped_from_outside_fails_its_asset_without_retry(assets, tmp_path):
    """SIGTERM to one worker (not the batch): it exits 143; its asset fails, not retried as
    a crash, and the batch goes on."""
    a, b = assets
    out = tmp_path / "maps"
    run = Run(["bake-batch", a, b, "--output", out / "{file}_{object}.png", "--workers", "1",
               "--resolution", "16"], tmp_path, env={session.FAULT_ENV: "hang:Stone"})
    run.wait_for(lambda: "baked a.blend:Rock" in run.stdout)
    time.sleep(1.0)                                # the worker is on Stone, hanging
    (worker,) = descendants(run.proc.pid)
    os.kill(worker, signal.SIGTERM)
    code = run.finish(timeout=120)
    assert code == 1, run.stderr[-2000:]
    m = json.loads((out / batch.MANIFEST_NAME).read_text())
    status = {e["object"]: e for e in m["assets"].values()}
    assert status["Rock"]["status"] == status["Tree"]["status"] == "baked"
    stone = status["Stone"]
    assert (stone["status"], stone["kind"], len(stone["attempts"])) == \
        ("failed", "interrupted", 1)
    assert "its worker process was stopped by SIGTERM (not retried)" in stone["error"]
    assert "retrying" not in run.stdout + run.stderr
    assert sorted(_files(out)) == ["a_Rock.png", "b_Tree.png", batch.MANIFEST_NAME]
    assert alive(run.seen | {worker}) == []


@pytest.mark.tier("bake")
def test_hung_worker_default_timeout_is_generous_and_scales_with_the_bake():
    s = dict(batch.DEFAULTS)
    assert batch.bake_timeout(s, 1) == pytest.approx(300 + 1024 ** 2 / 1e5)
    big = dict(s, resolution=4096, samples=16)
    assert batch.bake_timeout(big, 10) == pytest.approx(300 + 4096 ** 2 * 16 * 10 / 1e5)
    with pytest.raises(batch.BatchError, match="worker timeout 0"):
        batch.bake_batch(["x.blend"], "m/{object}.png", worker_timeout=0)


@pytest.mark.tier("bake")
def test_entries_for_the_same_file_are_merged_not_narrowed(assets, tmp_path):
    a, _ = assets
    before = _sha(a)
    out = tmp_path / "maps"
    rep = batch.bake_batch([str(a), f"{a}:Stone"], str(out / "{file}_{object}.png"),
                           defaults={"resolution": 16}, workers=0, log=lambda *_: None)
    assert sorted((e["object"], e["status"]) for e in rep["assets"].values()) == [
        ("Rock", "baked"), ("Stone", "baked")]
    assert sorted(_files(out)) == ["a_Rock.png", "a_Stone.png", batch.MANIFEST_NAME]
    # Named objects alone still narrow: only Stone.
    out2 = tmp_path / "maps2"
    rep = batch.bake_batch([f"{a}:Stone", f"{a}:Stone"], str(out2 / "{file}_{object}.png"),
                           defaults={"resolution": 16}, workers=0, log=lambda *_: None)
    assert [(e["object"], e["status"]) for e in rep["assets"].values()] == [("Stone", "baked")]
    assert _sha(a) == before


@pytest.mark.tier("blender")
def test_partial_file_pattern_matches_what_a_bake_writes(tmp_path):
    """The process's own temporary files only: another process's with the same id (a farm
    task in another container: red team 42b) keeps its files, so does an older surfgrad's."""
    pid, tok = 4321, "0123abcd"
    keep = [f".rock.part43210-{tok}.png", "rock.png", f".rock.part4321-{tok}",
            f".other.part4321-{tok}.png", ".rock.part4321-89abcdef.png", ".rock.part4321.png"]
    gone = [f".rock.part4321-{tok}.png", f".rock.1001.part4321-{tok}.png",
            f".rock.1002.part4321-{tok}.half.exr"]
    for name in keep + gone:
        (tmp_path / name).write_text("x")
    removed = interrupts.remove_partials(tmp_path / "rock.<UDIM>.png", pid, tok) + \
        interrupts.remove_partials(tmp_path / "rock.png", pid, tok)
    assert sorted(Path(p).name for p in removed) == sorted(gone)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(keep)


# Every Blender command line the project documents or emits ----------------------------------

_PYTHON_ARG = re.compile(r"--python(-expr)?(?![-\w])")


def _documented_lines():
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
             *sorted((ROOT / "surfgrad_addon").rglob("*.py")),
             *sorted((ROOT / "tools").rglob("*.js")), *sorted((ROOT / "tools").rglob("*.yaml")),
             *sorted((ROOT / "tools").rglob("*.py")), ROOT / "run.sh"]
    for path in files:
        if path.is_file():
            for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                if _PYTHON_ARG.search(line):
                    yield f"{path.relative_to(ROOT)}:{n}", line


@pytest.mark.tier("blender")
def test_every_blender_command_line_exits_non_zero_on_a_python_error():
    lines = list(_documented_lines())
    where = {w.split(":")[0] for w, _ in lines}
    # The lines this covers: the docs, the scripts' docstrings, the worker and Flamenco commands.
    assert {"docs/pipelines.md", "surfgrad_addon/addon/batch/workers.py",
            "surfgrad_addon/bake_normal_map.py", "tools/farm/flamenco/surfgrad-bake.js"} <= where, \
        where
    for w, line in lines:
        assert "--python-exit-code" in line, f"{w}: {line.strip()}"
        # Blender applies it to the --python arguments after it.
        assert line.index("--python-exit-code") < _PYTHON_ARG.search(line).start(), w
