"""Red team 59c: mutation testing of the ORACLE side (the numpy reference and compare's
machinery), where 57d and 58b mutated the node groups. Each mutant was one small edit to
surfgrad_addon/reference/ or harness/ (a few edit both twins, numba and numpy, the same way);
the numpy-tier files that cover those modules (test_listings, _sampling, _compiled_sampling,
_compiled_kernels, _compare_kernels, _noise, _decal_shapes, _raster, _faults_reference37,
_gpu_texture_filter, _gpu_texture_unit, _fast_reference, _compositing_and_baselines,
_height_blend, _method_registry, _faults_reads53a; for compare's file read and tiles
test_bake_compare, _bake_targets, _faults_images34, _faults_compare) were run with it.
80 mutants: 66 caught by the existing tests, 11 survived (caught here), 3 equivalent (below).
No mutant showed a bug in the current code. The survivors, each now caught here (an
independent expectation: a hand-worked texel, a closed-form plane, the listing's own
definition):

1. Listing 5's FLT_EPSILON at 1.19e-4 instead of 2^-23: nothing failed. At n.v = 1e-6 the
   surface gradient was (-8389, 0, 0) against the exact n - v / k = (-1e6, 0, 0).
2. Listing 6's determinant floor (DET_EPSILON) at 1.19e-7 instead of 1.19e-15: nothing failed,
   yet a texel's det is h^2 (h the texel step): a 1 cm object at 64^2 has det 2.4e-8, and its
   height map's surface gradient came out 0.205 of the slope (5.7 deg of tilt read as 1.2).
3. The listings' sign (`x < 0 ? -1 : 1`) counting zero as negative: nothing failed. Listing 4
   at det = 0 then turned t: (-2, 1, 0) for the hand-worked (2, -1, 0).
4. Texel steps dP/ds / H, dP/dt / W (width and height swapped): nothing failed, every test
   bakes square. A height ramp then gave half its slope on a 64 x 32 bake (0.00025 for
   0.0005) and twice it on a 32 x 64 one (0.2 for 0.1).
5. compare's backfacing bar (BACKFACING_DOT) at 0.3 instead of 1e-4: nothing failed; every
   compared texel whose shading normal was over 72.5 deg from its face was left out, wrong
   or not (a 90 deg error at 80 deg of smoothing: excluded). Now measured, 90 deg.
6. compare --image's file read: no test compared a correct group against a user's image
   FILE (only float arrays and refused files). Read as sRGB by Cycles (is_data dropped),
   its channels taken (B, G, R) for the reference, or its rows flipped, all passed: on a
   16^2 8-bit PNG at 32^2 those give p99 49.0, 90.0 and 45.2 deg; the correct read 1e-5.
7. Degenerate UV triangles at det <= 1e-6 of the edges' size (for 1e-14): nothing failed; a
   UV needle (0, 0), (1, 0), (1, 1e-7) lost its derivatives (zero), hand-worked (1, 0, 0),
   (0, 1000, 0).
8. The report over several UDIM tiles: its p99 / max over the first tile's errors only, or
   each tile's own figures replaced by the merged ones: nothing failed (the only multi-tile
   compare test has a correct group, alike on both tiles). Two tiles 0.01 and 5 deg off
   reported p99 0.01; now the union's p99 5 and each tile's own.
Left as equivalent: Listing 5's facing-away branch at n.v < 0 instead of < FLT_EPSILON (the
two branches agree within 1e-7 rad there); compare's float images not marked Non-Color, or
marked Linear Rec.709, in a file switched to Linear Rec.2020 in-process (5.2: Cycles did not
convert them; p99 5e-5 either way).
"""

import numpy as np
import pytest

import surfgrad_addon.reference as R
from surfgrad_addon.reference import listings as L
from surfgrad_addon.reference import methods as M
from surfgrad_addon.reference import vecmath as V
from surfgrad_addon.reference.agreement import COUNTS, texel_agreement

pytestmark = pytest.mark.tier("numpy")


# 1. Listing 5's FLT_EPSILON -------------------------------------------------------------------

