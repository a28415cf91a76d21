"""Which triangle, which image and which normal a Cycles bake gives each texel, pinned on every
supported line against the reference rasteriser (issue 12):

1. A texel several triangles claim (overlapping UV islands) goes to the LAST of them, the
   highest loop-triangle index: Blender's RE_bake_pixels_populate (render/intern/bake.cc)
   scan-converts the triangles in order and store_bake_pixel overwrites. Pinned with two
   triangles of different normals both ways round, and with a soup of 60 random triangles
   whose bake-assigned triangle ids equal the reference's at every texel.
2. A plain image bakes nothing outside 0..1 (no wrap); a UDIM tile bakes the triangles at its
   own UV offset (reference/tiles.py).
3. The normal a flat face shades with: its triangle's own normal (all lines), or Blender's
   corner normals where the mesh has per-corner normals (5.2 for mixed smooth/flat faces; up
   to 5.0 only with sharp edges or custom normals). LineFacts.sharp_faces_give_corner_normals.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

import surfgrad_addon.reference as R  # noqa: E402
from surfgrad_addon.harness import bake as B  # noqa: E402
from surfgrad_addon.harness.compare import angle_deg  # noqa: E402
from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def soup(name, uvs, heights=None):
    """Separate triangles at their UVs (z = heights per corner), face attribute "fid" = index."""
    uvs = np.asarray(uvs, float)
    n = len(uvs)
    z = np.zeros(3 * n) if heights is None else np.asarray(heights, float).ravel()
    pos = np.concatenate([uvs.reshape(-1, 2), z[:, None]], 1)
    me = bpy.data.meshes.new(name)
    me.from_pydata(pos.tolist(), [], [[3 * i, 3 * i + 1, 3 * i + 2] for i in range(n)])
    me.uv_layers.new(name="UVMap").uv.foreach_set("vector", uvs.ravel())
    me.attributes.new("fid", "FLOAT", "FACE").data.foreach_set(
        "value", np.arange(n, dtype=np.float32))
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    return obj


def _fid(nodes, links):
    node = nodes.new("ShaderNodeAttribute")
    node.attribute_name = "fid"
    return node.outputs["Fac"]


def _normal(nodes, links):
    return nodes.new("ShaderNodeNewGeometry").outputs["Normal"]


def baked_ids(obj, res):
    px, cov, _ = B.bake_vector(obj, _fid, res, res, "UVMap")
    return np.where(cov, np.rint(px[..., 0]).astype(int), -1)


def claims(uvs, res):
    """How many triangles contain each bake sample point: plain loops, half-plane tests."""
    y, x = np.mgrid[0:res, 0:res]
    px, py = (x + 0.501) / res, (y + 0.502) / res
    count = np.zeros((res, res), int)
    for a, b, c in np.asarray(uvs, float):
        s = [(q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (px - p[0])
             for p, q in ((a, b), (b, c), (c, a))]
        count += np.all(np.stack(s) >= 0, 0) | np.all(np.stack(s) <= 0, 0)
    return count


LOWER = [[0.1, 0.1], [0.9, 0.1], [0.1, 0.9]]
UPPER = [[0.2, 0.15], [0.95, 0.3], [0.3, 0.95]]


@pytest.mark.parametrize("order", ["lower-first", "upper-first"])
def test_the_last_of_two_overlapping_triangles_wins(fresh, order):
    uvs = [LOWER, UPPER] if order == "lower-first" else [UPPER, LOWER]
    # Different normals: the first triangle flat, the second tilted (z rises along u).
    heights = [[0, 0, 0], [0.0, 0.5, 0.1]]
    obj = soup("Two", uvs, heights)
    res = 32
    ids = baked_ids(obj, res)
    both = claims(uvs, res) == 2
    assert both.sum() == 150               # the overlap, counted by brute force
    assert (ids[both] == 1).all()          # the later triangle, whichever it is
    td = R.rasterize(mesh_arrays_from_object(obj, need_tangents=False), "UVMap", res, res)
    np.testing.assert_array_equal(td.triangle, ids)
    np.testing.assert_array_equal(td.contested, both)
    assert (td.other_triangle[both] == 0).all()
    # ... and the baked normal there is the later triangle's normal, not the earlier one's.
    px, _, _ = B.bake_vector(obj, _normal, res, res, "UVMap")
    n1 = td.mesh.geometric_normals_world[1]
    n0 = td.mesh.geometric_normals_world[0]
    assert angle_deg(n0, n1) > 10
    assert angle_deg(px[both], n1).max() < 0.01


@pytest.mark.parametrize("res", [64, 37])
def test_a_soup_of_overlapping_triangles_matches_the_bake_texel_for_texel(fresh, res):
    rng = np.random.default_rng(1)
    uvs = rng.uniform(-0.1, 1.1, (60, 1, 2)) + rng.normal(0, 0.15, (60, 3, 2))
    obj = soup("Soup", uvs)
    ids = baked_ids(obj, res)
    td = R.rasterize(mesh_arrays_from_object(obj, need_tangents=False), "UVMap", res, res)
    assert (td.triangle != ids).sum() == 0
    many = claims(uvs, res)
    assert {64: 614, 37: 204}[res] == (many >= 2).sum() == td.contested.sum()
    # The highest index among the claimants, by brute force.
    y, x = np.nonzero(many >= 2)
    assert (ids[y, x] >= 0).all()


@pytest.mark.parametrize("shift", [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0)])
def test_a_plain_image_ignores_uvs_outside_the_unit_square(fresh, shift):
    uvs = np.array([LOWER]) + np.array(shift)
    obj = soup("Shifted", uvs)
    assert (baked_ids(obj, 16) >= 0).sum() == 0
    td = R.rasterize(mesh_arrays_from_object(obj, need_tangents=False), "UVMap", 16, 16)
    assert not td.covered.any()
    # Inside 0..1 the same triangle covers 66 texels (no wrap took them away).
    assert (baked_ids(soup("Home", [LOWER]), 16) >= 0).sum() == 66


def test_udim_tiles_bake_each_tile_at_its_uv_offset(fresh):
    uvs = np.array([LOWER, np.array(LOWER) + [1, 0], np.array(UPPER) + [0, 1],
                    np.array(LOWER) + [0.5, 0]])             # the last straddles 1001/1002
    obj = soup("Tiles", uvs)
    tiles = R.tiles.tiles_touched(uvs)
    assert tiles == [1001, 1002, 1011]
    baked, _ = B.bake_vector_tiles(obj, _fid, 16, 16, tiles, "UVMap")
    mesh = mesh_arrays_from_object(obj, need_tangents=False)
    for number in tiles:
        px, cov = baked[number]
        ids = np.where(cov, np.rint(px[..., 0]).astype(int), -1)
        td = R.rasterize(mesh, "UVMap", 16, 16, uv_offset=R.tiles.tile_uv_offset(number))
        np.testing.assert_array_equal(td.triangle, ids)
        assert td.covered.sum() > 30
    assert set(np.unique(baked[1002][0][baked[1002][1], 0])) == {1.0, 3.0}


def _bumpy_grid():
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=6, y_subdivisions=6, size=2)
    obj = bpy.context.object
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[:, 2] = np.random.default_rng(0).normal(0, 0.15, len(co))   # non-planar quads
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    return obj


@pytest.mark.parametrize("case", ["flat", "mixed", "smooth+sharp", "mixed+sharp"])
def test_the_shading_normal_of_flat_and_mixed_faces(fresh, case):
    obj = _bumpy_grid()
    me = obj.data
    smooth = np.full(len(me.polygons), "smooth" in case)
    if "mixed" in case:
        smooth[:3] = True
    me.polygons.foreach_set("use_smooth", smooth)
    me.edges[5].use_edge_sharp = "sharp" in case
    me.update()
    px, _, _ = B.bake_vector(obj, _normal, 64, 64, "UVMap")
    td = R.rasterize(mesh_arrays_from_object(obj, need_tangents=False), "UVMap", 64, 64)
    baked = px[td.pixel[:, 1], td.pixel[:, 0]]
    assert angle_deg(baked, td.shading_normal).max() < 0.01
    # The rule matters: the polygon's own normal is far off on these non-planar quads.
    me.calc_loop_triangles()
    face = np.array([t.polygon_index for t in me.loop_triangles])[td.tri]
    poly_n = np.array([p.normal[:] for p in me.polygons])[face]
    flat = ~smooth[face]
    if not flat.any():
        return
    off = angle_deg(baked[flat], poly_n[flat]).max()
    facts = B.running_line()
    if case == "flat" or (case == "mixed" and not facts.sharp_faces_give_corner_normals):
        assert off > 20          # each triangle its own normal, not the polygon's
    else:
        assert off < 0.01        # corner normals: the polygon's normal on a flat face
