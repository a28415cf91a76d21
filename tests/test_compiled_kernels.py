"""The compiled kernels (reference/compiled.py, raster_kernels.py) against the numpy code they
replace: the same rasterisation (winner, claimant, contested and edge flags, texels,
barycentrics) and the same interpolated attributes, bit for bit, on meshes that exercise every
rule: overlaps both ways round, mirrored islands, slivers thinner than a texel, UVs past the
image, UDIM offsets, odd sizes and every Blender line's sample offset. No bpy needed."""

import numpy as np
import pytest

import surfgrad_addon.reference as R
from surfgrad_addon.reference import compiled, raster
from surfgrad_addon.reference.blender_lines import LINES

pytestmark = [pytest.mark.tier("numpy"),
              pytest.mark.skipif(not compiled.AVAILABLE,
                                 reason="numba is not installed: the reference runs numpy only")]

FIELDS = ("triangle", "other_triangle", "contested", "on_edge", "pixel", "barycentric", "tri")


def both(monkeypatch, fn):
    """fn() with kernels off, then on."""
    monkeypatch.setenv(compiled.ENV, "0")
    assert not compiled.enabled()
    plain = fn()
    monkeypatch.setenv(compiled.ENV, "1")
    assert compiled.enabled()
    return plain, fn()


def soup_mesh(n, rng, spread=1.2, name="soup"):
    """n random triangles with overlapping, mirrored and out-of-range UVs."""
    uv = rng.uniform(-0.1, spread, size=(n, 3, 2))
    pos = rng.normal(size=(3 * n, 3))
    nrm = rng.normal(size=(n, 3, 3))
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    return R.MeshArrays(positions=pos, triangles=np.arange(3 * n).reshape(n, 3),
                        corner_normals=nrm, uv_maps={"UVMap": uv}, name=name,
                        point_attributes={"rest": rng.normal(size=(3 * n, 3))})


def sliver_mesh():
    """Triangles far thinner than a texel, degenerate (zero-area) ones and one huge one."""
    uv = np.array([[[0.1, 0.1], [0.9, 0.1000001], [0.5, 0.1000002]],     # sliver
                   [[0.2, 0.2], [0.2, 0.2], [0.3, 0.4]],                   # zero area
                   [[0.0, 0.5], [1e-9, 0.9], [0.0, 0.95]],                 # hair-thin upright
                   [[-5.0, -5.0], [20.0, -5.0], [-5.0, 20.0]]])              # covers everything
    n = len(uv)
    return R.MeshArrays(positions=np.random.default_rng(3).normal(size=(3 * n, 3)),
                        triangles=np.arange(3 * n).reshape(n, 3),
                        corner_normals=np.tile([0.0, 0.0, 1.0], (n, 3, 1)),
                        uv_maps={"UVMap": uv}, name="slivers")


def assert_same_raster(a, b):
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert np.array_equal(x, y), f"{name}: {np.sum(x != y)} values differ"


@pytest.mark.parametrize("size", [16, 67, 256])
@pytest.mark.parametrize("seed", [0, 1])
def test_rasterize_matches_numpy_on_a_soup(monkeypatch, size, seed):
    mesh = soup_mesh(80, np.random.default_rng(seed))
    plain, fast = both(monkeypatch, lambda: R.rasterize(mesh, "UVMap", size, size + 3))
    assert_same_raster(plain, fast)
    # The soup really exercises the rules: contested texels, claimants, and texels left
    # uncovered.
    assert plain.contested.sum() > 20 and (plain.other_triangle >= 0).sum() > 20
    assert (plain.triangle < 0).sum() > 0


@pytest.mark.parametrize("threads", [2, 3])
def test_rasterize_in_bands_matches_numpy(monkeypatch, threads):
    """The compiled rasteriser's bands of rows (scanned by threads at once) give what the numpy
    code gives: triangles spanning many bands, overlaps across band edges, odd band sizes."""
    monkeypatch.setattr(raster, "PARALLEL_RASTER_TEXELS", 1)
    monkeypatch.setenv("SURFGRAD_REFERENCE_THREADS", str(threads))
    bands = raster._row_bands(103, 97 * 103)
    assert len(bands) == raster.BANDS_PER_THREAD * threads
    assert bands[0][0] == 0 and bands[-1][1] == 103
    assert all(a[1] == b[0] for a, b in zip(bands, bands[1:]))
    mesh = soup_mesh(120, np.random.default_rng(7))
    plain, fast = both(monkeypatch, lambda: R.rasterize(mesh, "UVMap", 97, 103))
    assert_same_raster(plain, fast)
    assert plain.contested.sum() > 20 and (plain.other_triangle >= 0).sum() > 20