def test_flt_epsilon_is_hlsls_and_listing5_divides_by_k_above_it():
    """HLSL's FLT_EPSILON is float32's machine epsilon, 2^-23. Listing 5 at n.v = k = 1e-6
    (a normal 89.99994 deg from the base, above FLT_EPSILON): sg = (k n - v) / k = n - v / k,
    for n = z and v = (1, 0, k): (-1e6, 0, 0) exactly, so its resolve points along v."""
    assert V.FLT_EPSILON == pytest.approx(2.0 ** -23, rel=1e-9)
    n = np.array([[0.0, 0.0, 1.0]])
    k = 1e-6
    v = np.array([[1.0, 0.0, k]])
    sg = L.surfgrad_from_perturbed_normal(n, v)
    np.testing.assert_allclose(sg, [[-1e6, 0.0, 0.0]], rtol=1e-12, atol=1e-9)
    out = L.resolve_normal_from_surface_gradient(n, sg)
    angle = np.degrees(np.arctan2(np.linalg.norm(np.cross(out, v)), np.sum(out * v)))
    assert angle < 1e-9


# 2. Listing 6's determinant floor at small texel steps -----------------------------------------

def test_listing6_gives_the_height_gradient_at_a_hundred_micron_texel():
    """A plane H = a x + b y has surface gradient (a, b, 0) at any scale. Listing 6 with texel
    steps h = 1e-4 (a 1 cm object at 100^2: det = h^2 = 1e-8) must give it: its determinant
    floor is the paper's 1.19e-15, far below any texel's h^2 (a floor at FLT_EPSILON scaled
    the gradient by det / FLT_EPSILON = 0.084 here)."""
    a, b, h = 0.3, -0.7, 1e-4
    n = np.array([[0.0, 0.0, 1.0]])
    dpdx, dpdy = np.array([[h, 0.0, 0.0]]), np.array([[0.0, h, 0.0]])
    deriv = np.array([[a * h, b * h]])                      # (dH/dx, dH/dy) per texel step
    sg = L.surfgrad_scale_dependent(n, dpdx, dpdy, deriv, None, None, None,
                                    is_deriv_screen_space=True)
    np.testing.assert_allclose(sg, [[a, b, 0.0]], rtol=1e-12, atol=1e-15)


def _ramp_plane_gradient(size, width, height, variant):
    """SG Height Map's reference on a plane `size` wide (UVs [0, 1]^2) baked at width x
    height, heights a ramp of 1 mm across u (texel-centre values, 64 texels): the surface
    gradient at texels away from the ramp's wrap seam."""
    td = R.rasterize(R.meshes.plane(size=size), "UVMap", width, height)
    cols = 64
    ramp = 1e-3 * (np.arange(cols) + 0.5) / cols
    image = np.tile(ramp, (16, 1))
    n, sg = M.height_map_surfgrad(td, image, variant=variant)
    u = td.uv()[:, 0]
    inner = (u > 0.1) & (u < 0.9)
    return n[inner], sg[inner]


@pytest.mark.parametrize("variant", ["one-texel", "hq"])
@pytest.mark.parametrize("size, width, height", [(0.01, 64, 64), (2.0, 64, 32),
                                                 (0.01, 32, 64)])
def test_height_ramp_on_a_plane_gives_its_slope_at_any_size_and_aspect(size, width, height,
                                                                       variant):
    """Closed form: heights 1 mm over the plane's width `size` (x = (u - 0.5) size): dH/dx =
    1e-3 / size, the surface gradient (1e-3 / size, 0, 0), 0.1 for a 1 cm plane. On a 1 cm
    plane at 64^2 (det = (0.01 / 64)^2 = 2.4e-8) and at a non-square 64 x 32 and 32 x 64
    bake (texel steps dP/ds / W, dP/dt / H: taken the other way round they halved or doubled
    the gradient)."""
    n, sg = _ramp_plane_gradient(size, width, height, variant)
    assert len(sg) > 100
    # x, y: the slope; z: the projection onto the shading normal, which Cycles' 16-bit
    # packing tilts by 1.5e-5 rad (so z is about -1.5e-5 times the slope, and sg . n is 0).
    np.testing.assert_allclose(sg[:, :2], np.tile([1e-3 / size, 0.0], (len(sg), 1)),
                               rtol=1e-6, atol=1e-12 / size)
    assert np.all(np.abs(sg[:, 2]) <= 2e-5 * 1e-3 / size)
    np.testing.assert_allclose(np.sum(sg * n, axis=-1), 0.0, atol=1e-15 / size)


