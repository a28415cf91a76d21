"""The render-cost bench in its quick form: every SG material and its twin render, the table and
chart are written, the look checks hold (SG against its twin where both mean the same thing,
against the reference otherwise), and the node counts trace the cost, Cycles' own SVM count after
folding among them (a child compiles the materials: tier child). Timings are printed and written
by the bench (bash run.sh bench-render), never asserted here."""

import json

import pytest

pytestmark = pytest.mark.tier("child")

pytest.importorskip("bpy")

from surfgrad_addon.harness.bench import folded_cost, render_cost  # noqa: E402
from surfgrad_addon.harness.bench import render_materials as M  # noqa: E402


def test_quick_render_cost_bench(tmp_path):
    result = render_cost.run(tmp_path, quick=True, log=lambda *_: None)
    assert {p.name for p in tmp_path.iterdir()} >= {"render_cost.json", "render_cost.md",
                                                    "render_cost.png"}
    rows = {r["key"]: r for r in json.loads((tmp_path / "render_cost.json").read_text())["rows"]}
    assert set(rows) == {key for key, *_ in M.cases()}
    for key, row in rows.items():
        assert row["seconds"] > 0, key
        if "twin" in row:
            assert 0.2 < row["ratio"] < 20, (key, row["ratio"])
            assert row["svm_ratio"] == row["svm"] / rows[row["twin"]]["svm"]
    # The after-folding table: every material and option, the rows' counts taken from it, each
    # perturbation costing more than the unperturbed material.
    folded = {r["key"]: r for r in result["folded"]}
    assert set(folded) == {key for key, *_ in folded_cost.materials()}
    assert all(rows[k]["svm"] == folded[k]["svm"] for k in rows)
    assert all(r["svm"] > folded["none"]["svm"] for k, r in folded.items() if k != "none")
    assert "SVM program size after Cycles' constant folding" in \
        (tmp_path / "render_cost.md").read_text()
    # Same look: SG Normal Map resolves to Blender's node, SG Height Map Forward to the Bump
    # node at the same Filter Width; triplanar and the procedural basis match the reference.
    for key in ("nm-sg", "bump-sg"):
        assert rows[key]["look"]["against"] == "twin" and rows[key]["look"]["max_deg"] < 0.05
    for key in ("tri-sg", "uv2-sg"):
        assert rows[key]["look"]["max_deg"] < 0.5
    # Where the cost comes from: one Normal Map node per SG Normal Map layer (Listings 3 and 9
    # through Blender's own node); SG Resolve's guard has none (arithmetic nodes only).
    assert rows["nm-sg"]["normal_map_nodes"] == 1
    assert rows["layers3-sg"]["normal_map_nodes"] == 3
    # Each layer of a stack reads its own image (identical layers would be merged by Cycles).
    assert rows["layers3-sg"]["image_lookups"] == rows["layers3-builtin"]["image_lookups"] == 3
    # A third layer adds at least what one image lookup and Normal Map node add to a material
    # (a merged, repeated layer added only its SG Combine).
    assert rows["layers3-sg"]["svm"] - rows["layers2-sg"]["svm"] > \
        rows["nm-builtin"]["svm"] - rows["none"]["svm"]
    assert result["marginal_layer"].keys() == {"sg_s", "builtin_s"}
    # The default device: the CPU, named in the JSON and the table's heading.
    assert result["cycles_device"] == "CPU" and (result["size"], result["samples"]) == (96, 8)
    assert (tmp_path / "render_cost.md").read_text().startswith("Render cost, Cycles CPU, 96 x 96")
    # Blender 5.0+: each Sampler group looks like its per-image group (the same taps), and
    # its image lookups moved out of the group into the one Image Texture of its zone.
    from surfgrad_addon.addon.sampler_zone import has_closures
    if has_closures():
        for key, twin in (("hq-sampler", "hq-image"), ("tri-sampler", "tri-sg"),
                          ("triheight-sampler", "triheight-image"),
                          ("parallax-sampler", "parallax-image")):
            assert rows[key]["look"]["against"] == "twin"
            assert rows[key]["look"]["max_deg"] < 0.05, (key, rows[key]["look"])
            assert rows[key]["image_lookups"] < rows[twin]["image_lookups"], key