@pytest.mark.parametrize("line", sorted(LINES))
def test_rasterize_matches_numpy_on_every_line_and_tile(monkeypatch, line):
    mesh = R.meshes.uv_sphere(segments=24, rings=12)
    mesh.uv_maps["UVMap"] = mesh.uv_maps["UVMap"] + [1.0, 0.0]         # on UDIM tile 1002
    facts = LINES[line]
    plain, fast = both(monkeypatch, lambda: R.rasterize(
        mesh, "UVMap", 128, 96, facts=facts, uv_offset=(1.0, 0.0)))
    assert_same_raster(plain, fast)
    assert len(plain.pixel) > 0.5 * 128 * 96


def test_rasterize_matches_numpy_where_edges_cross_texel_centres(monkeypatch):
    """A grid whose quad diagonals pass exactly through texel centres: every such texel is
    claimed by two triangles within rounding (on_edge)."""
    mesh = R.meshes.plane(subdivisions=4)
    plain, fast = both(monkeypatch, lambda: R.rasterize(mesh, "UVMap", 64, 64,
                                                        sample_offset=(0.5, 0.5)))
    assert_same_raster(plain, fast)
    assert plain.on_edge.sum() >= 64 and plain.covered.all()


def test_rasterize_matches_numpy_on_slivers_and_degenerate_triangles(monkeypatch):
    plain, fast = both(monkeypatch, lambda: R.rasterize(sliver_mesh(), "UVMap", 200, 200))
    assert_same_raster(plain, fast)
    # The big triangle (index 3, last) wins every texel it covers, the whole image.
    assert (plain.triangle == 3).all()


def test_interpolated_attributes_match_numpy(monkeypatch):
    rng = np.random.default_rng(5)
    mesh = R.meshes.torus(segments=24, rings=12)
    mesh.point_attributes["rest"] = rng.normal(size=(len(mesh.positions), 3))

    def attributes():
        td = R.rasterize(mesh, "UVMap", 96, 96)
        out = {}
        for start, stop, block in td.blocks(1000):      # block seams at odd places
            t, sign = block.tangent()
            steps = block.texel_steps("Detail")
            dp_ds, dp_dt, _ = block.derivatives()
            for name, value in (("position", block.position), ("normal", block.normal),
                                ("geometric", block.geometric_normal), ("dp_ds", dp_ds),
                                ("dp_dt", dp_dt), *((f"step{i}", v) for i, v in
                                                    enumerate(steps)),
                                ("shading", block.shading_normal), ("uv", block.uv()),
                                ("rest", block.point_attribute("rest")), ("tangent", t),
                                ("sign", sign), ("object", block.position_object)):
                out.setdefault(name, []).append(value)
        return {k: np.concatenate(v) for k, v in out.items()}

    plain, fast = both(monkeypatch, attributes)
    for name in plain:
        assert plain[name].shape == fast[name].shape, name
        assert np.array_equal(plain[name], fast[name]), name
    # And they are the right values: positions lie on the torus's facets, within their
    # chord error (24 x 12 facets of a tube of radius 0.35) of the tube.
    r = np.hypot(plain["position"][:, 0], plain["position"][:, 1])
    tube = np.hypot(r - 1.0, plain["position"][:, 2])
    assert 0.32 < tube.min() and tube.max() < 0.36


def test_kernels_load_once_and_report_their_time(monkeypatch):
    monkeypatch.setattr(raster, "_LOADED", [])
    seconds = raster.load_compiled()
    assert seconds > 0 and raster._LOADED
    assert raster.load_compiled() == 0.0
    monkeypatch.setenv(compiled.ENV, "0")
    monkeypatch.setattr(raster, "_LOADED", [])
    assert raster.load_compiled() == 0.0          # kernels off: nothing to load


def test_compiled_raster_makes_texels_per_block_only(monkeypatch):
    """Memory follows the block: evaluating every block of a compiled raster never makes the
    whole image's texel arrays; asking for them afterwards gives the blocks' values."""
    from surfgrad_addon.reference import methods as M
    monkeypatch.setenv(compiled.ENV, "1")
    td = R.rasterize(R.meshes.uv_sphere(segments=16, rings=8), "UVMap", 100, 100)
    assert "pixel" not in td.__dict__ and td.texel_count > 5000
    pos = M.evaluate_in_blocks(lambda b: b.position, td, texels=777)
    xy = M.evaluate_in_blocks(lambda b: b.pixel.astype(float), td, texels=1234)
    assert "pixel" not in td.__dict__ and "barycentric" not in td.__dict__
    assert np.array_equal(xy, td.pixel) and np.array_equal(pos, td.position)
    assert td.texel_count == len(td.pixel) == int(td.covered.sum())


