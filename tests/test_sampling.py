"""Image lookups as Blender's Image Texture node does them, and height-map derivatives
(Listings 7 and 16), against hand-computed values."""

import numpy as np
import pytest

import surfgrad_addon.reference as R

pytestmark = pytest.mark.tier("numpy")


IMG = np.arange(12, dtype=np.float64).reshape(3, 4)   # 3 rows (v), 4 columns (u); row 0 at v=0


def st_of(i, j, w=4, h=3):
    return np.array([(i + 0.5) / w, (j + 0.5) / h])


def test_closest_picks_the_texel_under_the_point():
    assert R.sample_image(IMG, st_of(2, 1), "Closest") == IMG[1, 2]
    assert R.sample_image(IMG, [0.999, 0.001], "Closest") == IMG[0, 3]
    assert R.sample_image(IMG, [1.1, 0.5], "Closest", "REPEAT") == IMG[1, 0]
    assert R.sample_image(IMG, [1.1, -0.5], "Closest", "EXTEND") == IMG[0, 3]


def test_linear_returns_texels_at_centres_and_interpolates_between():
    for i in range(4):
        for j in range(3):
            assert R.sample_image(IMG, st_of(i, j), "Linear") == IMG[j, i]
    mid = (st_of(1, 0) + st_of(2, 1)) / 2
    assert R.sample_image(IMG, mid, "Linear") == pytest.approx(IMG[:2, 1:3].mean())
    # Repeat wraps the left neighbour of column 0 to column 3; Extend clamps it.
    left = np.array([0.0, st_of(0, 1)[1]])      # halfway between column 3 (wrapped) and 0
    assert R.sample_image(IMG, left, "Linear", "REPEAT") == pytest.approx((IMG[1, 3] + IMG[1, 0]) / 2)
    assert R.sample_image(IMG, left, "Linear", "EXTEND") == IMG[1, 0]


def test_multichannel_and_errors():
    rgb = np.dstack([IMG, -IMG, 2 * IMG])
    np.testing.assert_allclose(R.sample_image(rgb, st_of(1, 2)), [IMG[2, 1], -IMG[2, 1], 2 * IMG[2, 1]])
    with pytest.raises(ValueError, match="interpolation"):
        R.sample_image(IMG, [0.5, 0.5], "Cubic")
    with pytest.raises(ValueError, match="extension"):
        R.sample_image(IMG, [0.5, 0.5], "Linear", "CLIP")


def ramp_image(w, h, fn):
    x = np.arange(w) + 0.5
    y = np.arange(h) + 0.5
    xx, yy = np.meshgrid(x, y)
    return fn(xx, yy)


def test_height_map_derivatives_on_a_linear_ramp_are_exact():
    img = ramp_image(16, 8, lambda x, y: 0.25 * x - 0.5 * y)
    st = np.array([[0.4, 0.45], [0.3, 0.5]])
    for hq in (False, True):
        np.testing.assert_allclose(R.deriv_from_height_map(img, st, hq=hq, extension="EXTEND"),
                                   [[0.25, -0.5]] * 2, atol=1e-12)


def test_hq_is_central_difference_of_a_quadratic_and_plain_is_forward():
    img = ramp_image(32, 32, lambda x, y: 0.01 * x * x)
    st = R.texel_centres(32, 32)[10, 12]          # texel (12, 10), centre at x = 12.5
    plain = R.deriv_from_height_map(img, st)
    hq = R.deriv_from_height_map(img, st, hq=True)
    # Forward: H(13.5) - H(12.5); HQ (Eq. 20, Sobel rows are equal): (H(13.5) - H(11.5)) / 2.
    np.testing.assert_allclose(plain, [0.01 * (13.5 ** 2 - 12.5 ** 2), 0], atol=1e-12)
    np.testing.assert_allclose(hq, [0.01 * 2 * 12.5, 0], atol=1e-12)
    # Off-centre HQ is the bilinear blend of the two neighbouring central differences.
    st2 = np.array([(12.5 + 0.3) / 32, (10.5) / 32])
    np.testing.assert_allclose(R.deriv_from_height_map(img, st2, hq=True)[0],
                               0.01 * 2 * (12.5 * 0.7 + 13.5 * 0.3), atol=1e-12)
    # Above lod 0.5 the HQ branch fades out entirely; steps grow to 2^lod texels.
    np.testing.assert_allclose(R.deriv_from_height_map(img, st, hq=True, lod=1.0),
                               [0.01 * (14.5 ** 2 - 12.5 ** 2) / 2, 0], atol=1e-12)


def test_three_tap_screen_derivative():
    img = ramp_image(8, 8, lambda x, y: x + 10 * y)
    st = np.array([[0.5, 0.5]])
    d = R.deriv_three_tap(img, st, [[1 / 8, 0]], [[0, 2 / 8]])
    np.testing.assert_allclose(d, [[1.0, 20.0]])
