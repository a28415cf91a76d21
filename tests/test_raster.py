"""Meshes into texels: hand-computed texels, exact coverage, exact derivatives, clear errors."""

import numpy as np
import pytest

import surfgrad_addon.reference as R

pytestmark = pytest.mark.tier("numpy")


def one_mesh(positions, tris, uvs, normals=None, matrix=None, extra_uv=None):
    positions = np.asarray(positions, float)
    tris = np.asarray(tris)
    if normals is None:
        normals = np.tile([0, 0, 1.0], (len(tris), 3, 1))
    uv_maps = {"UVMap": np.asarray(uvs, float)}
    if extra_uv is not None:
        uv_maps["Second"] = np.asarray(extra_uv, float)
    return R.MeshArrays(positions, tris, np.asarray(normals, float), uv_maps,
                        matrix_world=np.eye(4) if matrix is None else matrix, name="Test")


def test_single_triangle_hand_computed_texels():
    # UV triangle (0,0), (1,0), (0,1) on a 4x4 texture. Blender samples texel (i, j) at
    # ((i + .501)/4, (j + .502)/4): inside when (i + .501) + (j + .502) <= 4, i.e. i + j <= 2
    # (the diagonal i + j = 3 falls just outside, by the bake offset).
    mesh = one_mesh([[0, 0, 0], [2, 0, 0], [0, 3, 0]], [[0, 1, 2]],
                    [[[0, 0], [1, 0], [0, 1]]])
    td = R.rasterize(mesh, "UVMap", 4, 4)
    expect = {(i, j) for i in range(4) for j in range(4) if i + j <= 2}
    got = {tuple(p) for p in td.pixel}
    assert got == expect
    # Texel (1, 1): sample (1.501/4, 1.502/4) -> barycentrics (1 - s - t, s, t).
    k = [tuple(p) for p in td.pixel].index((1, 1))
    s_, t_ = 1.501 / 4, 1.502 / 4
    np.testing.assert_allclose(td.barycentric[k], [1 - s_ - t_, s_, t_], atol=1e-12)
    np.testing.assert_allclose(td.position[k], [2 * s_, 3 * t_, 0], atol=1e-12)
    dp_ds, dp_dt, bad = td.derivatives()
    np.testing.assert_allclose(dp_ds[k], [2, 0, 0])
    np.testing.assert_allclose(dp_dt[k], [0, 3, 0])
    assert not bad.any()
    assert td.triangle[0, 3] == -1 and td.triangle[0, 2] == 0 and td.covered.sum() == 6
    # With exact centres (offset 0.5) the diagonal texels are on the edge and included.
    centred = R.rasterize(mesh, "UVMap", 4, 4, sample_offset=(0.5, 0.5))
    assert {tuple(p) for p in centred.pixel} == {(i, j) for i in range(4) for j in range(4)
                                                  if i + j <= 3}


def brute_force_owners(mesh, w, h):
    """How many triangles contain each texel centre (closed triangles), by plain loops over
    triangles with a half-plane test (independent of the rasteriser's algorithm)."""
    counts = np.zeros((h, w), int)
    centres = R.bake_sample_points(w, h)
    for tri_uv in mesh.uv_maps["UVMap"]:
        a, b, c = tri_uv
        def side(p0, p1):
            return ((p1[0] - p0[0]) * (centres[..., 1] - p0[1])
                    - (p1[1] - p0[1]) * (centres[..., 0] - p0[0]))
        s = np.stack([side(a, b), side(b, c), side(c, a)])
        tol = 1e-12
        inside = np.all(s >= -tol, 0) | np.all(s <= tol, 0)
        counts += inside
    return counts


@pytest.mark.parametrize("w,h", [(16, 16), (37, 23)])
def test_uv_square_is_covered_exactly_once(w, h):
    mesh = R.meshes.plane(size=2.0, subdivisions=5)
    td = R.rasterize(mesh, "UVMap", w, h)
    assert td.covered.all()
    assert len(td.pixel) == w * h and len(np.unique(td.pixel, axis=0)) == w * h
    owners = brute_force_owners(mesh, w, h)
    assert owners.min() >= 1          # every texel centre lies in some triangle...
    # ...and the chosen triangle is one that contains it.
    uv = td.uv()
    np.testing.assert_allclose(uv, R.bake_sample_points(w, h)[td.pixel[:, 1], td.pixel[:, 0]],
                               atol=1e-12)