@pytest.mark.parametrize("line", ["5.0", "5.2"])
@pytest.mark.parametrize("applied", [True, False])
def test_normal_map_frame_and_colours_match_numpy(monkeypatch, line, applied):
    """Blender's Normal Map node frame (unit or unnormalised normal, by line), under a sheared
    non-uniform transform applied to the mesh or not; the node's colour-to-derivative at
    several strengths and both green conventions; Listing 2 on a colour."""
    from surfgrad_addon.reference import methods as M
    shear = np.array([[1.5, 0.3, 0.0, 2.0], [0.0, 0.7, 0.2, -1.0], [0.1, 0.0, 2.5, 0.5],
                      [0.0, 0.0, 0.0, 1.0]])
    mesh = R.meshes.torus(segments=20, rings=10, matrix_world=shear)
    mesh.transform_applied = applied

    def values():
        td = R.rasterize(mesh, "UVMap", 80, 80, facts=LINES[line])
        out = []
        for _, _, block in td.blocks(999):
            colour = R.sample_image(np.random.default_rng(2).uniform(size=(32, 32, 4)),
                                    block.uv())
            out.append([*M.mikktspace_frame(block), block.shading_normal,
                        M.colour_to_derivative(colour), M.colour_to_derivative(colour, True),
                        *(M.normal_map_node_derivative(colour, s, dx)
                          for s in (0.0, 0.3, 1.0, 2.0) for dx in (False, True))])
        return [np.concatenate(parts) for parts in zip(*out)]

    plain, fast = both(monkeypatch, values)
    assert len(plain) == 14
    for k, (a, b) in enumerate(zip(plain, fast)):
        assert a.shape == b.shape and np.array_equal(a, b), k
    # The frame is Listing 9's: n unit, t and b scaled by the same 1/|n|.
    assert np.allclose(np.linalg.norm(plain[0], axis=1), 1.0)
    # Strength 0 is flat, and the DirectX flip negates the second component only.
    assert np.array_equal(plain[6], np.zeros_like(plain[6]))
    assert np.array_equal(plain[10][:, 1], -plain[11][:, 1])


@pytest.mark.parametrize("steps", [1, 4, 16])
@pytest.mark.parametrize("shape", [(64, 64), (48, 80)])
def test_parallax_march_matches_numpy(monkeypatch, steps, shape):
    """The compiled march against parallax_occlusion_march on Linear lookups: rays that hit
    at the first sample, cross between steps, never hit, and wrap around the image."""
    from surfgrad_addon.reference import parallax_kernels
    rng = np.random.default_rng(steps)
    image = rng.uniform(size=shape)
    st = rng.uniform(-1.5, 2.5, size=(3000, 2))
    v = rng.normal(scale=0.2, size=(3000, 2))
    v[:100] = 0.0                                   # straight down: hits at once where h = 1
    monkeypatch.setenv(compiled.ENV, "0")
    plain = R.parallax_occlusion_march(lambda q: R.sample_image(image, q), st, v, steps)
    monkeypatch.setenv(compiled.ENV, "1")
    fast = parallax_kernels.march(image, st, v, steps)
    assert np.array_equal(plain, fast)
    hit = np.linalg.norm(plain, axis=1) / np.maximum(np.linalg.norm(v, axis=1), 1e-300)
    assert 0.0 <= hit.min() and hit.max() <= 1.0 + 1e-12
    assert (hit[100:] > 0).sum() > 100 and (hit[100:] < 1).sum() > 100


