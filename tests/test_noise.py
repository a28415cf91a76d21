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