def test_mirrored_island_and_transformed_object():
    # Two triangles, the second with mirrored (clockwise) UVs; object rotated, scaled
    # non-uniformly and negatively.
    ang = np.radians(30)
    rot = np.array([[np.cos(ang), -np.sin(ang), 0], [np.sin(ang), np.cos(ang), 0], [0, 0, 1]])
    m3 = rot @ np.diag([2.0, -0.5, 3.0])
    mat = np.eye(4)
    mat[:3, :3] = m3
    mat[:3, 3] = [10.0, 0, -5]
    mesh = one_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [3, 0, 0], [4, 0, 0], [3, 1, 0]],
                    [[0, 1, 2], [3, 4, 5]],
                    [[[0.0, 0.0], [0.5, 0.0], [0.0, 1.0]],
                     [[1.0, 0.0], [0.5, 0.0], [1.0, 1.0]]], matrix=mat)
    td = R.rasterize(mesh, "UVMap", 32, 32)
    dp_ds, dp_dt, _ = td.derivatives()
    first = td.tri == 0
    np.testing.assert_allclose(dp_ds[first], np.tile(m3 @ [2, 0, 0], (first.sum(), 1)), atol=1e-12)
    np.testing.assert_allclose(dp_ds[~first], np.tile(m3 @ [-2, 0, 0], ((~first).sum(), 1)),
                               atol=1e-12)
    np.testing.assert_allclose(dp_dt[~first], np.tile(m3 @ [0, 1, 0], ((~first).sum(), 1)),
                               atol=1e-12)
    # World positions: M p + translation, checked through the UVs (p = (2s, t) on triangle 0).
    uv = td.uv()
    p_obj = np.stack([2 * uv[first, 0], uv[first, 1], 0 * uv[first, 0]], -1)
    np.testing.assert_allclose(td.position[first], p_obj @ m3.T + mat[:3, 3], atol=1e-12)
    # Normals go by the inverse transpose; the geometric normal keeps facing +z of the object.
    n_expect = np.linalg.inv(m3).T @ [0, 0, 1]
    np.testing.assert_allclose(td.normal[0], n_expect, atol=1e-12)
    np.testing.assert_allclose(td.geometric_normal[0], n_expect / np.linalg.norm(n_expect),
                               atol=1e-12)


def test_second_uv_map_steps_follow_the_chain_rule():
    mesh = R.meshes.plane(size=2.0, subdivisions=2)
    td = R.rasterize(mesh, "UVMap", 8, 8)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps("Detail")
    a = np.radians(R.meshes.DETAIL_ROTATION_DEG)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]) * R.meshes.DETAIL_TILING
    np.testing.assert_allclose(dst_dx, np.tile(rot[:, 0] / 8, (64, 1)), atol=1e-12)
    np.testing.assert_allclose(dst_dy, np.tile(rot[:, 1] / 8, (64, 1)), atol=1e-12)
    np.testing.assert_allclose(dpdx, np.tile([2 / 8, 0, 0], (64, 1)), atol=1e-12)


def test_sphere_texels_lie_on_the_sphere_and_interior_excludes_borders():
    mesh = R.meshes.uv_sphere(segments=48, rings=24)
    td = R.rasterize(mesh, "UVMap", 128, 64)
    r = np.linalg.norm(td.position, axis=-1)
    chord_sag = 1 - np.cos(np.pi / 48)
    assert np.all(r <= 1 + 1e-12) and np.all(r >= 1 - 2 * chord_sag)
    inner = td.interior()
    assert 0.8 < inner.mean() < 1.0
    # Interior texels have all 8 neighbours covered.
    px = td.pixel[inner]
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            assert td.covered[px[:, 1] + dy, px[:, 0] + dx].all()
    img = td.to_image(r)
    assert np.isnan(img[~td.covered]).all() and np.isfinite(img[td.covered]).all()


def test_degenerate_uv_triangles_cover_nothing_and_are_flagged():
    mesh = one_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]],
                    [[[0.2, 0.2], [0.4, 0.4], [0.6, 0.6]]])
    td = R.rasterize(mesh, "UVMap", 8, 8)
    assert not td.covered.any()
    assert mesh.triangle_derivatives("UVMap")[2].all()


