"""A float image's pixels are read once per request check (addon/float_pixels.py): the
finite-pixel refusal and the -1..1 warning share one read. Before, each loaded the image and
copied every pixel: for an 8192^2 float EXR, 11 s of checks before a 5 s bake (5.2.3)."""

import numpy as np
import pytest

from surfgrad_addon.addon import float_pixels as FP


def _naive(texels):
    """The counts, written out value by value against which the sliced sums are held."""
    nonfinite = sum(1 for v in texels.ravel() if not np.isfinite(v))
    below = tuple(sum(1 for v in texels[:, c] if v < 0) if texels.shape[1] >= 2 else 0
                  for c in (0, 1))
    return nonfinite, below


@pytest.mark.tier("numpy")
@pytest.mark.parametrize("channels", [1, 3, 4])
@pytest.mark.parametrize("slice_texels", [1, 7, 1 << 22])
def test_the_sliced_counts_are_the_value_by_value_counts(channels, slice_texels, monkeypatch):
    monkeypatch.setattr(FP, "_SLICE_TEXELS", slice_texels)
    rng = np.random.default_rng(channels * 31 + slice_texels)
    texels = rng.uniform(-0.3, 1.0, (53, channels)).astype(np.float32)
    flat = texels.ravel()
    flat[rng.choice(flat.size, 6, replace=False)] = [np.nan, np.inf, -np.inf, np.nan,
                                                     -np.inf, 3.4e38]
    facts = FP.summed(texels)
    nonfinite, below = _naive(texels)
    assert facts.texels == 53
    assert facts.nonfinite == nonfinite == 5
    assert facts.below_zero == below
    assert facts.share_below_zero() == tuple(n / 53 for n in below)


@pytest.mark.tier("numpy")
def test_values_at_float32s_limit_are_finite_and_one_nan_among_them_is_counted():
    """The float64 sum is a shortcut that float32's largest values cannot fool."""
    texels = np.full((8, 4), 3.0e38, np.float32)
    assert FP.summed(texels).nonfinite == 0
    texels[5, 2] = np.nan
    assert FP.summed(texels).nonfinite == 1


@pytest.mark.tier("bake")
@pytest.mark.parametrize("nan", [False, True])
def test_the_checks_read_a_float_image_once(nan, tmp_path, monkeypatch):
    """A float normal map stored in -1..1: warned with its shares below 0; with two NaN
    values: refused, naming the count. Either way its pixels are read once."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.addon import bake_request as BR
    from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image

    rgba = _normal_texels()
    rgba[..., :3] = rgba[..., :3] * 2 - 1
    below = [round(100 * np.mean(rgba[..., c] < 0)) for c in (0, 1)]
    if nan:
        rgba[3, 4, 0] = rgba[7, 1, 1] = np.nan
    _write_image(tmp_path / "n.exr", rgba, "OPEN_EXR", float_buffer=True, color_depth="32")
    _scene(tmp_path / "f.blend", tmp_path / "n.exr")
    reads = []
    real = FP._read
    monkeypatch.setattr(FP, "_read", lambda image: reads.append(image.name) or real(image))
    request = BR.BakeRequest(object="Plane", output=str(tmp_path / "m.png"), resolution=16)
    warned = []
    if nan:
        with pytest.raises(BR.BakeRequestError,
                           match=r"'n.exr' has non-finite pixels \(NaN or Inf, 2 value"):
            BR.check(request, bpy.data.objects["Plane"], warn=warned.append)
    else:
        BR.check(request, bpy.data.objects["Plane"], warn=warned.append)
        said = f"has {below[0]}% of its texels below 0 in R and {below[1]}% in G"
        assert min(below) > 5 and [w for w in warned if said in w], warned
    assert reads == ["n.exr"]
