"""Height-blended layers (reference/height_blend.py): the weights of (HB1) and the blend of
(HB2) against hand-worked values, their continuity, offsets, N layers and chaining."""

import numpy as np
import pytest

from surfgrad_addon.reference.height_blend import (HEIGHT_BLEND_CONTRAST, MIN_TRANSITION,
                                                   height_blend_transition,
                                                   height_blend_weights, surfgrad_height_blend)

pytestmark = pytest.mark.tier("numpy")

SG_A, SG_B, SG_C = np.array([0.3, -0.1, 0.0]), np.array([-0.2, 0.4, 0.1]), np.array([0, 0, 1.0])


def test_a_hand_worked_blend():
    # c = 1 - 0.8 = 0.2, m = 0.3: w = (0.2, 0.1), W = (2/3, 1/3).
    sg, height, w = surfgrad_height_blend((SG_A, SG_B), (0.3, 0.2), contrast=0.8)
    np.testing.assert_allclose(w, [2 / 3, 1 / 3], atol=1e-15)
    np.testing.assert_allclose(sg, 2 / 3 * SG_A + 1 / 3 * SG_B, atol=1e-15)
    assert height == pytest.approx(2 / 3 * 0.3 + 1 / 3 * 0.2, abs=1e-15)


def test_layers_more_than_the_transition_below_get_nothing():
    sg, height, w = surfgrad_height_blend((SG_A, SG_B), (0.9, 0.6), contrast=0.8)
    np.testing.assert_array_equal(w, [1.0, 0.0])
    np.testing.assert_array_equal(sg, SG_A)
    assert height == 0.9


def test_equal_heights_share_equally_and_contrast_sets_the_width():
    _, _, w = surfgrad_height_blend((SG_A, SG_B), (0.5, 0.5), contrast=0.3)
    np.testing.assert_allclose(w, [0.5, 0.5])
    assert height_blend_transition(0.0) == 1.0 and height_blend_transition(0.75) == 0.25
    assert height_blend_transition(1.0) == MIN_TRANSITION
    # Contrast 0, heights 0.1 apart: w = (1, 0.9) -> W_B = 0.9 / 1.9.
    _, _, w = surfgrad_height_blend((SG_A, SG_B), (0.6, 0.5), contrast=0.0)
    assert w[1] == pytest.approx(0.9 / 1.9, abs=1e-15)
    # Contrast 1: the higher layer takes all once it leads by the minimal width.
    _, _, w = surfgrad_height_blend((SG_A, SG_B), (0.5, 0.5 + 2 * MIN_TRANSITION), 1.0)
    np.testing.assert_array_equal(w, [0.0, 1.0])


def test_the_weights_are_continuous_where_the_heights_cross():
    hb = np.linspace(0.0, 1.0, 100001)
    for contrast in (0.0, HEIGHT_BLEND_CONTRAST, 1.0):
        w, height = height_blend_weights((np.full_like(hb, 0.5), hb), contrast)
        np.testing.assert_allclose(w.sum(axis=0), 1.0, atol=1e-14)
        assert w.min() >= 0.0
        step = np.abs(np.diff(w[1])).max()
        # Steepest slope of W_B = (c - d) / (2 c - d) (B lower by d): 1 / c, at d = c.
        assert step <= 1e-5 / height_blend_transition(contrast) * 1.01, contrast
        # The height is a weighted mean (between the two), slope at most 2 in h_B.
        assert np.abs(np.diff(height)).max() <= 2 * 1.01e-5
        assert np.all((height >= np.minimum(0.5, hb) - 1e-15) & (height <= np.maximum(0.5, hb)))
        assert np.all(np.diff(w[1]) >= -1e-15)          # B gains as it rises


def test_an_offset_is_added_to_its_layers_height():
    hb = np.linspace(0.0, 1.0, 11)
    w1, h1 = height_blend_weights((np.full(11, 0.5), hb), 0.7, offsets=(0.0, 0.25))
    w2, h2 = height_blend_weights((np.full(11, 0.5), hb + 0.25), 0.7)
    np.testing.assert_allclose(w1, w2, atol=1e-15)
    np.testing.assert_allclose(h1, h2, atol=1e-15)


def test_three_layers_and_a_chain_of_two_blends():
    rng = np.random.default_rng(7)
    h = rng.uniform(0, 1, size=(3, 5000))
    sgs = [np.broadcast_to(v, (5000, 3)) for v in (SG_A, SG_B, SG_C)]
    sg3, _, w3 = surfgrad_height_blend(sgs, h, 0.8)
    np.testing.assert_allclose(w3.sum(axis=0), 1.0, atol=1e-14)
    # A third layer far below changes nothing: the two-layer blend.
    sg2, _, _ = surfgrad_height_blend(sgs[:2], h[:2], 0.8)
    sg_low, _, _ = surfgrad_height_blend(sgs, (h[0], h[1], h[2] - 5.0), 0.8)
    np.testing.assert_allclose(sg_low, sg2, atol=1e-15)
    # blend(blend(A, B), C) is the three-layer blend where (A, B) is settled (one of the two
    # has all its weight), and close to it elsewhere.
    sg_ab, h_ab, w_ab = surfgrad_height_blend(sgs[:2], h[:2], 0.8)
    chain, _, _ = surfgrad_height_blend((sg_ab, sgs[2]), (h_ab, h[2]), 0.8)
    settled = w_ab.max(axis=0) == 1.0
    assert 0.2 < settled.mean() < 0.95
    np.testing.assert_allclose(chain[settled], sg3[settled], atol=1e-15)
    assert np.abs(chain - sg3).max() < 0.5 * np.abs(SG_A - SG_B).max()


def test_wrong_layer_counts_are_refused():
    with pytest.raises(ValueError, match="two or more layers"):
        surfgrad_height_blend((SG_A,), (0.5,))
    with pytest.raises(ValueError, match="two or more layers"):
        surfgrad_height_blend((SG_A, SG_B), (0.5,))
    with pytest.raises(ValueError, match="1 offsets for 2 layers"):
        height_blend_weights((0.5, 0.4), offsets=(0.1,))