def test_bad_meshes_get_clear_errors():
    good = R.meshes.plane()
    with pytest.raises(KeyError, match="no UV map named 'Nope'"):
        R.rasterize(good, "Nope", 8, 8)
    empty = R.MeshArrays(np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros((0, 3, 3)),
                         {"UVMap": np.zeros((0, 3, 2))}, name="Empty")
    with pytest.raises(ValueError, match="no mesh data"):
        R.rasterize(empty, "UVMap", 8, 8)
    no_uv = R.MeshArrays(good.positions, good.triangles, good.corner_normals, {}, name="NoUV")
    with pytest.raises(ValueError, match="no UV map; add one"):
        R.rasterize(no_uv, "UVMap", 8, 8)
    bad = R.meshes.plane()
    bad.positions = bad.positions.copy()
    bad.positions[0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        R.rasterize(bad, "UVMap", 8, 8)


def test_overlapping_triangles_go_to_the_last_one_and_are_flagged():
    # Three triangles over one another in UV: every texel goes to the highest index covering
    # it (Blender's bake writes triangles in order: tests/test_raster_rules.py pins it).
    rng = np.random.default_rng(7)
    uvs = rng.uniform(0.05, 0.95, (12, 3, 2))
    mesh = one_mesh(rng.normal(size=(36, 3)), np.arange(36).reshape(12, 3), uvs)
    td = R.rasterize(mesh, "UVMap", 40, 40)
    centres = R.bake_sample_points(40, 40)
    expect = np.full((40, 40), -1)
    count = np.zeros((40, 40), int)
    for i, (a, b, c) in enumerate(uvs):
        s = [(q[0] - p[0]) * (centres[..., 1] - p[1]) - (q[1] - p[1]) * (centres[..., 0] - p[0])
             for p, q in ((a, b), (b, c), (c, a))]
        inside = np.all(np.stack(s) >= 0, 0) | np.all(np.stack(s) <= 0, 0)
        expect[inside] = i
        count += inside
    np.testing.assert_array_equal(td.triangle, expect)
    np.testing.assert_array_equal(td.contested, count >= 2)
    assert td.contested.sum() > 300
    other = td.other_triangle[td.contested]
    assert (other >= 0).all() and (other < td.triangle[td.contested]).all()
    assert (td.other_triangle[~td.contested] == -1).all()


def test_texels_within_rounding_of_an_edge_are_flagged():
    # Texel (1, 1) of a 4 x 4 image samples (1.501, 1.502): put an edge 1e-6 texels from it.
    x = 1.501 + 1e-6
    mesh = one_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]],
                    [[[x / 4, 0.0], [4 / 4, 0.0], [x / 4, 4 / 4]]])
    td = R.rasterize(mesh, "UVMap", 4, 4)
    assert td.triangle[1, 1] == -1 and td.triangle[1, 2] == 0
    edge = R.meshes.plane(size=2.0, subdivisions=1)
    tde = R.rasterize(edge, "UVMap", 4, 4)
    assert not tde.on_edge.any()          # a quad's diagonal passes no sample point
    mesh2 = one_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]],
                     [[[(1.501 - 1e-6) / 4, 0.0], [1.0, 0.0], [(1.501 - 1e-6) / 4, 1.0]]])
    td2 = R.rasterize(mesh2, "UVMap", 4, 4)
    assert td2.triangle[1, 1] == 0 and td2.on_edge[1, 1] and not td2.on_edge[1, 2]


def test_udim_tile_math_and_offsets():
    T = R.tiles
    assert T.tile_uv_offset(1001) == (0.0, 0.0) and T.tile_uv_offset(1012) == (1.0, 1.0)
    assert T.tile_uv_offset(1010) == (9.0, 0.0)
    np.testing.assert_array_equal(T.tile_number([0.5, 1.5, 9.99, 10.0, -0.1], [0.5, 1.2, 0, 0, 0]),
                                  [1001, 1012, 1010, -1, -1])
    with pytest.raises(ValueError, match="UDIM tile 1000 is out of range"):
        T.tile_uv_offset(1000)
    tri = np.array([[[0.1, 0.1], [1.5, 0.2], [0.2, 0.9]], [[-1, -1], [-0.5, -1], [-1, -0.5]],
                    [[2.2, 3.1], [2.8, 3.1], [2.5, 3.9]]])
    assert T.tiles_touched(tri) == [1001, 1002, 1033]
    assert T.tiles_touched(tri[1:2]) == []
    # A tile is its own UV square: the same island moved by a tile covers the same texels.
    mesh = R.meshes.plane(size=2.0, subdivisions=3)
    home = R.rasterize(mesh, "UVMap", 16, 16)
    moved = one_mesh(mesh.positions, mesh.triangles, mesh.uv_maps["UVMap"] + [2, 3])
    away = R.rasterize(moved, "UVMap", 16, 16)
    assert not away.covered.any()                       # a plain image: nothing, no wrap
    tile = R.rasterize(moved, "UVMap", 16, 16, uv_offset=T.tile_uv_offset(1033))
    np.testing.assert_array_equal(tile.triangle, home.triangle)
    np.testing.assert_allclose(tile.barycentric, home.barycentric, atol=1e-9)
