"""The compiled image lookups (reference/sampling_kernels.py) give image_sampling's numpy
numbers bit for bit, in the same dtype, shape and memory layout, and never index outside the
image, whatever the coordinates."""

import platform

import numpy as np
import pytest

from surfgrad_addon.reference import compiled, image_sampling as IS

pytestmark = pytest.mark.tier("numpy")

pytest.importorskip("numba", reason="numba is not installed: the reference runs numpy only")

from surfgrad_addon.reference import sampling_kernels as K  # noqa: E402

X86 = platform.machine().lower() in ("x86_64", "amd64", "i386", "i686")


@pytest.fixture
def paths(monkeypatch):
    """sample(image, st, interp, ext) -> (numpy path result, kernel result); fails unless the
    kernel really ran."""
    calls = []
    real = K.sample

    def spy(*args):
        calls.append(args[2])
        return real(*args)

    monkeypatch.setattr(K, "sample", spy)

    def both(image, st, interp, ext):
        monkeypatch.setenv(compiled.ENV, "0")
        want = IS.sample_image(image, st, interp, ext)
        assert not calls
        monkeypatch.setenv(compiled.ENV, "1")
        got = IS.sample_image(image, st, interp, ext)
        assert calls == [interp]
        calls.clear()
        return want, got
    return both


def assert_same(want, got):
    assert got.dtype == want.dtype
    assert got.shape == want.shape
    assert got.strides == want.strides      # vecmath's component layout where numpy gives it
    assert np.array_equal(got, want, equal_nan=True)


