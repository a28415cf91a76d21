"""compare's per-texel statistics (reference/agreement.py): the compiled pass against its numpy
definition bit for bit, the numpy definition against the expressions compare used before it
(np.cross, norms, masks: written out again here), and a hand-made block whose every class and
count is known. No bpy needed."""

import numpy as np
import pytest

from surfgrad_addon.reference import agreement as A
from surfgrad_addon.reference import compiled

pytestmark = pytest.mark.tier("numpy")


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_block(seed, h=23, w=31, n=500):
    """A block of n distinct texels of an h x w image with every kind of texel: unbaked,
    edge, contested, backfacing, zero, non-finite and non-unit bakes."""
    rng = np.random.default_rng(seed)
    flat = rng.choice(h * w, size=n, replace=False)
    pixel = np.stack([flat % w, flat // w], axis=-1).astype(np.int64)
    ref = _unit(rng.normal(size=(n, 3)))
    pixels = np.zeros((h, w, 3), dtype=np.float32)
    # The bake: the reference tilted a little, some wild texels.
    tilt = _unit(ref + rng.normal(scale=1e-3, size=(n, 3))).astype(np.float32)
    tilt[:10] = 0.0
    tilt[10:15, 1] = np.nan
    tilt[15:20, 0] = np.inf
    tilt[20:40] *= np.float32(1.5)
    pixels[pixel[:, 1], pixel[:, 0]] = tilt
    covered = rng.random((h, w)) < 0.9
    contested = rng.random((h, w)) < 0.2
    on_edge = rng.random((h, w)) < 0.2
    geometric = _unit(rng.normal(size=(n, 3)))
    shading = _unit(geometric + rng.normal(scale=0.8, size=(n, 3)))
    ref[40:45] = 0.0
    ref[45:48, 2] = np.nan
    base = shading.copy()
    base[48:50] = 0.0
    return pixel, pixels, covered, contested, on_edge, ref, shading, geometric, base


def run(monkeypatch, enabled, args, dot=1e-4):
    monkeypatch.setenv(compiled.ENV, "1" if enabled else "0")
    h, w = args[2].shape
    reasons = np.full((h, w), 3, dtype=np.int8)
    a = A.texel_agreement(*args, dot, reasons)
    return a, reasons


@pytest.mark.skipif(not compiled.AVAILABLE, reason="numba is not installed")
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_pass_matches_its_numpy_definition_bit_for_bit(monkeypatch, seed):
    args = random_block(seed)
    plain, reasons_plain = run(monkeypatch, False, args)
    fast, reasons_fast = run(monkeypatch, True, args)
    assert 0 < plain.n < len(args[0]) and fast.n == plain.n
    n = plain.n
    assert np.array_equal(reasons_plain, reasons_fast)
    assert np.array_equal(plain.counts, fast.counts)
    assert np.array_equal(plain.flat[:n], fast.flat[:n])
    assert np.array_equal(plain.marked[:n], fast.marked[:n])
    assert np.array_equal(plain.backfacing, fast.backfacing)
    assert np.array_equal(plain.valid[:, :n], fast.valid[:, :n])
    # Bit for bit, NaN where NaN (an overflowing cross product stays NaN both ways).
    assert np.array_equal(plain.args[:, :n], fast.args[:, :n], equal_nan=True)
    assert np.array_equal(plain.error(), fast.error(), equal_nan=True)


def _old_statistics(pixel, pixels, covered, contested_image, on_edge, ref, shading, geometric,
                    base, dot):
    """What compare computed before agreement.py (its expressions written out again)."""
    def angle(a, b):
        ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                    np.sum(a * b, axis=-1)))
        valid = (np.isfinite(a).all(-1) & np.isfinite(b).all(-1)
                 & (np.linalg.norm(a, axis=-1) > 0) & (np.linalg.norm(b, axis=-1) > 0))
        return np.where(valid, ang, 180.0)
    px, py = pixel[:, 0], pixel[:, 1]
    baked = pixels[py, px].astype(np.float64)
    in_bake = covered[py, px]
    contested = contested_image[py, px]
    edge = on_edge[py, px] & ~contested
    backfacing = in_bake & ~edge & (np.sum(shading * geometric, axis=-1) < dot)
    compared = in_bake & ~edge & ~backfacing
    marked = contested & compared
    b_cmp = baked[compared]
    return {"error": angle(b_cmp, ref[compared]), "contested": angle(baked[marked],
                                                                     ref[marked]),
            "tilt_bake": angle(b_cmp, base[compared]).sum(),
            "tilt_ref": angle(ref[compared], base[compared]).sum(),
            "compared": compared.sum(), "marked": marked.sum(),
            "backfacing": backfacing, "edge": edge & in_bake}


