"""The public API (surfgrad_addon.api) that scripts and TDs use: every group by name, with
options; the layer stack; the normal-map bake. The comparison is the harness's
(surfgrad_addon.harness.api). Clear errors for bad names."""

import re

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.harness import api as harness_api  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402

pytestmark = pytest.mark.tier("bake")


@pytest.mark.tier("blender")
def test_node_group_builds_every_group_by_name(fresh):
    for name in api.group_names():
        if G.unavailable_reason(name):
            with pytest.raises(G.FeatureUnavailable, match=re.escape(name)):
                api.node_group(name)
            continue
        tree = api.node_group(name)
        assert tree.name == name and tree.description
    detail = api.node_group("SG Normal Map", uv_map="Detail")
    assert detail.name == "SG Normal Map [Detail]"
    frame = [n for n in detail.nodes if n.bl_idname == "ShaderNodeNormalMap"]
    assert len(frame) == 1 and frame[0].uv_map == "Detail"
    basis = api.node_group("SG Procedural Basis", uv_map="Detail")
    assert basis.name == "SG Procedural Basis [Detail]"
    assert [n.uv_map for n in basis.nodes if n.bl_idname == "ShaderNodeUVMap"] == ["Detail"]


@pytest.mark.tier("blender")
def test_node_group_refuses_unknown_names_and_options(fresh):
    with pytest.raises(ValueError, match="no surfgrad group named 'SG Nope'.*SG Resolve"):
        api.node_group("SG Nope")
    with pytest.raises(ValueError, match="SG Resolve takes no option uv_map"):
        api.node_group("SG Resolve", uv_map="UVMap")


def test_layer_stack_bake_and_compare_through_the_api(fresh, tmp_path):
    obj = scenes.new_scene(["Plane"])["Plane"]
    mat = new_material("API")
    obj.data.materials.append(mat)
    nodes = api.add_layer_stack(mat)
    assert nodes["resolve"].outputs[0].is_linked
    out = api.bake_normal_map(obj, tmp_path / "n.exr", resolution=16, log=lambda *_: None)
    assert out.is_file()
    groups = set(bpy.data.node_groups)
    report = harness_api.compare(obj, "normal-map", resolution=24)
    assert report["max_deg"] <= 0.5 and report["texels_compared"] > 0.5 * 24 * 24
    assert np.isfinite(report["mean_deg"])
    assert set(bpy.data.node_groups) == groups      # the bake's own groups went again
    with pytest.raises(ValueError, match="give a material"):
        api.add_layer_stack(None)


def test_the_api_offers_no_compare_and_says_where_it_went():
    """api ships in the extension, the harness does not: compare lives in the harness's API,
    and the old name says so instead of importing the harness."""
    with pytest.raises(AttributeError, match=r"harness\.api\.compare.*checkout"):
        api.compare
    assert not hasattr(api, "compare") and "compare" not in dir(api)
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        api.nothing