def test_listing1_resolve_matches_numpy(monkeypatch):
    """Listing 1's twin: ordinary gradients, ones that cancel n exactly (no direction: n is
    kept), NaN and infinite gradients (n kept), and huge ones."""
    from surfgrad_addon.reference import methods as M
    rng = np.random.default_rng(4)
    n = rng.normal(size=(4000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    sg = rng.normal(scale=0.7, size=(4000, 3))
    sg[:50] = n[:50]
    sg[50:60] = np.nan
    sg[60:70] = np.inf
    sg[70:80] *= 1e300
    n, sg = np.asfortranarray(n), np.asfortranarray(sg)
    with np.errstate(over="ignore", invalid="ignore"):     # the numpy path's |1e300|^2
        plain, fast = both(monkeypatch, lambda: M.resolve((n, sg)))
    assert np.array_equal(plain, fast)
    assert np.array_equal(fast[:70], np.concatenate([n[:50], n[50:70]]))
    assert np.allclose(np.linalg.norm(fast, axis=1), 1.0)


@pytest.mark.tier("child")
def test_the_reference_runs_without_numba_and_gives_the_same_normals():
    """In an interpreter that refuses numba (and bpy), the reference imports, runs its numpy
    code only, and gives a method's normals equal to the compiled kernels' in this one."""
    from support.child import NO_BPY, run_python
    from surfgrad_addon.reference import methods as M
    code = (NO_BPY.replace("('bpy', 'mathutils', 'bmesh')", "('bpy', 'mathutils', 'bmesh', 'numba')")
            + "import numpy as np, surfgrad_addon.reference as R\n"
            "from surfgrad_addon.reference import methods as M\n"
            "assert not R.compiled.AVAILABLE and 'numba' not in sys.modules\n"
            "td = R.rasterize(R.meshes.torus(segments=16, rings=8), 'UVMap', 40, 40)\n"
            "img = np.random.default_rng(1).uniform(size=(16, 16, 4))\n"
            "out = M.evaluate_in_blocks(lambda b: M.resolve(M.normal_map_surfgrad(b, img)), td, 300)\n"
            "np.save(sys.argv[1], out)\n")
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        path = f"{tmp}/numpy_only.npy"
        result = run_python(["-c", code, path], timeout=120)
        assert result.returncode == 0, result.stderr
        plain = np.load(path)
    td = R.rasterize(R.meshes.torus(segments=16, rings=8), "UVMap", 40, 40)
    img = np.random.default_rng(1).uniform(size=(16, 16, 4))
    fast = M.evaluate_in_blocks(lambda b: M.resolve(M.normal_map_surfgrad(b, img)), td, 300)
    assert compiled.enabled() and len(plain) > 500
    assert np.array_equal(plain, fast)


def test_normal_map_reach_matches_the_listings():
    """normal_map_kernels.reach_normal against Listings 3 and 5 in numpy, with texels whose
    target faces away from the base normal (n - v there) and degenerate ones."""
    from surfgrad_addon.reference import listings as L, normal_map_kernels, vecmath as V
    rng = np.random.default_rng(11)
    count = 5000
    unit = lambda v: v / np.linalg.norm(v, axis=1, keepdims=True)     # noqa: E731
    n_f, n = unit(rng.normal(size=(count, 3))), unit(rng.normal(size=(count, 3)))
    t, b = rng.normal(size=(count, 3)) * 0.7, rng.normal(size=(count, 3)) * 0.7
    deriv = rng.normal(size=(count, 2)) * 2.0
    n[:300] = n_f[:300]                              # the usual case: same normal
    deriv[:50] = 0.0
    n_f, n, t, b, deriv = (np.asfortranarray(a) for a in (n_f, n, t, b, deriv))
    v = V.normalize(n_f - L.surfgrad_from_tbn(deriv, t, b))
    want = np.where(V.dot(n, v) < V.FLT_EPSILON, n - v, L.surfgrad_from_perturbed_normal(n, v))
    out = np.empty((3, count))
    normal_map_kernels.reach_normal(*(np.ascontiguousarray(a.T) for a in (n_f, t, b, deriv, n)),
                                    out)
    assert np.array_equal(out.T, want)
    away = (V.dot(n, v) < V.FLT_EPSILON)[:, 0]
    assert 1000 < away.sum() < 4500                  # both branches taken
    # Resolved against n, it lands on v (Listing 5's point), where v is not away.
    resolved = L.resolve_normal_from_surface_gradient(n, out.T)
    assert np.allclose(resolved[~away], v[~away], atol=1e-9)


@pytest.mark.parametrize("shape", [(64, 64), (48, 80)])
@pytest.mark.parametrize("lod", [0.0, 1.0])
@pytest.mark.parametrize("extension", ["REPEAT", "EXTEND"])
def test_three_tap_height_derivative_matches_numpy(monkeypatch, shape, lod, extension):
    """Listing 16's plain branch (three taps) compiled against its numpy code, points inside,
    on and far outside the image; and it is the derivative of a plane image exactly."""
    rng = np.random.default_rng(3)
    image = rng.uniform(size=shape)
    st = np.asfortranarray(rng.uniform(-1.5, 2.5, size=(4000, 2)))
    plain, fast = both(monkeypatch, lambda: R.deriv_from_height_map(
        image, st, lod=lod, extension=extension))
    assert plain.shape == fast.shape == (4000, 2) and np.array_equal(plain, fast)
    ramp = np.add.outer(np.arange(shape[0]) * 0.25, np.arange(shape[1]) * 0.5)
    inside = np.asfortranarray(rng.uniform(0.3, 0.6, size=(500, 2)))
    slope = R.deriv_from_height_map(ramp, inside, lod=lod, extension=extension)
    assert np.allclose(slope, [0.5, 0.25])          # per texel of level 0, u then v
