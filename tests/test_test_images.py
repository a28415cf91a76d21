"""The procedural test images' closed forms: the truths later comparisons rely on."""

import numpy as np
import pytest

import surfgrad_addon.reference as R
from surfgrad_addon.reference import images as T

pytestmark = pytest.mark.tier("numpy")


def test_wave_height_derivative_matches_central_differences():
    st = np.random.default_rng(0).uniform(size=(2000, 2))
    h, d = T.wave_height(st)
    e = 1e-6
    fd = np.stack([(T.wave_height(st + e * u)[0] - T.wave_height(st - e * u)[0]) / (2 * e)
                   for u in np.eye(2)], -1)
    np.testing.assert_allclose(d, fd, rtol=1e-6, atol=1e-6)
    assert h.min() >= 0 and h.max() <= 1
    # Integer frequencies: it tiles (REPEAT-safe).
    np.testing.assert_allclose(T.wave_height(st)[0], T.wave_height(st + [1.0, -2.0])[0], atol=1e-12)


def test_hemisphere_tile_is_the_normal_of_its_height_field():
    """Inside a cell the map is the normal of h = sqrt(r^2 - rho^2) over local coordinates,
    i.e. Eq. 12 of that height's derivative."""
    rng = np.random.default_rng(1)
    tiles, r = 4, 0.85
    st = rng.uniform(size=(3000, 2))
    m = T.hemisphere_tile_normal(st, tiles, r)
    local = (np.mod(st * tiles, 1.0) - 0.5) * 2
    rho2 = (local ** 2).sum(-1)
    inside = rho2 < (r * 0.99) ** 2
    h = np.sqrt(r * r - rho2[inside])
    deriv = -local[inside] / h[:, None]              # dh/d(local)
    np.testing.assert_allclose(m[inside], R.derivative_to_tspace_normal(deriv), atol=1e-12)
    np.testing.assert_allclose(m[rho2 > r * r], [[0, 0, 1]] * int((rho2 > r * r).sum()))
    img = T.hemisphere_tile_image(64, tiles, r)
    assert img.shape == (64, 64, 3) and img.min() >= 0 and img.max() <= 1
