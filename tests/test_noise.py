"""The noise's hash against a scalar re-derivation of Cycles' lookup3, and every analytic
gradient against central differences."""

import struct

import numpy as np
import pytest

import surfgrad_addon.reference as R

pytestmark = pytest.mark.tier("numpy")


M32 = 0xFFFFFFFF


def _rot(x, k):
    return ((x << k) | (x >> (32 - k))) & M32


def scalar_hash_uint3(kx, ky, kz):
    """Plain-int lookup3 hash_uint3, written from the algorithm's description (not shared
    with the vectorised implementation under test)."""
    a = b = c = (0xDEADBEEF + (3 << 2) + 13) & M32
    c = (c + kz) & M32
    b = (b + ky) & M32
    a = (a + kx) & M32
    for x, y, k in (("c", "b", 14), ("a", "c", 11), ("b", "a", 25), ("c", "b", 16),
                    ("a", "c", 4), ("b", "a", 14), ("c", "b", 24)):
        regs = {"a": a, "b": b, "c": c}
        regs[x] = ((regs[x] ^ regs[y]) - _rot(regs[y], k)) & M32
        a, b, c = regs["a"], regs["b"], regs["c"]
    return c


def fbits(x):
    return struct.unpack("<I", struct.pack("<f", x))[0]


def test_hash_uint3_matches_scalar_lookup3():
    rng = np.random.default_rng(1)
    k = rng.integers(0, 2 ** 32, size=(200, 3), dtype=np.uint64)
    got = R.hash_uint3(k[:, 0].astype(np.uint32), k[:, 1].astype(np.uint32),
                       k[:, 2].astype(np.uint32))
    expect = [scalar_hash_uint3(int(a), int(b), int(c)) for a, b, c in k]
    np.testing.assert_array_equal(got, np.array(expect, dtype=np.uint32))


def test_white_noise_value_is_hash_of_float_bits_times_2_pow_minus_32():
    p = np.array([[0.0, 0.0, 0.0], [1.0, -2.0, 3.0], [0.25, 17.5, -1e3]], dtype=np.float32)
    color = R.white_noise_color(p)
    for row, c in zip(p, color):
        h = scalar_hash_uint3(*(fbits(float(v)) for v in row))
        assert c[0] == np.float32(np.float32(h) * np.float32(2.0 ** -32))
    assert color.dtype == np.float32
    assert np.all((color >= 0) & (color <= 1))
    # The three channels are different hashes.
    assert np.all(color[:, 0] != color[:, 1]) and np.all(color[:, 1] != color[:, 2])


def test_lattice_gradients_are_uniform_in_the_cube():
    corners = np.stack(np.meshgrid(*[np.arange(-20, 20.0)] * 3), -1).reshape(-1, 3)
    g = R.lattice_gradient(corners)
    assert g.shape == corners.shape
    assert abs(g.mean()) < 0.01 and abs(g.std() - 1 / np.sqrt(3)) < 0.01


def test_gradient_noise_vanishes_on_the_lattice_and_ignores_signed_zero():
    corners = np.array([[0.0, 0.0, 0.0], [3.0, -4.0, 7.0], [-1.0, 2.0, -9.0]])
    v, g = R.gradient_noise(corners)
    np.testing.assert_allclose(v, 0, atol=1e-15)
    # At a lattice point the gradient is that corner's lattice gradient.
    np.testing.assert_allclose(g, R.lattice_gradient(corners), atol=1e-12)
    vz, gz = R.gradient_noise(np.array([[-0.0, 0.5, 0.5]]))
    vp, gp = R.gradient_noise(np.array([[0.0, 0.5, 0.5]]))
    assert vz == vp and np.array_equal(gz, gp)


def central_difference(fn, p, eps=1e-5):
    cols = []
    for e in np.eye(3):
        cols.append((fn(p + eps * e)[0] - fn(p - eps * e)[0]) / (2 * eps))
    return np.stack(cols, -1)


@pytest.mark.parametrize("name,fn", [
    ("noise", R.gradient_noise),
    ("fractal_sum", lambda p: R.fractal_sum(p, octaves=5)),
    ("turbulence", lambda p: R.turbulence(p, octaves=3)),
    ("dented", lambda p: R.dented(p, k=3.0, octaves=3)),
])
def test_analytic_gradients_match_central_differences(name, fn):
    rng = np.random.default_rng(7)
    p = rng.uniform(-10, 10, (3000, 3))
    value, grad = fn(p)
    if name in ("turbulence", "dented"):
        # |noise| has a kink on each octave's zero set: keep points away from it.
        octave_values = [R.gradient_noise(p * 2.0 ** i)[0] for i in range(3)]
        keep = np.min(np.abs(octave_values), axis=0) > 1e-3
        p, grad = p[keep], grad[keep]
    fd = central_difference(fn, p)
    err = np.linalg.norm(grad - fd, axis=-1) / np.maximum(np.linalg.norm(grad, axis=-1), 1e-3)
    assert np.max(err) < 1e-6, (name, np.max(err))


def test_noise_is_continuous_across_cells():
    rng = np.random.default_rng(3)
    p = rng.uniform(-5, 5, (500, 3))
    p[:, 0] = np.round(p[:, 0])
    e = np.array([1e-9, 0, 0])
    (v0, g0), (v1, g1) = R.gradient_noise(p - e), R.gradient_noise(p + e)
    np.testing.assert_allclose(v0, v1, atol=1e-8)
    np.testing.assert_allclose(g0, g1, atol=1e-7)


