"""EXR files with too few colour channels, as Blender loads them on each line, and what a bake
does with them. The line fact LineFacts.exr_two_colours_fill_zero is pinned here: an EXR with
two of R, G and B loads them into R and G, and B is 0 on 4.2 but uninitialised memory on 4.5
and later (it differed between loads of one file, and sometimes held NaN: the checks' answer
was luck). Cycles renders neither (tests/test_faults_images34.py): a bake refuses it."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.image_headers import file_channels  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from test_faults_pipeline_leftovers import (_exr_of_channels, _normal_texels,  # noqa: E402
                                            _scene)

pytestmark = pytest.mark.tier("bake")
LINE = facts_for(bpy.app.version)
LOADS = 8


def _loads(path, times=LOADS):
    out = []
    for _ in range(times):
        img = bpy.data.images.load(str(path))
        px = np.empty(len(img.pixels), np.float32)
        img.pixels.foreach_get(px)
        bpy.data.images.remove(img)
        out.append(px.reshape(-1, 4))
    return out


def _planes(names):
    t = _normal_texels()
    src = {"R": t[..., 0], "G": t[..., 1], "B": t[..., 2], "A": t[..., 3] * 0.5}
    return {c: src[c] for c in names}, t


@pytest.mark.parametrize("names", ["RG", "RGA", "GB"])
def test_two_colour_channels_load_into_r_and_g_and_b_is_the_line_fact(names, tmp_path):
    planes, _ = _planes(names)
    path = tmp_path / "two.exr"
    _exr_of_channels(path, planes)
    loads = _loads(path)
    first, second = [c for c in "RGB" if c in names]
    # The two present channels, in R, G and B order, are the loaded R and G.
    for got, name in ((0, first), (1, second)):
        want = planes[name].ravel()
        assert all(np.allclose(px[:, got], want, atol=2e-3) for px in loads), (names, got)
    b = [px[:, 2] for px in loads]
    zero = all(np.array_equal(v, np.zeros_like(v)) for v in b)
    assert zero == LINE.exr_two_colours_fill_zero, (LINE.line, [v[:4] for v in b[:3]])
    with open(path, "rb") as f:
        assert file_channels(f).two_colours


@pytest.mark.parametrize("names", ["R", "G", "B", "RA"])
def test_one_colour_channel_is_spread_as_grey_and_defined(names, tmp_path):
    planes, _ = _planes(names)
    path = tmp_path / "one.exr"
    _exr_of_channels(path, planes)
    loads = _loads(path, 3)
    colour = next(c for c in names if c in "RGB")
    for px in loads:
        for c in range(3):
            assert np.allclose(px[:, c], planes[colour].ravel(), atol=2e-3), (names, c)
    with open(path, "rb") as f:
        found = file_channels(f)
    assert found.lacking == "grey" and not found.two_colours


def _bake(blend, output, capsys):
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(output), "--resolution", "16"])
    return rc, capsys.readouterr().err


def test_a_bake_from_an_exr_with_two_colour_channels_is_refused_on_every_line(tmp_path, capsys):
    """Refused before baking (exit 2, no map) naming the image, what its file holds and the fix,
    on every run: Cycles renders a grey of R from it (tests/test_faults_images34.py), not the R
    and G Blender shows (nor their B: uninitialised on 4.5 and later, where the NaN check's
    answer was luck; 0 on 4.2, which baked it with a warning that B reads 0, untrue of the
    grey map Cycles baked)."""
    planes, _ = _planes("RG")
    _exr_of_channels(tmp_path / "n.exr", planes)
    blend = _scene(tmp_path / "e.blend", tmp_path / "n.exr")
    shown = "0" if LINE.exr_two_colours_fill_zero else "uninitialised"
    for run in range(3):
        out = tmp_path / f"m{run}.png"
        rc, err = _bake(blend, out, capsys)
        assert rc == exit_codes.BAD_REQUEST and not out.exists(), err
        assert (f"image 'n.exr' holds two colour channels in its file (n.exr: R and G EXR): "
                f"Blender {LINE.line} shows them in R and G with B {shown}, but Cycles renders "
                f"a grey of the first of them, so no check sees what the bake takes") in err
        assert "non-finite" not in err, err