def coordinates(rng, width, height, n=600):
    """Random points with the hard cases: negatives, exact texel edges (integers / size,
    negative ones too), texel centres, and values far outside 0..1."""
    size = np.array([width, height])
    edges = rng.integers(-3 * max(size), 3 * max(size), (n // 4, 2)) / size
    centres = (rng.integers(-2 * max(size), 2 * max(size), (n // 4, 2)) + 0.5) / size
    far = rng.uniform(-1, 1, (n // 8, 2)) * 10.0 ** rng.integers(1, 5, (n // 8, 1))
    plain = rng.uniform(-2, 3, (n - 2 * (n // 4) - n // 8, 2))
    st = np.concatenate([edges, centres, far, plain])
    return st[rng.permutation(len(st))]


SHAPES = [(7, 5), (8, 16), (5, 9, 3), (16, 8, 4), (6, 10, 1), (1, 3, 2)]


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: "x".join(map(str, s)))
def test_kernels_match_the_numpy_path_bit_for_bit(paths, shape, dtype):
    rng = np.random.default_rng(sum(shape) * 7)
    image = rng.standard_normal(shape).astype(dtype)
    st = coordinates(rng, shape[1], shape[0]).astype(dtype)
    for interp in IS.INTERPOLATIONS:
        for ext in IS.EXTENSIONS:
            want, got = paths(image, st, interp, ext)
            assert_same(want, got)
            assert np.isfinite(got).all()


def test_a_single_point_stays_on_numpy(monkeypatch):
    # numpy 1.x promotes 0-d float32 arithmetic with Python floats to float64, so for st of
    # shape (2,) the numpy path is the only definition on every line.
    monkeypatch.setattr(K, "sample", None)      # would raise if called
    image = np.random.default_rng(2).random((9, 11, 3)).astype(np.float32)
    for interp in IS.INTERPOLATIONS:
        assert IS.sample_image(image, [0.3, 0.7], interp).shape == (3,)


@pytest.mark.parametrize("lead", [(0,), (1,), (3, 50), (2, 3, 17)], ids=str)
def test_any_leading_shape_and_non_contiguous_coordinates(paths, lead):
    rng = np.random.default_rng(len(lead))
    for image in (rng.random((9, 11)), rng.random((9, 11, 3)).astype(np.float32)):
        st = rng.uniform(-1.5, 2.5, lead + (2,))
        strided = np.stack([st[..., 1], st[..., 0]])[::-1].transpose(tuple(range(1, st.ndim)) + (0,))
        assert not strided.flags.c_contiguous or strided.size == 0
        for interp in IS.INTERPOLATIONS:
            assert_same(*paths(image, st, interp, "REPEAT"))
            assert_same(*paths(image, strided, interp, "EXTEND"))


def test_integer_images_and_list_coordinates(paths):
    image = np.arange(24, dtype=np.uint8).reshape(4, 6)
    st = [[0.3, 0.9], [-0.2, 1.7], [1.0, 0.0]]
    for interp in IS.INTERPOLATIONS:
        want, got = paths(image, st, interp, "REPEAT")
        assert got.dtype == np.float64
        assert_same(want, got)


@pytest.mark.parametrize("flag", ["0", "1"], ids=["numpy", "compiled"])
def test_closest_reads_the_expected_texels(monkeypatch, flag):
    monkeypatch.setenv(compiled.ENV, flag)
    # Independent of the numpy path: an image whose texels hold their own flat index.
    h, w = 6, 10
    image = np.arange(h * w, dtype=np.float64).reshape(h, w)
    st = np.array([[0.05, 0.05], [0.95, 0.99], [-0.05, 0.5], [1.05, -0.01], [-0.2, 0.25]])
    # i(u w), i(v h); REPEAT wraps, EXTEND clamps; -0.2 * 10 = -2 is a negative integer -> -3.
    rep = [0 * w + 0, 5 * w + 9, 3 * w + 9, 5 * w + 0, 1 * w + 7]
    ext = [0 * w + 0, 5 * w + 9, 3 * w + 0, 0 * w + 9, 1 * w + 0]
    assert IS.sample_image(image, st, "Closest", "REPEAT").tolist() == rep
    assert IS.sample_image(image, st, "Closest", "EXTEND").tolist() == ext


NASTY = [np.nan, np.inf, -np.inf, 1e30, -1e30, 2.0 ** 63, -(2.0 ** 63), 2.0 ** 62, -(2.0 ** 62) - 1e6]


@pytest.mark.parametrize("flag", ["0", "1"], ids=["numpy", "compiled"])
@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
def test_huge_coordinates_read_texels_inside_the_image(monkeypatch, dtype, flag):
    monkeypatch.setenv(compiled.ENV, flag)
    # Far from 0..1 (beyond 2**53 yet inside int64 once scaled by the size) the coordinates
    # minus 0.5 are whole numbers, the bilinear weights are (1, 0) and Linear returns texel (x0, y0) itself; with
    # texels holding their own flat index the result shows which texel was read.
    values = np.array([1e17, -1e17, 2.0 ** 58, -(2.0 ** 58), 5e17, -5e17, 3.3e16],
                      dtype=dtype)
    st = np.stack(np.meshgrid(values, values), axis=-1).reshape(-1, 2)
    for h, w in ((5, 7), (8, 8), (1, 3), (12, 16)):
        image = np.arange(h * w, dtype=dtype).reshape(h, w)
        for interp in IS.INTERPOLATIONS:
            for ext in IS.EXTENSIONS:
                got = IS.sample_image(image, st, interp, ext)
                assert np.isin(got, np.arange(h * w)).all(), (h, w, interp, ext)


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
def test_non_finite_coordinates_stay_in_bounds(paths, dtype):
    # numpy warns about its NaN casts and inf * 0; the values are what is tested here.
    with np.errstate(invalid="ignore", over="ignore"):
        check_non_finite(paths, dtype)


def check_non_finite(paths, dtype):
    rng = np.random.default_rng(5)
    for shape in ((5, 7), (8, 8, 3)):
        h, w = shape[:2]
        image = (np.arange(h * w, dtype=dtype)[:, None] * np.ones(shape[2:] or (1,), dtype)
                 ).reshape(shape)
        pairs = [(a, b) for a in NASTY for b in NASTY[:3] + [0.3]] + list(rng.random((50, 2)))
        st = np.array(pairs, dtype=dtype)
        for ext in IS.EXTENSIONS:
            want, got = paths(image, st, "Closest", ext)
            # Every Closest result is a texel's own index: the lookup stayed in the image.
            assert np.isin(got, np.arange(h * w)).all()
            want_l, got_l = paths(image, st, "Linear", ext)
            finite = np.isfinite(st).all(axis=-1) & (np.abs(st) < 1e18).all(axis=-1)
            assert np.array_equal(got_l[finite], want_l[finite])
            if X86:
                # numpy's cast of NaN/inf to int64 is the CPU's (INT64_MIN on x86); the kernel
                # spells that out, so here the two agree everywhere.
                assert_same(want, got)
                assert_same(want_l, got_l)
