"""A GPU bake's Linear lookups as an NVIDIA H100's texture unit made them, lookup by lookup
(tools/texture_unit_probe: probe.cu on the card; tests/data/h100_texture_unit.npz keeps 2048
lookups of each coordinate set of the random-texel run, a 128^2 float4 texture, wrap).

Findings (docs/performance.md, "On a GPU"; docs/gpu_texture_unit.json for all 6M lookups):
- The reference's GPU model weighted the four texels by exact products of the two axis weights
  (each rounded to 1/256, ties to even). The texture unit rounds the far corner's product to
  1/256 again (ties up) and takes the other three from it: w01 = tx - w11, w10 = ty - w11,
  w00 = 1 - tx - ty + w11. Against the card the earlier model got 2% of random-texel lookups
  (max 5.7e-3 off), the model now every one to float32 rounding. At a bake's plain UV lookups
  (tx = ty = 0.5 between a 64^2 bake and a 128^2 image) both models are exact, which is why only
  the methods whose lookups sit at computed coordinates (triplanar, decals, parallax, the
  detail layer, the procedural basis, post-resolve) came out over the bars on the GPU.
- Ties: np.round's ties to even disagreed with the card at 0.1-0.5% of lookups, every one a
  tie; the card rounds them up.
- With numba installed, the height-map and parallax references looked up heights in their
  compiled kernels, with exact weights even inside gpu_texture_filter(): a GPU compare's
  height lookups were modelled as a CPU's. They now take sample_image's lookups there.
"""

from pathlib import Path

import numpy as np
import pytest

from surfgrad_addon import reference as R
from surfgrad_addon.reference import compiled, height_map_kernels, parallax_kernels
from surfgrad_addon.reference import image_sampling as IS

pytestmark = pytest.mark.tier("numpy")

DATA = np.load(Path(__file__).parent / "data" / "h100_texture_unit.npz")
SETS = ("one", "tiled", "sweep", "centres")


def _earlier_model(image, st):
    """Products of the axis weights, each rounded to the nearest 1/256 with ties to even."""
    h, w = image.shape[:2]
    x = st[:, 0] * w - 0.5
    y = st[:, 1] * h - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    tx = (np.round((x - x0) * 256) / 256)[:, None]
    ty = (np.round((y - y0) * 256) / 256)[:, None]
    c = lambda yy, xx: image[yy % h, xx % w]
    return ((1 - ty) * ((1 - tx) * c(y0, x0) + tx * c(y0, x0 + 1))
            + ty * ((1 - tx) * c(y0 + 1, x0) + tx * c(y0 + 1, x0 + 1)))


@pytest.mark.parametrize("name", SETS)
def test_gpu_lookups_are_the_h100s(name):
    texels = DATA["texels"].astype(np.float64)
    st = DATA[f"st_{name}"].astype(np.float64)
    card = DATA[f"gpu_{name}"].astype(np.float64)
    with IS.gpu_texture_filter():
        model = IS.sample_image(texels, st)
    assert np.max(np.abs(model - card)) < 1e-6


def test_the_data_tells_the_models_apart():
    """Exact weights and the earlier model both miss the card where coordinates are anywhere."""
    texels = DATA["texels"].astype(np.float64)
    st = DATA["st_one"].astype(np.float64)
    card = DATA["gpu_one"].astype(np.float64)
    exact = IS.sample_image(texels, st)
    earlier = _earlier_model(texels, st)
    assert np.mean(np.all(np.abs(exact - card) < 1e-6, -1)) < 0.01
    assert np.mean(np.all(np.abs(earlier - card) < 1e-6, -1)) < 0.1
    assert np.max(np.abs(earlier - card)) > 3e-3


def test_a_tie_rounds_up():
    """A weight of exactly 1.5/256 (and 2.5/256): ties to even would give 2/256 for both."""
    ramp = np.array([[0.0, 1.0]])                 # a lookup returns its weight (EXTEND)
    for weight, card in ((1.5 / 256, 2 / 256), (2.5 / 256, 3 / 256)):
        st = np.array([[(weight + 0.5) / 2, 0.5]])
        with IS.gpu_texture_filter():
            assert IS.sample_image(ramp, st, extension="EXTEND")[0] == card


def _never(*args, **kwargs):
    raise AssertionError("a compiled lookup with exact weights inside gpu_texture_filter()")


@pytest.mark.skipif(not compiled.enabled(), reason="numba is not installed")
def test_height_lookups_take_the_texture_units_weights(monkeypatch):
    rng = np.random.default_rng(5)
    height = rng.random((32, 32))
    st = rng.random((500, 2))
    exact = R.deriv_from_height_map(height, st)
    monkeypatch.setattr(height_map_kernels, "derivative", _never)
    with IS.gpu_texture_filter():
        gpu = R.deriv_from_height_map(height, st)
        taps = [IS.sample_image(height, st + d) for d in ((0, 0), (1 / 32, 0), (0, 1 / 32))]
    assert np.allclose(gpu, np.stack([taps[1] - taps[0], taps[2] - taps[0]], -1), atol=1e-12)
    assert np.max(np.abs(gpu - exact)) > 1e-3


@pytest.mark.skipif(not compiled.enabled(), reason="numba is not installed")
def test_parallax_lookups_take_the_texture_units_weights(monkeypatch):
    td = R.rasterize(R.meshes.uv_sphere(segments=16, rings=8), "UVMap", 48, 48)
    height = np.random.default_rng(9).random((32, 32))
    view = R.methods.unit_base_normal(td) * 0.6 + np.array([0.5, 0.2, 0.6])
    view /= np.linalg.norm(view, axis=-1, keepdims=True)
    exact = R.methods.parallax_offset(td, height, view, 0.05)
    monkeypatch.setattr(parallax_kernels, "march", _never)
    with IS.gpu_texture_filter():
        gpu = R.methods.parallax_offset(td, height, view, 0.05)
    assert np.max(np.abs(gpu - exact)) > 1e-6
