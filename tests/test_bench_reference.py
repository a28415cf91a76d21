"""bench-reference end to end at tiny sizes: it measures (every rate and second a real,
positive figure), runs a compare child whose bake agrees with the reference, takes the ratio
from that child's own bake and reference seconds, records whether the compiled kernels ran,
and refuses to overwrite its output unasked."""

import json

import numpy as np
import pytest

from surfgrad_addon.harness.bench import reference as BR
from surfgrad_addon.reference import compiled

pytestmark = pytest.mark.tier("child")      # bench-reference runs a compare child


def test_bench_reference_writes_measured_figures(tmp_path):
    out = tmp_path / "bench.json"
    lines = []
    BR.run(out, sizes=(64,), method_sizes=(64,), compare_sizes=(64,), memory_sizes=(),
           methods=["normal-map"], repeats=1, log=lines.append)
    data = json.loads(out.read_text())
    kernels = data["compiled_kernels"]
    assert kernels["enabled"] == compiled.enabled() and kernels["threads"] >= 1
    assert any(line.startswith("compiled kernels: ") for line in lines)
    rates = list(data["listings"]["64"].values())
    assert len(rates) >= 25 and all(np.isfinite(r) and r > 0 for r in rates)
    assert data["methods"]["normal-map"]["64"] > 0
    row = data["compare"]["normal-map"]["64"]
    assert row["bake_seconds"] > 0 and row["reference_seconds"] > 0
    assert row["ratio"] == pytest.approx(row["reference_seconds"] / row["bake_seconds"])
    assert row["max_deg"] < 0.5 and row["texels"] > 1000      # the bake agrees with it
    assert 0.05 < row["peak_gb"] < 4
    with pytest.raises(FileExistsError):
        BR.run(out, sizes=(), method_sizes=(), compare_sizes=(), memory_sizes=())
