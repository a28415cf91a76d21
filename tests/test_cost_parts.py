"""harness/bench/cost_parts.py: the materials that miss their render-cost target taken apart
into their listings. The parts' own arithmetic, and, counted by Cycles (SVM program size after
folding), that the parts are real pieces of their material: each adds nodes to its base, and
together they account for what the material runs above its twin."""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness.bench import cost_parts as P, svm_counts as S  # noqa: E402

pytestmark = pytest.mark.tier("child")


def test_rows_take_the_parts_off_the_overhead():
    now = {key: 0 for key in P.keys()}
    now.update({"nm-builtin": 100, "nm-sg": 190, "part-nm-listing2": 130,
                "part-nm-listing5": 120, "part-nm-resolve": 135, "part-nm-hand": 125,
                "uv2-builtin": 100, "uv2-sg": 300, "part-lookup-detail": 60,
                "part-uv2-gradients": 150, "part-uv2-basis": 200,
                "part-uv2-tangent-normal": 140, "part-uv2-resolve": 135})
    rows = {r["key"]: r for r in P.rows(now)}
    nm = rows["nm-sg"]
    assert nm["twin"] == "nm-builtin" and nm["overhead"] == 90
    cost = {p["key"]: p["instructions"] for p in nm["parts"]}
    assert cost == {"part-nm-listing2": 30, "part-nm-listing5": 20, "part-nm-resolve": 35,
                    "part-nm-hand": 25}
    assert nm["remainder"] == 90 - 30 - 20 - 35          # the hand chain is for scale only
    uv2 = rows["uv2-sg"]
    cost = {p["key"]: p["instructions"] for p in uv2["parts"]}
    # the basis beyond its gradients, and the twin's Normal Map node taken off (sign -1)
    assert cost["part-uv2-basis"] == 50 and cost["uv2-builtin"] == -(100 - 60)
    assert uv2["remainder"] == 200 - (150 + 50 + 80 + 35 - 40)
    assert abs(sum(p["share"] for p in uv2["parts"]) - (200 - uv2["remainder"]) / 200) < 1e-12


def test_the_parts_add_up_to_what_each_material_runs_above_its_twin():
    """In SVM program size the parts of SG Normal Map, Height Map Forward and Triplanar add up
    to the material's overhead exactly on 5.2 (nothing is shared between them); the procedural
    basis shares its UV Map node's evaluations (a few words). Every part adds nodes."""
    words = {k: v.nodes for k, v in S.svm_counts(
        P.keys(), build="surfgrad_addon.harness.bench.cost_parts:build_materials").items()}
    for whole in P.rows(words):
        for part in whole["parts"]:
            if part["instructions"] >= 0:
                assert part["instructions"] > 0, (whole["key"], part)
        assert abs(whole["remainder"]) <= 0.1 * whole["overhead"], whole
