"""bench-compare (harness/bench/compare.py): the docs' ratios (docs/proof.md) are the ones in the
JSON they quote (docs/bench_compare.json: this code's compare and, in the same rounds, the one
before it), and a tiny run measures real child processes (no timing bar: a shared machine's
timings are not a test's business)."""

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from surfgrad_addon.harness.bench import compare as BC

pytestmark = pytest.mark.tier("numpy")

ROOT = Path(__file__).resolve().parents[1]
KEYS = ("compare_over_bake_alone", "compare_over_bake_operator")


def _readme_rows():
    """{size: (before alone, now alone, before operator, now operator)} from docs/proof.md
    (the CPU columns after them are checked by tests/test_docs_figures.py's generated tables)."""
    rows = {}
    for line in (ROOT / "docs" / "proof.md").read_text().splitlines():
        m = re.match(r"\| (\d+)² \| ([\d.]+) \| \*\*([\d.]+)\*\* \| ([\d.]+) \| "
                     r"\*\*([\d.]+)\*\* \|", line)
        if m:
            rows[m.group(1)] = tuple(float(x) for x in m.groups()[1:])
    return rows


def test_the_readme_quotes_the_json():
    now = json.loads((ROOT / "docs" / "bench_compare.json").read_text())
    before = {"sizes": {k: v["before"] for k, v in now["sizes"].items()},
              "repeats": now["repeats"]}
    rows = _readme_rows()
    assert set(rows) == {"2048", "4096"} == set(now["sizes"])
    for size, quoted in rows.items():
        want = (before["sizes"][size][KEYS[0]], now["sizes"][size][KEYS[0]],
                before["sizes"][size][KEYS[1]], now["sizes"][size][KEYS[1]])
        assert quoted == tuple(round(x, 2) for x in want), size
        # Each figure is the median of its pairs' ratios, each ratio its pair's walls.
        for data in (now, before):
            pairs = data["sizes"][size]["pairs"]
            assert len(pairs) == data["repeats"] >= 3
            for p in pairs:
                assert p[KEYS[0]] == p["compare"]["wall_seconds"] / \
                    p["bake_alone"]["wall_seconds"]
                assert p[KEYS[1]] == p["compare"]["wall_seconds"] / \
                    p["bake_alone"]["bake_seconds"]
            for key in KEYS:
                assert data["sizes"][size][key] == float(np.median([p[key] for p in pairs]))


@pytest.mark.tier("child")
def test_a_tiny_run_times_real_children(tmp_path):
    pytest.importorskip("bpy")
    out = tmp_path / "bench.json"
    lines = []
    data = BC.run(out, sizes=(64,), repeats=1, log=lines.append, before_root=ROOT)
    assert json.loads(out.read_text()) == json.loads(json.dumps(data))
    pair = data["sizes"]["64"]["pairs"][0]
    # The before checkout's compare ran in the same round, against the same bake alone child.
    before = data["sizes"]["64"]["before"]
    assert before["compare_root"] == str(ROOT) and before["pairs"][0]["bake_alone"] == \
        pair["bake_alone"]
    assert before["pairs"][0]["compare"]["max_deg"] < 0.5
    assert before[KEYS[0]] == before["pairs"][0]["compare"]["wall_seconds"] / \
        pair["bake_alone"]["wall_seconds"]
    b, c = pair["bake_alone"], pair["compare"]
    # The bake alone child baked (its operator ran inside its wall), compare compared.
    assert 0 < b["bake_seconds"] < b["wall_seconds"]
    assert 0 < c["bake_seconds"] < c["wall_seconds"] and c["reference_seconds"] > 0
    assert c["max_deg"] < 0.5
    assert data["sizes"]["64"][KEYS[0]] == c["wall_seconds"] / b["wall_seconds"]
    # CPU seconds are each child's own (Blender's start-up alone is well over 0.1 s of it).
    for child in (b, c):
        assert 0.1 < child["cpu_seconds"] < 2 * child["wall_seconds"] * (os.cpu_count() or 1)
    assert pair["compare_cpu_over_bake_alone_cpu"] == c["cpu_seconds"] / b["cpu_seconds"]
    assert any(line.startswith("wrote ") for line in lines)
