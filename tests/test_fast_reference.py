"""The optimised reference against its own earlier values: every method's resolved normal on
three rasters, and the noise, image sampling and height derivatives at fixed points, agree with
the float64 values the unoptimised code (commit a08fc13) computed, to 1e-12
(tests/data/reference_a08fc13.npz, written by tools/reference_fixture.py from that commit).
Blocked evaluation (any block size, seams anywhere) gives the same numbers as one block."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import surfgrad_addon.reference as R
from surfgrad_addon.reference import methods as M

pytestmark = pytest.mark.tier("numpy")


ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("reference_fixture",
                                               ROOT / "tools" / "reference_fixture.py")
FX = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(FX)
SAVED = np.load(ROOT / "tests" / "data" / "reference_a08fc13.npz")
TOL = 1e-12


def saved_texels(key):
    """The raster recorded with the values, so they do not depend on rasterize's tie rule."""
    mesh, size, facts = FX.rasters()[key]
    return R.TexelData(mesh=mesh, uv_map="UVMap", width=size, height=size,
                       triangle=SAVED[f"{key}/triangle"], pixel=SAVED[f"{key}/pixel"],
                       barycentric=SAVED[f"{key}/barycentric"], facts=facts)


def test_every_method_and_raster_was_recorded():
    assert len(FX.cases()) >= 18
    for key in FX.rasters():
        for case in FX.cases():
            if case not in FX.NEW_CASES:
                assert "{}/{}/{}".format(key, *FX.recorded(case)) in SAVED.files


@pytest.mark.parametrize("key", list(FX.rasters()))
@pytest.mark.parametrize("case", FX.cases(), ids=lambda c: "-".join(c))
def test_methods_match_the_unoptimised_values(key, case):
    method, variant = case
    td = saved_texels(key)
    fn = FX.H.METHODS[method].reference
    # A small odd block size puts block seams inside triangles and rows.
    got = M.evaluate_in_blocks(lambda b: M.resolve(fn(FX.inputs(variant), b)), td, texels=97)
    if case in FX.NEW_CASES:
        # No before-values (newer than the recorded commit): blocks agree with one block, and
        # on the sphere (the fixture's small projector misses the torus's tube) the round
        # decals really bend normals.
        whole = M.resolve(fn(FX.inputs(variant), saved_texels(key)))
        np.testing.assert_allclose(got, whole, rtol=0, atol=TOL)
        assert np.isfinite(got).all()
        if method == "decal" and key == "sphere":
            bent = np.abs(got - M.unit_base_normal(td)).max(axis=-1) > 1e-3
            assert bent.mean() > 0.01, bent.mean()
        return
    want = SAVED["{}/{}/{}".format(key, *FX.recorded(case))]
    assert got.dtype == np.float64 and got.shape == want.shape
    assert np.isfinite(want).all()
    np.testing.assert_allclose(got, want, rtol=0, atol=TOL)
    whole = M.resolve(fn(FX.inputs(variant), saved_texels(key)))
    np.testing.assert_allclose(whole, want, rtol=0, atol=TOL)


def test_noise_sampling_and_height_derivatives_match_the_unoptimised_values():
    pts = FX.points(np.random.default_rng(13))
    p, st = pts["p"], pts["st"]
    for name, fn in (("gradient_noise", R.gradient_noise), ("fractal_sum", R.fractal_sum),
                     ("turbulence", R.turbulence)):
        v, g = fn(p)
        np.testing.assert_allclose(v, SAVED[f"points/{name}/value"], rtol=0, atol=TOL)
        np.testing.assert_allclose(g, SAVED[f"points/{name}/gradient"], rtol=0, atol=TOL)
    image = FX.inputs().pixels("normal")
    for interp in ("Linear", "Closest"):
        for ext in ("REPEAT", "EXTEND"):
            np.testing.assert_allclose(R.sample_image(image, st, interp, ext),
                                       SAVED[f"points/sample/{interp}/{ext}"], rtol=0, atol=TOL)
    height = FX.inputs().pixels("height")
    for hq in (False, True):
        np.testing.assert_allclose(R.deriv_from_height_map(height, st, hq=hq),
                                   SAVED[f"points/height_deriv/{hq}"], rtol=0, atol=TOL)


def test_the_saved_values_are_not_trivial():
    # The check above could pass on constant data: the recorded normals vary and are unit.
    want = SAVED["sphere/normal-map/hq"]
    assert want.std(axis=0).min() > 0.1
    np.testing.assert_allclose(np.linalg.norm(want, axis=-1), 1.0, atol=1e-12)


def test_blocks_cover_every_texel_once_and_share_per_triangle_arrays():
    td = R.rasterize(R.meshes.uv_sphere(), "UVMap", 37, 29)
    seen = np.concatenate([np.arange(a, b) for a, b, _ in td.blocks(100)])
    np.testing.assert_array_equal(seen, np.arange(len(td.pixel)))
    blocks = [b for _, _, b in td.blocks(100)]
    assert all(b._shared is td._shared for b in blocks)
    np.testing.assert_array_equal(np.concatenate([b.tri for b in blocks]), td.tri)
    pos = M.evaluate_in_blocks(lambda b: b.position, td, texels=100)
    np.testing.assert_array_equal(pos, td.position)