@pytest.mark.parametrize("enabled", [False, True] if compiled.AVAILABLE else [False])
def test_the_statistics_are_the_ones_compare_computed_before(monkeypatch, enabled):
    args = random_block(5)
    old = _old_statistics(*args, 1e-4)
    a, reasons = run(monkeypatch, enabled, args)
    err = a.error()
    assert np.array_equal(err, old["error"], equal_nan=True)
    assert np.array_equal(err[a.marked[:a.n]], old["contested"])
    tb, tr = a.tilts()
    assert tb.sum() == old["tilt_bake"] and tr.sum() == old["tilt_ref"]
    assert a.counts[0] == old["compared"] and a.counts[1] == old["marked"]
    assert np.array_equal(a.backfacing, old["backfacing"])
    px, py = args[0][:, 0], args[0][:, 1]
    assert np.all(reasons[py[old["edge"]], px[old["edge"]]] == A.EDGE)
    assert np.all(reasons[py[old["backfacing"]], px[old["backfacing"]]] == A.BACKFACING)
    # Zero, NaN and infinite bakes score 180 degrees, never 0.
    assert np.sum(err == 180.0) >= 5


@pytest.mark.parametrize("enabled", [False, True] if compiled.AVAILABLE else [False])
def test_a_hand_made_block(monkeypatch, enabled):
    """Five texels of a 1 x 5 image, one of each class, with angles known in closed form."""
    pixel = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0]], dtype=np.int64)
    z = np.array([0.0, 0.0, 1.0])
    t = np.radians(30.0)
    tilted = np.array([np.sin(t), 0.0, np.cos(t)])
    pixels = np.zeros((1, 5, 3), dtype=np.float32)
    pixels[0, :] = tilted
    covered = np.array([[False, True, True, True, True]])
    contested = np.array([[False, False, False, False, True]])
    on_edge = np.array([[False, True, False, False, True]])   # texel 4: contested, so compared
    ref = np.tile(z, (5, 1))
    geometric = np.tile(z, (5, 1))
    shading = np.tile(z, (5, 1))
    shading[2] = [0.0, 1.0, -0.01]                                # faces away: backfacing
    a, reasons = run(monkeypatch, enabled, (pixel, pixels, covered, contested, on_edge, ref,
                                            shading, geometric, shading))
    assert a.n == 2 and list(a.flat[:2]) == [3, 4] and list(a.marked[:2]) == [False, True]
    assert list(reasons[0]) == [3, A.EDGE, A.BACKFACING, 3, A.CONTESTED]
    assert list(a.backfacing) == [False, False, True, False, False]
    np.testing.assert_allclose(a.error(), [30.0, 30.0], atol=1e-5)       # float32 bake
    tb, tr = a.tilts()
    np.testing.assert_allclose(tb, [30.0, 30.0], atol=1e-5)
    assert list(tr) == [0.0, 0.0]
    counts = dict(zip(A.COUNTS, a.counts.tolist()))
    assert counts == {"compared": 2, "contested": 1, "finite_unit": 2, "both": 4,
                      "finite_unit_all": 4, "away": 0, "truth_away": 0, "away_wrong": 0}


def test_angle_deg_against_arccos_and_its_rules():
    rng = np.random.default_rng(9)
    a, b = _unit(rng.normal(size=(200, 3))), _unit(rng.normal(size=(200, 3)))
    want = np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1, 1)))
    np.testing.assert_allclose(A.angle_deg(a, b), want, atol=1e-6)
    assert A.angle_deg([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]) == 180.0
    assert A.angle_deg([np.nan, 0.0, 1.0], [0.0, 0.0, 1.0]) == 180.0
    assert A.angle_deg([0.0, 0.0, 2.0], [0.0, 0.0, 1.0]) == 0.0