def test_texel_steps_of_a_non_square_bake_are_one_texel_each_way():
    """A plane 2 wide at 16 x 8: one texel in s is 2 / 16 in x, one in t is 2 / 8 in y; the
    UV steps 1 / 16 and 1 / 8 (hand-worked)."""
    td = R.rasterize(R.meshes.plane(size=2.0), "UVMap", 16, 8)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps()
    count = len(td.pixel)
    np.testing.assert_allclose(dpdx, np.tile([2 / 16, 0, 0], (count, 1)), atol=1e-12)
    np.testing.assert_allclose(dpdy, np.tile([0, 2 / 8, 0], (count, 1)), atol=1e-12)
    np.testing.assert_allclose(dst_dx, np.tile([1 / 16, 0], (count, 1)), atol=1e-15)
    np.testing.assert_allclose(dst_dy, np.tile([0, 1 / 8], (count, 1)), atol=1e-15)



def test_a_needle_uv_triangle_keeps_its_exact_derivatives():
    """A UV needle (0, 0), (1, 0), (1, 1e-7) over positions (0, 0, 0), (1, 0, 0), (1, 1e-4, 0):
    the map is x = s, y = 1000 t (hand-worked), so dP/ds = (1, 0, 0), dP/dt = (0, 1000, 0).
    Degenerate means det within rounding of 0 (1e-14 of the edges' size); a looser floor
    (1e-6) zeroed this triangle's derivatives, which every texel-step method reads."""
    mesh = R.MeshArrays(np.array([[0, 0, 0], [1, 0, 0], [1, 1e-4, 0]], float),
                        np.array([[0, 1, 2]]), np.tile([0, 0, 1.0], (1, 3, 1)),
                        {"UVMap": np.array([[[0, 0], [1, 0], [1, 1e-7]]], float)},
                        matrix_world=np.eye(4), name="Needle")
    dp_ds, dp_dt, degenerate = mesh.triangle_derivatives("UVMap")
    assert not degenerate[0]
    np.testing.assert_allclose(dp_ds, [[1.0, 0.0, 0.0]], atol=1e-6)
    np.testing.assert_allclose(dp_dt, [[0.0, 1000.0, 0.0]], rtol=1e-6, atol=1e-6)

# 3. The listings' sign at zero ------------------------------------------------------------------

def test_listing4_counts_a_zero_determinant_as_positive():
    """The listings' `x < 0 ? -1 : 1`: 0 and -0 are +1. Listing 4 on a degenerate UV map
    (ddx(st) = (0, 1), ddy(st) = (0, 2): det = 0) over the plane z with dP/dx = x, dP/dy = y:
    invC0 = (ddy(st).y, -ddx(st).y) = (2, -1), t = 2 x - y left unnormalised, b = n x t =
    (1, 2, 0) (hand-worked). Zero counted negative flipped t."""
    assert V.sign_nonneg(np.array(0.0)) == 1.0 and V.sign_nonneg(np.array(-0.0)) == 1.0
    t, b = L.gen_basis_tb(np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]),
                          np.array([[0.0, 1.0, 0.0]]), np.array([[0.0, 1.0]]),
                          np.array([[0.0, 2.0]]))
    np.testing.assert_array_equal(t, [[2.0, -1.0, 0.0]])
    np.testing.assert_array_equal(b, [[1.0, 2.0, 0.0]])


# 4. compare's backfacing exclusion --------------------------------------------------------------

@pytest.mark.parametrize("facing_deg", [60.0, 80.0, 89.0])
def test_a_steep_but_front_facing_texel_is_compared(facing_deg):
    """A smooth-shaded texel whose shading normal is `facing_deg` from its face still faces
    front: compare must measure it. One texel, a bake 90 deg off the reference: compared (not
    excluded as backfacing), its error 90 deg. The exclusion is for dot(shading, geometric)
    within rounding of zero or below (texel_report.BACKFACING_DOT); a bar at 0.3 left out
    every texel beyond 72.5 deg, wrong or not."""
    from surfgrad_addon.harness import texel_report as TR
    a = np.radians(facing_deg)
    shading = np.array([[np.sin(a), 0.0, np.cos(a)]])
    geometric = np.array([[0.0, 0.0, 1.0]])
    ref = shading.copy()
    pixels = np.zeros((1, 1, 4), dtype=np.float32)
    pixels[0, 0] = (0.0, 1.0, 0.0, 1.0)                     # 90 deg from the reference
    flags = np.zeros((1, 1), dtype=bool)
    reasons = np.zeros((1, 1), dtype=np.int8)
    out = texel_agreement(np.zeros((1, 2), dtype=np.int64), pixels, np.ones((1, 1), bool),
                          flags, flags, ref, shading, geometric, shading, TR.BACKFACING_DOT,
                          reasons)
    assert out.counts[COUNTS.index("compared")] == 1 and reasons[0, 0] == 0
    np.testing.assert_allclose(out.error(), [90.0], atol=1e-9)


