"""A large bake in pieces (harness/bake.py, bake_vector_in_pieces) is the whole bake: the same
texels covered and the same values to float32 rounding, and the mesh's UV maps as they were."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.harness import bake as B  # noqa: E402
from surfgrad_addon.harness import compare as C  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402
from surfgrad_addon.harness.graph import Graph  # noqa: E402
from surfgrad_addon.harness.methods import METHODS  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def uv_state(obj):
    return [(layer.name, layer.active, layer.active_render) for layer in obj.data.uv_layers]


@pytest.mark.parametrize("obj_name,method", [("Sphere", "normal-map"), ("Torus", "height-map")])
def test_pieces_bake_what_one_bake_does(obj_name, method):
    objects = scenes.new_scene()
    G.build_all()
    obj = objects[obj_name]
    inp = C.prepare_inputs(obj, variant="forward")
    m = METHODS[method]

    def build(nodes, links):
        return Graph(nodes, links).resolve(m.graph(inp, nodes, links))
    before = uv_state(obj)
    whole, covered, _ = B.bake_vector(obj, build, 128, 128, uv_map="UVMap")
    pieces, covered_p, seconds = B.bake_vector_in_pieces(obj, build, 128, 128, uv_map="UVMap",
                                                         piece=32)
    assert uv_state(obj) == before and B.PIECE_UV_MAP not in obj.data.uv_layers
    assert seconds > 0
    np.testing.assert_array_equal(covered_p, covered)
    assert covered.sum() > 0.8 * 128 * 128
    # Float32 rounding of the shifted barycentrics (measured 3.3e-5 at most, 0.002 degrees).
    np.testing.assert_allclose(pieces[covered], whole[covered], rtol=0, atol=2e-4)
    assert np.abs(pieces[covered] - whole[covered]).mean() < 5e-6


@pytest.mark.tier("blender")
def test_piece_grid_is_a_power_of_two_that_divides_the_size():
    assert B._grid(2048, 2048) == 1
    assert B._grid(4096, 2048) == 2
    assert B._grid(8192, 2048) == 4
    assert B._grid(3000, 2048) == 2
    assert B._grid(4097, 2048) is None