# The heat map (harness/heat_map.py) ------------------------------------------------------------

def random_heat(seed, h=37, w=53):
    """An error image with every kind of texel: errors from 0 to past the top, NaN (not
    compared), infinities, and every reason code, known or not."""
    from surfgrad_addon.harness.texel_report import ErrorImage
    rng = np.random.default_rng(seed)
    heat = rng.random((h, w)) * 3.0
    heat[rng.random((h, w)) < 0.2] = np.nan
    heat[0, :3] = [np.inf, -np.inf, 0.0]
    codes = rng.choice(np.array([0, 0, 0, 1, 2, 3, 4, 7, -1], dtype=np.int8), size=(h, w))
    return ErrorImage(heat, codes)


@pytest.mark.skipif(not compiled.AVAILABLE, reason="numba is not installed")
@pytest.mark.parametrize("seed", [0, 1])
def test_the_compiled_heat_map_is_its_numpy_definition_byte_for_byte(monkeypatch, seed):
    from surfgrad_addon.harness import heat_map as H
    heat = random_heat(seed)
    monkeypatch.setenv(compiled.ENV, "1")
    fast, fast_down = H.heat_map_indices(heat), H.heat_map_indices(heat, top_down=True)
    monkeypatch.setenv(compiled.ENV, "0")
    plain = H.heat_map_indices(heat)
    assert np.array_equal(fast, plain) and np.array_equal(fast_down, plain[::-1])
    assert np.array_equal(H.heat_map_indices(heat, top_down=True), plain[::-1])
    # Without reasons (a plain array) and with no finite error at all.
    bare = np.array(heat)
    assert np.array_equal(H.heat_map_indices_numpy(bare),
                          _with_env(monkeypatch, H.heat_map_indices, bare))
    empty = np.full((3, 4), np.nan)
    assert np.array_equal(H.heat_map_indices_numpy(empty),
                          _with_env(monkeypatch, H.heat_map_indices, empty))


def _with_env(monkeypatch, fn, *args):
    monkeypatch.setenv(compiled.ENV, "1")
    return fn(*args)


@pytest.mark.parametrize("enabled", [False, True] if compiled.AVAILABLE else [False])
def test_heat_map_colours_by_hand(monkeypatch, enabled):
    """Black at 0, white-ish (255, 204, 255) at the top, the reasons' colours, dark blue where
    nothing was compared; the top is at least 0.5 degrees. An error's level is sqrt(v) in
    1/250 steps, rounded half up (v = error / top); its colour the ramp at the level's v."""
    from surfgrad_addon.harness import heat_map as H
    from surfgrad_addon.harness.texel_report import ErrorImage
    monkeypatch.setenv(compiled.ENV, "1" if enabled else "0")
    heat = ErrorImage([[0.0, 0.25, 2.0, np.nan, 1.0, np.nan]], [[0, 0, 0, 3, 1, 0]])
    # v = e / 2. v = 0.125: sqrt 0.35355 -> level 88 (88.39 + 0.5 floored), its v 0.352^2.
    # Reasons: slot 251 + code (outside 3, contested 1); no error: 251.
    assert H.heat_map_indices(heat)[0].tolist() == [0, 88, 250, 254, 252, 251]
    rgb = H.heat_map_rgb(heat)
    assert rgb[0, 0].tolist() == [0, 0, 0]
    # (255 v, 204 sqrt(v), 255 v^2) rounded half up at v = 0.123904: 31.6, 71.8, 3.9.
    assert rgb[0, 1].tolist() == [32, 72, 4]
    assert rgb[0, 2].tolist() == [255, 204, 255]
    assert rgb[0, 3].tolist() == [0, 204, 204]         # outside: cyan
    assert rgb[0, 4].tolist() == [230, 26, 204]        # contested: magenta, whatever its error
    assert rgb[0, 5].tolist() == [13, 13, 51]          # not compared: dark blue
    small = H.heat_map_rgb(ErrorImage([[0.25]], [[0]]))
    # v = 0.25 / 0.5: sqrt 0.7071 -> level 177, v 0.501264: 127.8, 144.4, 64.1.
    assert small[0, 0].tolist() == [128, 144, 64]


