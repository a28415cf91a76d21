"""bench-compare (harness/bench/compare.py): the README's ratios are the ones in the JSON it
quotes (docs/bench_compare.json, docs/bench_compare_before.json), and a tiny run measures real
child processes (no timing bar: a shared machine's timings are not a test's business)."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from surfgrad_addon.harness.bench import compare as BC

pytestmark = pytest.mark.tier("numpy")

ROOT = Path(__file__).resolve().parents[1]
KEYS = ("compare_over_bake_alone", "compare_over_bake_operator")


def _readme_rows():
    """{size: (before alone, now alone, before operator, now operator)} from the README."""
    rows = {}
    for line in (ROOT / "README.md").read_text().splitlines():
        m = re.match(r"\| (\d+)² \| ([\d.]+) \| \*\*([\d.]+)\*\* \| ([\d.]+) \| "
                     r"\*\*([\d.]+)\*\* \|$", line)
        if m:
            rows[m.group(1)] = tuple(float(x) for x in m.groups()[1:])
    return rows


def test_the_readme_quotes_the_json():
    now = json.loads((ROOT / "docs" / "bench_compare.json").read_text())
    before = json.loads((ROOT / "docs" / "bench_compare_before.json").read_text())
    rows = _readme_rows()
    assert set(rows) == {"2048", "4096"} == set(now["sizes"]) == set(before["sizes"])
    for size, quoted in rows.items():
        want = (before["sizes"][size][KEYS[0]], now["sizes"][size][KEYS[0]],
                before["sizes"][size][KEYS[1]], now["sizes"][size][KEYS[1]])
        assert quoted == tuple(round(x, 2) for x in want), size
        # Each figure is the median of its pairs' ratios, each ratio its pair's walls.
        for data in (now, before):
            pairs = data["sizes"][size]["pairs"]
            assert len(pairs) == data["repeats"] == 3
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
    data = BC.run(out, sizes=(64,), repeats=1, log=lines.append)
    assert json.loads(out.read_text()) == json.loads(json.dumps(data))
    pair = data["sizes"]["64"]["pairs"][0]
    b, c = pair["bake_alone"], pair["compare"]
    # The bake alone child baked (its operator ran inside its wall), compare compared.
    assert 0 < b["bake_seconds"] < b["wall_seconds"]
    assert 0 < c["bake_seconds"] < c["wall_seconds"] and c["reference_seconds"] > 0
    assert c["max_deg"] < 0.5
    assert data["sizes"]["64"][KEYS[0]] == c["wall_seconds"] / b["wall_seconds"]
    assert any(line.startswith("wrote ") for line in lines)
