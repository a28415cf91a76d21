"""SG Procedural Basis [<map>] (the per-map group, its UV unlinked) bakes the frame of the
generic SG Procedural Basis fed that map by a UV Map node: the same Listing 4, with the choice
of map made in the group (a constant Cycles folds) instead of per sample. The per-map group's
fold is counted in tests/test_render_cost_folding.py."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.harness import bake, scenes  # noqa: E402
from surfgrad_addon.harness.graph import Graph  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 24
MAP = "Detail"         # scenes' second UV map: the first rotated, so its frame differs


@pytest.fixture(scope="module")
def torus():
    scenes.new_scene(["Torus"])
    return bpy.data.objects["Torus"]


def _frame(obj, basis):
    """Tangent and bitangent of the group node that basis(g) makes, baked over the active map:
    (texels, 6) of the covered texels."""
    out = []
    for socket in ("Tangent", "Bitangent"):
        def build(nodes, links):
            return basis(Graph(nodes, links)).outputs[socket]
        px, cov, _ = bake.bake_vector(obj, build, RES, RES)
        out.append(px[cov].astype(np.float64))
    return np.concatenate(out, axis=1)


def test_per_map_basis_is_the_generic_group_fed_that_map(torus):
    assert torus.data.uv_layers.active.name != MAP        # the per-map group must not fall back
    per_map = _frame(torus, lambda g: g.group(G.procedural_basis_group(MAP)))
    linked = _frame(torus, lambda g: g.group(G.procedural_basis_group(), UV=g.uv(MAP)))
    active = _frame(torus, lambda g: g.group(G.procedural_basis_group()))
    assert len(per_map) > 0.3 * RES * RES
    diff = np.abs(per_map - linked).max()
    print(f"per-map vs generic fed {MAP}: max {diff:.2e} over {len(per_map)} texels; "
          f"vs the active map: max {np.abs(per_map - active).max():.2f}")
    assert diff < 1e-5
    # the frames are unit and the map matters: the active map's frame is another one
    np.testing.assert_allclose(np.linalg.norm(per_map[:, :3], axis=1), 1.0, atol=1e-4)
    assert np.abs(per_map - active).max() > 0.5


@pytest.mark.tier("blender")
def test_per_map_group_is_named_and_reads_its_map(torus):
    tree = G.procedural_basis_group(MAP)
    assert tree.name == f"SG Procedural Basis [{MAP}]"
    assert MAP in tree.description and "(active render map)" not in tree.description
    maps = [n.uv_map for n in tree.nodes if n.bl_idname == "ShaderNodeUVMap"]
    assert maps == [MAP]
    generic = G.procedural_basis_group()
    assert [n.uv_map for n in generic.nodes if n.bl_idname == "ShaderNodeUVMap"] == [""]
    def sockets(t):
        return [(s.name, s.in_out) for s in t.interface.items_tree if s.item_type == "SOCKET"]
    assert sockets(tree) == sockets(generic)             # one interface, the same sockets