def test_heat_map_png_is_indexed_and_reads_back_its_levels(tmp_path):
    """The written PNG holds the indices (no other copy of the picture) and the palette's
    colours."""
    from PIL import Image
    from surfgrad_addon.harness import heat_map as H
    heat = random_heat(3)
    path = H.write_heat_map(tmp_path / "h.png", heat, overwrite=False)
    image = Image.open(path)
    assert image.mode == "P"
    assert np.array_equal(np.asarray(image), H.heat_map_indices(heat, top_down=True))
    assert np.array_equal(np.asarray(image.convert("RGB")), H.heat_map_rgb(heat, top_down=True))


# The statistics on the block threads (harness/texel_report.py) --------------------------------

def _quad_texels(size):
    from surfgrad_addon.reference import raster
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    tris = np.array([[0, 1, 2], [0, 2, 3]])
    mesh = raster.MeshArrays(positions=np.c_[corners, np.zeros(4)], triangles=tris,
                             corner_normals=np.tile([0.0, 0.0, 1.0], (2, 3, 1)),
                             uv_maps={"UV": corners[tris]})
    return raster.rasterize(mesh, "UV", size, size)


def _field(x, y):
    v = np.stack([np.sin(x * 0.01), np.cos(y * 0.013), np.full(np.shape(x), 2.0)], -1)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_statistics_on_block_threads_are_those_of_one_thread_and_of_the_whole_image(
        monkeypatch):
    """A 640^2 quad (25 blocks: two threads share them) whose bake is a known field a little
    off the reference's: every figure is the same on one thread and on two, and the errors
    are the angles between the two fields, texel by texel."""
    from surfgrad_addon.harness import texel_report as TR
    size = 640
    td = _quad_texels(size)
    y, x = np.mgrid[0:size, 0:size]
    pixels = np.zeros((size, size, 4), dtype=np.float32)
    pixels[..., :3] = _field(x + 0.3 * np.sin(y * 0.05), y)
    covered = td.covered.copy()
    covered[:5, :7] = False                             # baked by one side only: outside
    reference = lambda block: _field(block.pixel[:, 0], block.pixel[:, 1])
    got = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("SURFGRAD_REFERENCE_THREADS", threads)
        r, heat, seconds = TR.compare_tile(td, reference, pixels, covered)
        got[threads] = (TR.merge([r]), heat, seconds)
    (one, heat_one, s1), (two, heat_two, s2) = got["1"], got["2"]
    assert one == two and s1 > 0 and s2 > 0
    assert np.array_equal(heat_one, heat_two, equal_nan=True)
    assert np.array_equal(heat_one.reasons, heat_two.reasons)
    compared = covered & td.covered & ~(td.on_edge & ~td.contested)
    want = A.angle_deg(pixels[..., :3][compared], _field(x, y)[compared])
    assert one["texels_compared"] == compared.sum() > 0.95 * size * size
    assert one["excluded"]["outside"] == 35 and one["excluded"]["backfacing"] == 0
    np.testing.assert_allclose(heat_one[compared], want, rtol=1e-12, atol=1e-12)
    assert np.isnan(heat_one[~compared]).all()
    assert one["max_deg"] == pytest.approx(want.max(), rel=1e-12)
    assert one["mean_deg"] == pytest.approx(want.mean(), rel=1e-9)
    assert one["p99_deg"] == pytest.approx(np.percentile(want, 99), rel=1e-12)
    # The tilts: both fields against the shading normal (the quad's, as the renderer packs it).
    normal = np.zeros((size, size, 3))
    normal[td.pixel[:, 1], td.pixel[:, 0]] = td.shading_normal
    for key, vectors in (("tilt_mean_deg", _field(x, y)), ("bake_tilt_mean_deg", pixels)):
        tilt = A.angle_deg(vectors[..., :3][compared], normal[compared])
        assert one[key] == pytest.approx(tilt.mean(), rel=1e-9), key