def _brute_force_raster(mesh, w, h):
    """Every triangle tested at every texel, in triangle order (Blender's last-wins rule):
    the winner, the claimant before it, barycentrics, and how many triangles strictly hold it."""
    from surfgrad_addon.reference import raster
    uv = mesh.uv("UVMap")
    q = uv * np.array([w, h], dtype=np.float64) - np.asarray(R.BAKE_TEXEL_OFFSET)
    a, b, c = q[:, 0], q[:, 1], q[:, 2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    coef = raster._barycentric_coefficients(a, b, c, area)
    edge_len = np.stack([np.hypot(*(b - c).T), np.hypot(*(c - a).T), np.hypot(*(a - b).T)], 1)
    tol = raster._EDGE_TEXELS * max(w, h) / 256 / (np.abs(area) / edge_len.max(axis=1))
    y, x = np.mgrid[0:h, 0:w]
    win = np.full((h, w), -1)
    other = np.full((h, w), -1)
    strict = np.zeros((h, w), dtype=int)
    bary = np.zeros((h, w, 3))
    lo, hi = np.ceil(q.min(1) - 1e-9), np.floor(q.max(1) + 1e-9)
    for t in range(len(area)):
        if area[t] == 0:
            continue
        box = (x >= lo[t, 0]) & (x <= hi[t, 0]) & (y >= lo[t, 1]) & (y <= hi[t, 1])
        bt = np.stack([(coef[t, k, 0] * x + coef[t, k, 1] * y) + coef[t, k, 2]
                       for k in range(3)], -1)
        s = bt.min(-1)
        strict += box & (s >= -tol[t]) & (s > tol[t])
        inside = box & (s >= -1e-12)
        other[inside] = win[inside]
        win[inside] = t
        bary[inside] = bt[inside]
    return win, other, strict, bary


@pytest.mark.parametrize("mesh_name,w,h", [("sphere", 37, 23), ("overlap", 160, 100),
                                            ("torus", 50, 50)])
def test_span_rasteriser_matches_a_brute_force_scan(mesh_name, w, h):
    if mesh_name == "sphere":
        mesh = R.meshes.uv_sphere()
    elif mesh_name == "torus":
        mesh = R.meshes.torus(matrix_world=FX.transformed())
    else:   # islands squeezed onto each other and shifted: contested texels
        mesh = R.meshes.torus()
        mesh.uv_maps["UVMap"] = mesh.uv_maps["UVMap"] * [0.5, 1.0] + [0.25, 0.0]
        mesh.uv_maps["UVMap"][::3] += [0.2, 0.0]
    td = R.rasterize(mesh, "UVMap", w, h)
    win, other, strict, bary = _brute_force_raster(mesh, w, h)
    np.testing.assert_array_equal(td.triangle, win)
    np.testing.assert_array_equal(td.other_triangle, np.where(win >= 0, other, -1))
    np.testing.assert_array_equal(td.contested, strict >= 2)
    if mesh_name == "overlap":
        assert td.contested.sum() > 50
    ys, xs = np.nonzero(win >= 0)
    np.testing.assert_array_equal(td.pixel, np.stack([xs, ys], -1))
    want = np.clip(bary[ys, xs], 0, None)
    want /= want.sum(-1, keepdims=True)
    np.testing.assert_allclose(td.barycentric, want, rtol=0, atol=1e-15)


def test_threaded_blocks_give_the_same_values(monkeypatch):
    td = saved_texels("torus")
    fn = FX.H.METHODS["layered"].reference
    one = M.evaluate_in_blocks(lambda b: M.resolve(fn(FX.inputs(), b)), td, texels=50, threads=1)
    monkeypatch.setenv("SURFGRAD_REFERENCE_THREADS", "3")
    assert M.reference_threads() == 3
    three = M.evaluate_in_blocks(lambda b: M.resolve(fn(FX.inputs(), b)), td, texels=50,
                                 threads=3)
    np.testing.assert_array_equal(one, three)
    seconds = [0.0]
    seen = [v for *_, v in M.evaluated_blocks(lambda b: b.position, td, 50, 2, seconds)]
    np.testing.assert_array_equal(np.concatenate(seen), td.position)
    assert seconds[0] > 0


def test_a_small_image_runs_its_blocks_on_the_calling_thread(monkeypatch):
    """Threads by default only from two windows of blocks on (fewer only contend for the GIL);
    asked for, they run whatever the size."""
    import threading
    td = saved_texels("torus")
    monkeypatch.setenv("SURFGRAD_REFERENCE_THREADS", "2")

    def where(texels, threads=None):
        seen = set()
        M.evaluate_in_blocks(lambda b: seen.add(threading.get_ident()) or b.position, td,
                             texels=texels, threads=threads)
        return seen
    me = {threading.get_ident()}
    assert where(50) == me                                  # 12 blocks < 2 x 4 x 2
    assert where(50, threads=2) - me                        # asked for: worker threads
    assert where(20) - me                                   # 29 blocks: threads by default