# 5. compare --image: how a user's 8-bit file is read on both sides -----------------------------

def _asymmetric_map(size=16):
    """An 8-bit tangent-space normal map whose red, green and rows all differ: tilts up to
    35 deg, red varying with u, green with v, so a swapped channel, a flipped row order or an
    sRGB decode moves every texel by degrees."""
    s = (np.arange(size) + 0.5) / size
    u, v = np.meshgrid(s, s)                    # row 0: v ~ 0 (Blender's pixel order)
    x = 0.5 * np.sin(2 * np.pi * u + 0.3) + 0.15
    y = 0.4 * np.sin(2 * np.pi * v + 0.7) * (0.5 + u)       # no symmetry in v or u
    n = np.stack([x, y, np.ones_like(x)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.round((n * 0.5 + 0.5) * 255).astype(np.uint8)


@pytest.mark.tier("bake")
def test_a_correct_group_is_within_the_bar_on_a_users_8_bit_png(tmp_path):
    """compare --image with an 8-bit PNG (the common case) on a correct SG Normal Map: within
    the bar (p99 0.1, max 0.5 deg). Both sides must read the file the same way: Cycles as
    Non-Color (an sRGB decode moves a 0.7 channel to 0.45), the reference Blender's pixels in
    their row and channel order. Before this test only float images (bpy_float_image) and
    refused files went through compare's file read, so a file read as sRGB, its channels
    turned (B, G, R) or its rows flipped passed every test."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.harness import compare, scenes as test_scenes
    bpy.ops.wm.read_factory_settings(use_empty=True)
    rgb = _asymmetric_map()
    img = bpy.data.images.new("png59c", 16, 16, alpha=False)
    rgba = np.concatenate([rgb / 255.0, np.ones((16, 16, 1))], -1).astype(np.float32)
    img.pixels.foreach_set(rgba.ravel())
    path = tmp_path / "n.png"
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)
    plane = test_scenes.new_scene(["Plane"])["Plane"]
    report, _heat = compare.compare_object(plane, "normal-map", 32, image=str(path),
                                           log=lambda *a: None)
    assert report["texels_compared"] > 500, report
    assert report["p99_deg"] <= 0.1 and report["max_deg"] <= 0.5, report
    # The map tilts the plane by 12-35 deg: a compare of anything against anything flat
    # could not pass by being blind to it.
    assert 5.0 < report["tilt_mean_deg"] < 40.0, report



# 6. The report over several UDIM tiles ------------------------------------------------------------

def _tile(number, err):
    from surfgrad_addon.harness import texel_report as TR
    sums = dict.fromkeys(("tilt_bake", "tilt_ref", *COUNTS), 0)
    sums.update(compared=len(err), both=len(err), finite_unit=len(err),
                finite_unit_all=len(err), backfacing_triangles=set(), grazing_triangles=set())
    return {"tile": number, "texels_covered": len(err), "texels_compared": len(err),
            "texels_contested": 0, "contested_max_deg": None, "_err": np.asarray(err, float),
            "_sums": sums, "excluded": {name: 0 for name, _ in
                                        list(TR.EXCLUSION_REASONS.values())[:3]}}


def test_the_report_over_tiles_holds_every_tiles_errors():
    """Two tiles, 100 texels each: 1001 all 0.01 deg off, 1002 all 5 deg off (a group wrong
    on the second tile only). Over the 200 errors (hand-worked): mean 2.505, p99 5, max 5, and
    tile 1002's own p99 5. A report of the first tile's errors alone (p99 0.01) would call
    the group right."""
    from surfgrad_addon.harness import texel_report as TR
    tiles = [_tile(1001, [0.01] * 100), _tile(1002, [5.0] * 100)]
    report = TR.merge(tiles)
    assert report["texels_compared"] == 200
    assert report["mean_deg"] == pytest.approx(2.505, rel=1e-12)
    assert report["p99_deg"] == pytest.approx(5.0, rel=1e-12)
    assert report["max_deg"] == pytest.approx(5.0, rel=1e-12)
    assert [t["p99_deg"] for t in tiles] == [pytest.approx(0.01), pytest.approx(5.0)]
