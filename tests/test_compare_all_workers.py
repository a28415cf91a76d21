"""compare-all on two processes (harness/compare_all.py) gives what one process gives: the same
cases in the same order, the same table rows, the same JSON fields and the same heat maps.
Small (32^2) and two methods, one with variants.

Bit for bit only within one process: Cycles' bake itself differs between processes by up to
one float32 step on a few texels (measured on the Sphere at 32^2: 93 of 1024 texels, 1.2e-7,
the same before this change), so figures from another process agree to that (ANGLE_TOL)."""

import json

import pytest

pytest.importorskip("bpy")

from surfgrad_addon.harness import compare_all as CA      # noqa: E402

pytestmark = pytest.mark.tier("child")

METHODS = ["normal-map", "decal"]
TIMINGS = {"bake_seconds", "reference_seconds", "compiled_load_seconds"}
ANGLE_TOL = 2e-4            # degrees: far above a float32 step's 3e-6, far below the bar 0.1


def _rows(path):
    """The table's rows: (label, scene, counts...) exact, (mean, p99, max) as floats; the
    two timing columns left out."""
    rows = []
    for line in path.read_text().splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if line.startswith("| ") and not cells[0] in ("method", "---"):
            rows.append((cells[:7], [float(c) for c in cells[7:10]]))
    return rows


def _fields(report):
    return {k: v for k, v in report.items() if k not in TIMINGS}


def test_two_workers_give_the_serial_table(tmp_path):
    serial, shared = tmp_path / "one", tmp_path / "two"
    lines = []
    one = CA.run_all(serial, 32, workers=1, methods=METHODS, log=lambda *_: None)
    two = CA.run_all(shared, 32, workers=2, methods=METHODS, log=lines.append)
    n = len(CA.all_cases(METHODS)) * 4                  # four test objects
    assert len(one) == len(two) == n and n >= 8
    assert [(r["method"], r["variant"], r["object"]) for r in one] == \
        [(r["method"], r["variant"], r["object"]) for r in two]
    rows_one, rows_two = _rows(serial / "compare.md"), _rows(shared / "compare.md")
    assert len(rows_one) == len(rows_two) == n
    for (text_one, figures_one), (text_two, figures_two) in zip(rows_one, rows_two):
        assert text_one == text_two
        assert figures_two == pytest.approx(figures_one, abs=ANGLE_TOL)
    saved = json.loads((shared / "compare.json").read_text())
    for a, b in zip(one, saved):
        a, b = _fields(a), _fields(b)
        assert set(a) == set(b)
        for k in a:
            if isinstance(a[k], float):
                assert b[k] == pytest.approx(a[k], abs=ANGLE_TOL), k
            else:
                assert json.loads(json.dumps(a[k])) == b[k], k
    heat = sorted(p.name for p in (serial / "heat").iterdir())
    assert heat == sorted(p.name for p in (shared / "heat").iterdir()) and len(heat) == n
    # The parent ran share 0 (every other case); the worker's files are gone.
    assert sum(line.startswith("[") for line in lines) == (n + 1) // 2
    assert not list(shared.glob(".compare_shard_*"))
