"""A frozen material costs what the built-in twin costs: Cycles' own SVM count (after constant
folding, harness/bench/svm_counts.py) of a material whose surface-gradient stack was frozen
equals that of Image Texture -> Normal Map (tangent) -> BSDF built by hand with the same image
and UV map; the live stack (kept in the material, unlinked) is not compiled. The live
material's count, far larger, shows the count sees the stack when it is linked."""

import pytest

from surfgrad_addon.harness.bench import svm_counts as S

pytestmark = pytest.mark.tier("child")

NAMES = ("live", "frozen", "twin", "twin_default_uv")


def build_materials():
    """In the child: the layered stack on a sphere, copied live, then frozen (32 x 32,
    packed); the built-in twins with the frozen image."""
    import bpy

    from support.freeze_scene import layered_material
    from support.materials import diffuse_material
    from surfgrad_addon.addon import freeze as F
    from surfgrad_addon.harness import scenes as test_scenes
    obj = test_scenes.build(["Sphere"])["Sphere"]
    mat, _ = layered_material(obj, "frozen")
    mat.copy().name = "live"
    record = F.freeze(obj, 32, log=lambda *_: None)
    image = bpy.data.images[record["image"]]
    for name, uv_node in (("twin", True), ("twin_default_uv", False)):
        _, tree, bsdf = diffuse_material(name)
        tex = tree.nodes.new("ShaderNodeTexImage")
        tex.image = image
        if uv_node:
            uv = tree.nodes.new("ShaderNodeUVMap")
            uv.uv_map = "UVMap"
            tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])
        nmap = tree.nodes.new("ShaderNodeNormalMap")
        nmap.uv_map = "UVMap" if uv_node else ""
        tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
        tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])


@pytest.fixture(scope="module")
def counts():
    return S.svm_counts(NAMES, build="test_freeze_cost:build_materials",
                        paths=[S.ROOT / "tests", S.ROOT])


def test_frozen_costs_the_built_in_twin(counts):
    got = {name: (c.nodes, c.peak_stack) for name, c in counts.items()}
    print("SVM (nodes, peak stack):", got, "unit", counts["frozen"].unit)
    # The freeze's explicit UV Map node folds into the texture lookup: no extra cost.
    assert got["frozen"] == got["twin"] == got["twin_default_uv"]
    assert got["live"][0] > 3 * got["frozen"][0]
