"""Red team 59b: the product on public assets the project had not used: bevyengine/bevy's
assets/models (glTF and GLB: FlightHelmet with 2k normal maps and TANGENT attributes, the
SheenChair of MixedLightingExample with two UV sets and KHR_texture_transform, AlienCake's
alien with UVs to u -28, AnisotropyBarnLamp with KTX2 normal maps, Faces' text meshes, PalmTree,
terrain, Fox (skinned), GolfBall, Cubes, primitives, craft_speederD), imported with Blender's
glTF importer on 5.2; each finding is built here by code, a few faces, so no test reads a
fetched or imported file.

1. A UV map with no area anywhere whose UVs lie inside the UDIM grid (bevy's Faces/faces.glb:
   six text meshes, 180 to 517 faces, exported with TEXCOORD_0 = (u, 0): every UV on the line
   v = 0; the same for a layout squashed onto any line or point inside the 0-1 square):
   bake-normal-map, the API, Freeze and bake-batch refused it as "has no faces in any UDIM
   tile (its UVs span u 0..1, v 0..0 ...), so nothing would be baked: move its islands into
   the 0-1 square (tile 1001) or onto UDIM tiles" (exit 2; bake-batch exit 1), naming the
   wrong thing and a fix that does nothing (its UVs are in the square already; for v 0.5 the
   same words, "v 0.5..0.5"), while `compare` said "has no area ... unwrap it". The tile plan
   ran before the area check, and a face with no UV area lies in no tile. Now all four say
   "UV map 'UVMap' of object 'Letters' has no area (every face collapsed to a point or a line
   in UV space), so the bake would cover no texel: unwrap it (UV > Unwrap)"
   (normal_bake.no_tile_problem given the UV triangles; the batch scan keeps that refusal).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze  # noqa: E402

pytestmark = pytest.mark.tier("blender")

NO_AREA = ("UV map 'UVMap' of object 'Letters' has no area (every face collapsed to a point or "
           "a line in UV space), so the bake would cover no texel: unwrap it (UV > Unwrap)")


def _squashed_uvs(uv_of_x):
    """Two quads (a 2 x 1 strip, as a text mesh's letters) whose UV corners are uv_of_x(x):
    faces with area on the mesh, none in UV space."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    me = bpy.data.meshes.new("Letters")
    me.from_pydata([(x, y, 0.0) for y in (0, 1) for x in (0, 1, 2)], [],
                   [(0, 1, 4, 3), (1, 2, 5, 4)])
    uv = me.uv_layers.new(name="UVMap")
    for loop in me.loops:
        uv.data[loop.index].uv = uv_of_x(me.vertices[loop.vertex_index].co.x)
    obj = bpy.data.objects.new("Letters", me)
    bpy.context.scene.collection.objects.link(obj)
    mat = bpy.data.materials.new("Letters")
    mat.use_nodes = True
    me.materials.append(mat)
    return obj


LAYOUTS = {"on v = 0 (faces.glb)": lambda x: (x / 2.0, 0.0),
           "on v = 0.5": lambda x: (x / 2.0, 0.5),
           "on one point": lambda x: (0.25, 0.75)}


@pytest.mark.parametrize("layout", LAYOUTS)
def test_a_layout_with_no_uv_area_is_refused_as_such_by_the_bake(tmp_path, layout):
    """Finding 1, bake-normal-map and the API: before, "has no faces in any UDIM tile ...
    move its islands into the 0-1 square"; now the no-area refusal, nothing written."""
    obj = _squashed_uvs(LAYOUTS[layout])
    uvs = np.array([d.uv[:] for d in obj.data.uv_layers["UVMap"].data])
    assert ((uvs >= 0) & (uvs <= 1)).all()          # in the square: no move would help
    with pytest.raises(ValueError) as err:
        api.bake_normal_map(obj, str(tmp_path / "n.png"), resolution=32, log=None)
    assert str(err.value) == NO_AREA, str(err.value)
    assert "move its islands" not in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_a_layout_with_no_uv_area_is_refused_as_such_by_a_batch(tmp_path):
    """Finding 1, bake-batch (the open, saved file, in this session): the asset fails with
    the no-area refusal (before: the tile words), no map written."""
    _squashed_uvs(LAYOUTS["on v = 0 (faces.glb)"])
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "faces.blend"))
    maps = tmp_path / "maps"
    maps.mkdir()
    report = api.bake_batch(output=str(maps / "{object}.<UDIM>.png"), resolution=32, log=None)
    (asset,) = report["assets"].values()
    assert asset["status"] == "failed" and report["counts"]["failed"] == 1, asset
    assert NO_AREA in asset["error"], asset["error"]
    assert not list(maps.glob("*.png"))


def test_a_layout_with_no_uv_area_is_refused_as_such_by_freeze():
    """Finding 1, Freeze: its check's refusal (before: the tile words), the material
    unchanged."""
    obj = _squashed_uvs(LAYOUTS["on v = 0.5"])
    mat = obj.active_material
    api.add_layer_stack(mat)
    nodes = sorted(n.name for n in mat.node_tree.nodes)
    with pytest.raises(freeze.FreezeError) as err:
        freeze.check(obj, 32)
    assert str(err.value) == NO_AREA, str(err.value)
    assert sorted(n.name for n in mat.node_tree.nodes) == nodes
