"""A float image's pixels are read once per request check (addon/float_pixels.py): the
finite-pixel refusal and the -1..1 warning share one read. Before, each loaded the image and
copied every pixel: for an 8192^2 float EXR, 11 s of checks before a 5 s bake (5.2.3)."""

import numpy as np
import pytest

from surfgrad_addon.addon import float_pixels as FP

pytestmark = pytest.mark.tier("numpy")


def _naive(texels):
    """The counts, written out value by value against which the sliced sums are held."""
    nonfinite = sum(1 for v in texels.ravel() if not np.isfinite(v))
    below = tuple(sum(1 for v in texels[:, c] if v < 0) if texels.shape[1] >= 2 else 0
                  for c in (0, 1))
    colours = [row[:3] for row in texels]
    high = [[v for v in row if v > 1.01] for row in colours]
    above = sum(1 for h in high if h)
    return nonfinite, below, above, max((v for h in high for v in h), default=0.0)


@pytest.mark.parametrize("channels", [1, 3, 4])
@pytest.mark.parametrize("slice_texels", [1, 7, 1 << 22])
def test_the_sliced_counts_are_the_value_by_value_counts(channels, slice_texels, monkeypatch):
    monkeypatch.setattr(FP, "_SLICE_TEXELS", slice_texels)
    rng = np.random.default_rng(channels * 31 + slice_texels)
    texels = rng.uniform(-0.3, 1.3, (53, channels)).astype(np.float32)
    flat = texels.ravel()
    flat[rng.choice(flat.size, 6, replace=False)] = [np.nan, np.inf, -np.inf, np.nan,
                                                     -np.inf, 3.4e38]
    facts = FP.summed(texels)
    nonfinite, below, above, largest = _naive(texels)
    assert facts.texels == 53
    assert facts.nonfinite == nonfinite == 5
    assert facts.below_zero == below
    assert facts.above_one == above > 0 and facts.largest == largest
    assert facts.share_below_zero() == tuple(n / 53 for n in below)


def test_values_at_float32s_limit_are_finite_and_one_nan_among_them_is_counted():
    """The float64 sum is a shortcut that float32's largest values cannot fool."""
    texels = np.full((8, 4), 3.0e38, np.float32)
    assert FP.summed(texels).nonfinite == 0
    texels[5, 2] = np.nan
    assert FP.summed(texels).nonfinite == 1


def test_texels_above_one_are_counted_once_each_and_alpha_is_not():
    """Red team 41: a normal map's texels above 1 (a 1e30 export) are counted per texel, over
    R, G and B; alpha above 1 and a 0..1 map's rounding (1.0, 1.001) are no such texel."""
    texels = np.full((6, 4), 0.5, np.float32)
    texels[0, :3] = 1e30                    # one texel, three values above 1
    texels[1, 1] = 1.5
    texels[2, 3] = 7.0                      # alpha
    texels[3, :3] = 1.0
    texels[4, 2] = 1.001
    facts = FP.summed(texels)
    assert (facts.above_one, facts.largest) == (2, np.float32(1e30))
    assert FP.summed(texels[2:]).above_one == 0


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


@pytest.mark.tier("bake")
def test_pixels_that_do_not_fit_the_process_are_a_refusal_not_a_traceback(tmp_path, capsys,
                                                                           monkeypatch):
    """Under `ulimit -v` an 8192^2 float EXR loaded (1 GB) but its copy for the check did not:
    before, numpy's MemoryError ended the bake with a traceback (exit 1). Now exit 2, one line
    naming the image, the limit and the fix, and no map. (Measured with ulimit -v 3.5 GB on
    5.2.3; here the copy's allocation fails on purpose, the same on every line.)"""
    pytest.importorskip("bpy")
    from surfgrad_addon.addon import commands, exit_codes
    from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image

    _write_image(tmp_path / "n.exr", _normal_texels(), "OPEN_EXR", float_buffer=True,
                 color_depth="32")
    blend = _scene(tmp_path / "f.blend", tmp_path / "n.exr")
    real_empty = np.empty

    def empty(shape, dtype=float):
        if dtype is np.float32 and shape == 16 * 16 * 4:        # the check's copy
            raise MemoryError("Unable to allocate")
        return real_empty(shape, dtype=dtype)

    monkeypatch.setattr(FP.np, "empty", empty)
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(tmp_path / "m.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert "surfgrad: error: image 'n.exr': its pixels could not be read to check them" in err
    assert "Traceback" not in err and not (tmp_path / "m.png").exists()


@pytest.mark.tier("bake")
def test_memory_running_out_mid_command_is_one_line_not_a_traceback(tmp_path, capsys,
                                                                    monkeypatch):
    """Any MemoryError a command meets (numpy's, under an address-space limit) ends it with
    one line and exit 1, the map not written; before, a raw traceback."""
    pytest.importorskip("bpy")
    from surfgrad_addon.addon import commands, exit_codes, normal_bake
    from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image

    _write_image(tmp_path / "n.png", _normal_texels())
    blend = _scene(tmp_path / "f.blend", tmp_path / "n.png")

    def out_of_memory(*args, **kwargs):
        raise MemoryError()

    monkeypatch.setattr(normal_bake, "_publish_all", out_of_memory)
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(tmp_path / "m.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAKE_FAILED, err
    assert "surfgrad: error: ran out of memory" in err and "Traceback" not in err, err
    assert not (tmp_path / "m.png").exists() and list(tmp_path.glob("*.png")) == [
        tmp_path / "n.png"], list(tmp_path.iterdir())


@pytest.mark.parametrize("slice_texels", [1, 1 << 22])
def test_values_past_what_a_shader_squares_are_counted_as_the_compare_check_counts(
        slice_texels, monkeypatch):
    """Red team 41: finite values beyond +-1e18 (a shader's float32 squares of them overflow)
    are counted by magnitude, in the bake's sliced read and compare's check alike; NaN still
    names itself first."""
    from surfgrad_addon.reference import input_checks as IC
    monkeypatch.setattr(FP, "_SLICE_TEXELS", slice_texels)
    texels = np.full((5, 4), 0.5, np.float32)
    texels[0, 0], texels[2, 3], texels[4, 1] = 2e18, -3e20, 9e17
    facts = FP.summed(texels)
    assert (facts.nonfinite, facts.beyond, facts.largest_magnitude) == (0, 2, np.float32(3e20))
    assert IC.pixels_problem("image 'x'", texels) == IC.nonfinite_pixels_problem(
        "image 'x'", 0, 2, float(np.float32(3e20)))
    assert "has 2 pixel value(s) beyond +-1e+18 (up to 3e+20)" in IC.pixels_problem(
        "image 'x'", texels)
    assert IC.pixels_problem("image 'x'", texels[1:2]) is None
    texels[1, 1] = np.nan
    assert "non-finite pixels (NaN or Inf, 1 value(s))" in IC.pixels_problem("image 'x'", texels)
