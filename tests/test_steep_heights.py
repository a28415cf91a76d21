"""SG Height Map Forward on heights of any slope (a user's Height input: a noise times 1e8, a
height in millimetres on a metre-sized object).

The group inverts the Bump node: g = N - nb / (nb . N). Mathematically nb . N = 1 / |N - grad h|
is positive, but past slopes of about 1e7 its float32 value is noise around zero; where it came
out negative the resolved normal turned over (on the unit sphere: a height image times 1e7 had
a maximum of 180 degrees off the float64 reference, times 1e8 a mean of 69 degrees, 156 of 512
texels facing away from the surface where the truth does not; every line). The floor on nb . N
keeps g along nb, as the truth is.

What the floor cannot give back: the Bump node's normal is a unit vector, so past slopes of about
1e7 it no longer carries the slope's size, and where such heights meet a tiny Bump Scale (1e-6
and less) the result is flatter than the truth (docs/proof.md, "Stability"); it still never
faces away from the surface where the truth does not.
"""

import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.node_vocabulary import Math  # noqa: E402
from surfgrad_addon.harness import compare as C  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402
from surfgrad_addon.harness.graph import Graph, surface_gradient  # noqa: E402
from surfgrad_addon.reference import methods as M  # noqa: E402


def _compare(gain, bump_scale):
    """The sphere's height image times `gain` into SG Height Map Forward, against the float64
    reference of the same heights (Listing 7 along the bake's differentials)."""
    import bpy
    obj = scenes.new_scene(["Sphere"])["Sphere"]

    def graph(inp, nodes, links):
        g = Graph(nodes, links)
        height = g.first(g.image(inp.bpy_image("height"), g.uv(inp.uv_map)))
        node = g.group(G.height_map_forward_group(),
                       Height=g.math(Math.MULTIPLY, height, gain))
        g.set(node, Bump_Scale=bump_scale)
        return g.resolve(surface_gradient(node))

    def reference(inp, td):
        return M.height_map_surfgrad(td, inp.images["height"][0] * gain, "forward",
                                     bump_scale=bump_scale, uv_map=inp.uv_map)

    inp = C.prepare_inputs(obj)
    try:
        report, _ = C.compare_graph(inp, obj, graph, reference, 32)
    finally:
        for _, img in inp.images.values():
            bpy.data.images.remove(img)
    return report


@pytest.mark.parametrize("gain, bump_scale", [(1e8, 1e-3), (1e10, 1.0)])
def test_steep_heights_never_turn_the_normal_over(gain, bump_scale):
    r = _compare(gain, bump_scale)
    assert r["finite_unit_fraction_all"] == 1.0
    # Nearly every normal lies almost in the surface here, half of them a hair below it (the
    # truth's too): none may face away where the truth does not, and all stay on the truth.
    assert r["truth_facing_away_fraction"] > 0.4
    assert r["faces_away_where_truth_does_not"] == 0
    assert r["max_deg"] < 0.05, r["max_deg"]
    assert np.isfinite(r["mean_deg"]) and r["mean_deg"] < 0.01


def test_steep_heights_with_a_tiny_bump_scale_are_flatter_but_never_turned_over():
    r = _compare(1e10, 1e-8)
    assert r["finite_unit_fraction_all"] == 1.0
    assert r["faces_away_where_truth_does_not"] == 0
    assert r["mean_deg"] > 1.0          # the documented limit: the size of the slope is lost
