"""Faults of compare-all's worker processes and of bench-compare: a worker that fails is named
with its exit code and last error line, the command exits non-zero and writes no table; an
unknown method is refused before anything is written; bench-compare does not overwrite its
JSON unasked."""

import hashlib
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("bpy")

from surfgrad_addon.harness.bench import compare as BC          # noqa: E402
from surfgrad_addon.harness import compare_all as CA            # noqa: E402
from surfgrad_addon.harness.compare import CompareError         # noqa: E402

pytestmark = pytest.mark.tier("child")

ROOT = Path(__file__).resolve().parents[1]


def test_a_failing_worker_is_named_and_no_table_is_written(tmp_path, monkeypatch):
    # The worker starts in a folder without the package: it cannot import it and exits 1.
    # A failure after this process's share was baked: exit 1 (red team 34b; it was a
    # CompareError, exit 2, "refused before anything was baked").
    from surfgrad_addon.addon.exit_codes import BakeFailed, code_for
    monkeypatch.setattr(CA, "ROOT", tmp_path)
    monkeypatch.delenv("PYTHONPATH", raising=False)
    out = tmp_path / "out"
    with pytest.raises(BakeFailed) as err:
        CA.run_all(out, 16, workers=2, methods=["normal-map"], log=lambda *_: None)
    assert code_for(err.value) == 1
    assert "compare-all worker 1 failed (exit 1)" in str(err.value)
    assert "No module named 'surfgrad_addon'" in str(err.value)
    assert not (out / "compare.md").exists() and not (out / "compare.json").exists()
    assert not list(out.glob(".compare_shard_*"))


def test_an_unknown_method_is_refused_before_anything_is_written(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(CompareError, match="no method 'nope'"):
        CA.run_all(out, 16, workers=2, methods=["nope"])
    assert not out.exists()


def test_the_command_exits_non_zero_with_the_message(tmp_path):
    out = tmp_path / "bench.json"
    out.write_text("{}")
    before = hashlib.sha256(out.read_bytes()).hexdigest()
    proc = subprocess.run([sys.executable, "-m", "surfgrad_addon", "bench-compare", "--out",
                           str(out), "--sizes", "64", "--repeats", "1"], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0
    assert f"surfgrad: error: {out} exists; pass --overwrite to replace it" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert hashlib.sha256(out.read_bytes()).hexdigest() == before


def test_bench_compare_names_a_failing_child(tmp_path, monkeypatch):
    monkeypatch.delenv("PYTHONPATH", raising=False)
    out = tmp_path / "bench.json"
    with pytest.raises(RuntimeError, match=r"failed \(exit 1\).*No module named"):
        BC.run(out, sizes=(64,), repeats=1, root=tmp_path, log=lambda *_: None)
    assert not out.exists()