# -- footprint filtering (issue 24): w_i = 1 - smoothstep(1/4, 1/2, 2^i F) ------------------------

def _hermite_fade_by_hand(x):
    """1 - smoothstep(0.25, 0.5, x), written out piecewise (not the module's clip form)."""
    if x <= 0.25:
        return 1.0
    if x >= 0.5:
        return 0.0
    t = (x - 0.25) * 4.0
    return 1.0 - (3.0 * t * t - 2.0 * t * t * t)


@pytest.mark.parametrize("footprint", [0.0, 0.1, 0.125, 0.15, 0.2, 0.3, 1.0])
def test_footprint_fractal_sum_weights_each_octave_by_the_smoothstep_fade(footprint):
    """fractal_sum with a footprint is sum_i gain^i w_i noise(2^i p), w_i from the piecewise
    fade by hand: at F = 0.125 octave 3 (f = 4) sits at x = 0.5 (gone), octave 2 at 0.25
    (whole); at F = 0.15 octave 2 is at x = 0.3, t = 0.2, w = 1 - 0.104 = 0.896."""
    rng = np.random.default_rng(11)
    p = rng.uniform(-4, 4, (400, 3))
    value, grad = R.fractal_sum(p, octaves=4, footprint=np.full(400, footprint))
    expect_v, expect_g = np.zeros(400), np.zeros((400, 3))
    for i in range(4):
        w = 0.5 ** i * _hermite_fade_by_hand(2.0 ** i * footprint)
        v, g = R.gradient_noise(p * 2.0 ** i)
        expect_v += w * v
        expect_g += w * 2.0 ** i * g
    np.testing.assert_allclose(value, expect_v, rtol=0, atol=1e-14)
    np.testing.assert_allclose(grad, expect_g, rtol=0, atol=1e-13)
    if footprint == 0.15:
        assert abs(_hermite_fade_by_hand(0.3) - 0.896) < 1e-12


def test_footprint_zero_changes_nothing_and_a_huge_one_leaves_nothing():
    rng = np.random.default_rng(12)
    p = rng.uniform(-4, 4, (300, 3))
    for fn in (R.fractal_sum, R.turbulence):
        plain = fn(p, octaves=4)
        small = fn(p, octaves=4, footprint=np.zeros(300))
        np.testing.assert_array_equal(plain[0], small[0])
        np.testing.assert_array_equal(plain[1], small[1])
        v, g = fn(p, octaves=4, footprint=np.full(300, 0.5))       # even octave 0 is gone
        assert np.all(v == 0) and np.all(g == 0)


def test_footprint_turbulence_fades_absolute_octaves_per_point():
    """Per-point footprints: each point's own weights (turbulence: |noise| and sign g)."""
    rng = np.random.default_rng(13)
    p = rng.uniform(-4, 4, (200, 3))
    fp = rng.uniform(0.0, 0.6, 200)
    value, grad = R.turbulence(p, octaves=3, footprint=fp)
    for k in range(0, 200, 37):
        ev, eg = 0.0, np.zeros(3)
        for i in range(3):
            w = 0.5 ** i * _hermite_fade_by_hand(2.0 ** i * fp[k])
            v, g = R.gradient_noise(p[k:k + 1] * 2.0 ** i)
            ev += w * abs(v[0])
            eg += w * 2.0 ** i * np.sign(v[0]) * g[0]
        assert abs(value[k] - ev) < 1e-14 and np.max(np.abs(grad[k] - eg)) < 1e-13


def test_bump_footprint_is_the_texel_size_for_a_bakes_equal_orthogonal_differentials():
    """A bake's differentials r a, r b (a, b orthonormal in the plane, n their normal) and
    J = c I: the group's estimator gives c r; J = diag(c1, c2, c3) on the z = 0 plane with
    a = x, b = y: r sqrt(c1^4 + c2^4) / sqrt(c1^2 + c2^2) (derived by hand)."""
    from surfgrad_addon.reference.noise_footprint import footprint_from_differentials
    rng = np.random.default_rng(14)
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    a = np.cross(n, rng.normal(size=(50, 3)))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(n, a)
    r = rng.uniform(1e-3, 0.2, (50, 1))
    c = rng.uniform(0.5, 8.0, (50, 1))
    f = footprint_from_differentials(r * a, r * b, n, c * r * a, c * r * b)
    np.testing.assert_allclose(f, (c * r)[:, 0], rtol=1e-12)
    c1, c2, c3 = 2.0, 5.0, 7.0
    ex, ey, ez = np.eye(3)
    f = footprint_from_differentials(0.1 * ex[None], 0.1 * ey[None], ez[None],
                                     0.1 * c1 * ex[None], 0.1 * c2 * ey[None])
    assert abs(f[0] - 0.1 * np.sqrt(c1 ** 4 + c2 ** 4) / np.sqrt(c1 ** 2 + c2 ** 2)) < 1e-15


def test_bump_footprint_of_orthogonal_unequal_differentials_is_their_rms():
    """dpdx = 0.3 x, dpdy = 0.1 y on the z = 0 plane, J = 3: F = 3 sqrt((0.09 + 0.01) / 2)."""
    from surfgrad_addon.reference.noise_footprint import footprint_from_differentials
    ex, ey, ez = np.eye(3)
    f = footprint_from_differentials(0.3 * ex[None], 0.1 * ey[None], ez[None],
                                     0.9 * ex[None], 0.3 * ey[None])
    assert abs(f[0] - 3.0 * np.sqrt(0.05)) < 1e-14
