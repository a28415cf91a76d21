"""Review 59k: the last merges (48569e1..main), read hostile.

1. normal_map_checks.normal_map_warnings (058c6b8) left the blue warning out for any file
   with a channel or range warning, taken as the same fault said twice. Not so for texels
   above 1, nor for a fault of another UDIM tile (blue_problem reads the image's own pixels,
   its first tile):
   - a float EXR two-channel map saved with blue 0 (136 degrees off through the Normal Map
     node: test_faults_pixels59f) whose resize left 1 texel at 1.02 in R: before, the only
     warning was "has 1 of its 256 texels above 1 ... clamp the map to 0..1"; clamped as told,
     the map still bakes 136 degrees off; the blue warning (256 of 256 texels) was not said.
   - a UDIM EXR, tile 1001 blue 0, tile 1002 stored in -1..1 (a right blue): before, only
     tile 1002's -1..1 warning; the blue of tile 1001 was not said.
   Now blue is left out only for a grey-channels or -1..1 warning of its own pixels (of a UDIM
   image, the first tile's); the grey PNG and -1..1 EXR said once, as 058c6b8 meant.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import normal_map_checks  # noqa: E402
from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image  # noqa: E402

pytestmark = pytest.mark.tier("blender")
BLUE = "with blue at or below 0.5"


def _blue_zero(size=16):
    """RG of _normal_texels, blue 0 (a two-channel map saved without its blue), RGBA."""
    rgba = _normal_texels(size).copy()
    rgba[..., 2] = 0.0
    return rgba


def _warnings():
    return normal_map_checks.input_warnings(bpy.data.objects["Plane"])


def test_a_blue_zero_map_with_a_texel_above_1_is_warned_of_both(tmp_path):
    rgba = _blue_zero()
    rgba[3, 5, 0] = 1.02                        # a resize's overshoot
    path = tmp_path / "rg.exr"
    _write_image(path, rgba, "OPEN_EXR", float_buffer=True)
    _scene(tmp_path / "s.blend", path)
    found = _warnings()
    assert [w for w in found if "has 1 of its 256 texels above 1" in w], found
    assert [w for w in found if f"has 256 of its 256 texels {BLUE}" in w], found


def test_a_grey_or_minus_one_map_is_still_warned_of_once(tmp_path):
    """058c6b8's case holds: a -1..1 float map (its blue a fault of the range) is warned of
    for its range alone."""
    rgba = _normal_texels()
    rgba[..., :3] = rgba[..., :3] * 2 - 1       # stored in -1..1
    path = tmp_path / "m1.exr"
    _write_image(path, rgba, "OPEN_EXR", float_buffer=True)
    _scene(tmp_path / "s.blend", path)
    found = _warnings()
    assert [w for w in found if "it looks stored in -1..1" in w], found
    assert not [w for w in found if BLUE in w], found


def test_a_udim_map_whose_other_tile_is_minus_one_is_warned_of_its_first_tiles_blue(tmp_path):
    _write_image(tmp_path / "n.1001.exr", _blue_zero(), "OPEN_EXR", float_buffer=True)
    other = _normal_texels()
    other[..., :3] = other[..., :3] * 2 - 1
    _write_image(tmp_path / "n.1002.exr", other, "OPEN_EXR", float_buffer=True)
    _scene(tmp_path / "s.blend", tmp_path / "n.1001.exr")
    image = bpy.data.images["n.1001.exr"]
    image.source = "TILED"
    assert sorted(t.number for t in image.tiles) == [1001, 1002]
    found = _warnings()
    assert [w for w in found if "it looks stored in -1..1" in w and "tile 1002" in w], found
    assert [w for w in found if f"has 256 of its 256 texels {BLUE}" in w], found
