"""SG Height Blend's render cost, counted by Cycles itself (harness/bench/svm_counts.py):
two bumped layers blended by height through surface gradients (SG Height Map Forward twice, SG
Height Blend, SG Resolve) against the nearest built-in way (two Bump nodes, their normals mixed
by a Mix whose factor is a Map Range of the height difference), and against the same two SG
layers masked by that factor (SG Combine): what the height weights themselves cost."""

import pytest

from surfgrad_addon.addon.node_vocabulary import Math
from surfgrad_addon.harness.bench import svm_counts as S

pytestmark = pytest.mark.tier("child")

OFFSET_B, WIDTH = 0.1, 0.2         # SG Height Blend's Offset B; its transition at contrast 0.8
# Measured (Principled BSDF materials): 5.2 (int words) built-in 194, SG Height Blend 470
# (x2.42), the weights 50; 4.2 (int4 records) 89, 210 (x2.36), 21. Bars with room for the
# other lines' folding.
RATIO_BAR, WEIGHTS_BAR = 3.0, 0.4


def _heights(g, p):
    """Two procedural heights (the rock's and the sand's) on the position."""
    a = g.node("ShaderNodeTexNoise")
    g.set(a, Vector=p, Scale=5.0)
    b = g.node("ShaderNodeTexNoise")
    g.set(b, Vector=p, Scale=23.0)
    return a.outputs["Fac"], b.outputs["Fac"]


def _factor(g, h_a, h_b):
    """The built-in stand-in for the height weight: Map Range of h_B + o - h_A over
    [-c, c] to [0, 1]."""
    ramp = g.node("ShaderNodeMapRange")
    diff = g.math(Math.SUBTRACT, g.math(Math.ADD, h_b, OFFSET_B), h_a)
    g.set(ramp, Value=diff, From_Min=-WIDTH, From_Max=WIDTH)
    return ramp.outputs["Result"]


def _builtin(g, p):
    h_a, h_b = _heights(g, p)
    return g.mix_vector(_factor(g, h_a, h_b), g.bump(h_a, g.geometry("Normal"), strength=0.3),
                        g.bump(h_b, g.geometry("Normal"), strength=0.3))


def _sg_layers(g, p):
    from surfgrad_addon.addon import groups as G
    h_a, h_b = _heights(g, p)
    a = g.group(G.height_map_forward_group(), Height=h_a, Bump_Scale=0.05)
    b = g.group(G.height_map_forward_group(), Height=h_b, Bump_Scale=0.05)
    return h_a, h_b, a.outputs[0], b.outputs[0]


def _sg_height_blend(g, p):
    from surfgrad_addon.addon import groups as G
    h_a, h_b, a, b = _sg_layers(g, p)
    blend = g.group(G.height_blend_group(), A=a, Height_A=h_a, B=b, Height_B=h_b,
                    Offset_B=OFFSET_B, Contrast=1.0 - WIDTH)
    return g.resolve(blend.outputs[0])


def _sg_masked(g, p):
    from surfgrad_addon.addon import groups as G
    h_a, h_b, a, b = _sg_layers(g, p)
    mask = _factor(g, h_a, h_b)
    combine = g.group(G.combine_group(), A=a, B=b, Scale_A=g.math(Math.SUBTRACT, 1.0, mask),
                      Mask_B=mask)
    return g.resolve(combine.outputs[0])


def _sg_added(g, p):
    _, _, a, b = _sg_layers(g, p)
    return g.resolve(g.add(a, b))


MATERIALS = {"builtin": _builtin, "sg_height_blend": _sg_height_blend,
             "sg_masked": _sg_masked, "sg_added": _sg_added}


def build_materials():
    """In the child: one material per MATERIALS entry, named after it (a Principled BSDF
    whose Normal is the entry's graph on the position)."""
    from surfgrad_addon.harness.demo_scene import material
    for name, build in MATERIALS.items():
        material(name, lambda g, build=build: build(g, g.geometry("Position")))


def test_height_blend_costs_against_the_built_in_way():
    counts = S.svm_counts(MATERIALS, build="test_height_blend_cost:build_materials",
                          paths=[S.ROOT / "tests"])
    builtin, blend, masked, added = (counts[k].nodes for k in MATERIALS)
    print(f"SVM nodes ({counts['builtin'].unit}): built-in {builtin}, SG Height Blend {blend} "
          f"(x{blend / builtin:.2f}), SG Combine masked {masked} (x{masked / builtin:.2f}), "
          f"SG layers added {added}: the height weights {blend - added}")
    assert 0 < builtin < blend < RATIO_BAR * builtin
    # The height weights cost no more than a Map Range mask on the same SG layers, and a
    # fraction of the built-in way: the ratio is the SG layers' (their Bump inversions).
    assert added < blend <= masked
    assert blend - added < WEIGHTS_BAR * builtin
