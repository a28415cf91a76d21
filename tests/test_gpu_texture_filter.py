"""The reference's model of a GPU bake's Linear lookups (image_sampling.gpu_texture_filter):
the texture unit weights texels on a grid of 1/256, where the CPU (and the reference outside
the block) weights them exactly. Expectations from the bilinear formula by hand."""

import numpy as np
import pytest

from surfgrad_addon.reference import image_sampling as IS

pytestmark = pytest.mark.tier("numpy")


def _ramp():
    """Two texels in a row, 0 and 1, clamped at the edges: a lookup returns its weight."""
    return np.array([[0.0, 1.0]])


@pytest.mark.parametrize("weight", [0.3, 0.123, 0.998, 0.5])
def test_a_gpu_lookup_weights_texels_on_the_256_grid(weight):
    st = np.array([[(weight + 0.5) / 2, 0.5]])          # u * width - 0.5 = weight
    exact = IS.sample_image(_ramp(), st, extension="EXTEND")[0]
    with IS.gpu_texture_filter():
        gpu = IS.sample_image(_ramp(), st, extension="EXTEND")[0]
    after = IS.sample_image(_ramp(), st, extension="EXTEND")[0]
    assert exact == pytest.approx(weight, abs=1e-12)
    assert gpu == pytest.approx(np.round(weight * 256) / 256, abs=1e-12)
    assert after == exact                               # the block leaves nothing behind


def test_texel_centres_and_closest_lookups_are_the_same_on_both():
    rng = np.random.default_rng(7)
    image = rng.random((8, 8, 3))
    centres = IS.texel_centres(8, 8).reshape(-1, 2)
    anywhere = rng.random((50, 2)) * 3 - 1
    with IS.gpu_texture_filter():
        gpu_centres = IS.sample_image(image, centres)
        gpu_closest = IS.sample_image(image, anywhere, interpolation="Closest")
    assert np.array_equal(gpu_centres, image.reshape(-1, 3))
    assert np.array_equal(gpu_closest, IS.sample_image(image, anywhere, interpolation="Closest"))


def test_the_gpu_weights_move_a_lookup_by_at_most_half_a_step():
    rng = np.random.default_rng(3)
    image = rng.random((16, 16))
    st = rng.random((2000, 2))
    exact = IS.sample_image(image, st)
    with IS.gpu_texture_filter():
        gpu = IS.sample_image(image, st)
    # Each weight moves by <= 1/512; a bilinear value by <= 2 * (1/512) * (max - min).
    span = image.max() - image.min()
    assert 0 < np.max(np.abs(gpu - exact)) <= 2 / 512 * span + 1e-12
