"""SG Noise's Filter Footprint costs nothing when off: Cycles' SVM program (svm_counts, read in a
child) of SG Noise -> SG Volume Gradient with the filter off is exactly that of the group built
without the filter; on, the footprint's Bump nodes and fades run."""

import pytest

pytestmark = pytest.mark.tier("child")

pytest.importorskip("bpy")

from surfgrad_addon.harness.bench import svm_counts as S  # noqa: E402

KEYS = ["noise-filter-off", "noise-filter-on"]


def build_materials():
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.harness.bench import render_materials as M

    def noise(filtered):
        def build(g, ctx):
            node = g.group(G.noise_group())
            node.inputs["Filter Footprint"].default_value = filtered
            vg = g.group(G.volume_gradient_group(), Gradient=node.outputs["Gradient"])
            return g.resolve(vg.outputs[0])
        return build
    ctx = M.images(normal_size=16, height_size=16)
    for key, filtered in zip(KEYS, (False, True)):
        M.material(key, noise(filtered), ctx)


def build_without_filter():
    """SG Noise as if the filter never existed: no footprint, no fade (the input declared)."""
    from surfgrad_addon.addon.groups import volume
    volume.noise_footprint = lambda b, p: 0.0
    volume.footprint_fade = lambda b, amp, filtered, footprint, frequency: amp
    build_materials()


def _counts(build):
    found = S.svm_counts(KEYS, build=f"test_noise_footprint_folding:{build}",
                         paths=[S.ROOT / "tests"])
    return {k: v.nodes for k, v in found.items()}


def test_filter_off_is_the_group_without_the_filter_and_on_runs_it():
    full, without = _counts("build_materials"), _counts("build_without_filter")
    assert full["noise-filter-off"] == without["noise-filter-off"], (full, without)
    # Without the filter, on and off are the same program; with it, on adds 4 Bump nodes
    # (each with its height's copies) and 4 fades.
    assert without["noise-filter-on"] == without["noise-filter-off"], without
    assert full["noise-filter-on"] > full["noise-filter-off"] + 40, full
    print("SVM counts", full, without)
