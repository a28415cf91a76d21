"""Red team 59f: bad pixels and unusual image files read as normal maps.

1. A normal map with an alpha channel below 1 (a PNG or TGA whose alpha is a mask, a coverage
   or a packed height; alpha 0 texels whose RGB is anything) read in the working colour space
   (Linear Rec.709, which an artist picks as "linear, so no conversion"): Cycles multiplies
   the colour by the alpha before the Normal Map node or SG Normal Map decodes it, under
   Straight (a PNG's default) on every line, and up to 5.0 a PNG's Premultiplied too; 5.2 an
   EXR set to Straight too (it loads Premultiplied). Measured with 16^2 bakes of a 16 x 16 PNG
   (alpha 0.5 in the middle 8 x 8, 0 in a 4 x 4 corner), against the normals its RGB holds:
   the Normal Map node 73.7 degrees off at alpha 0.5 and 101.2 at alpha 0 (up to 106.1), SG
   Normal Map 68.1 and 79.2 (up to 98.5); exit 0 and no word, since the colour-space warning
   took the working space as unconverted (true of colour, not of alpha). Non-Color, or Alpha
   Channel Packed or None, reads the RGB as the file holds it (0.12 degrees, the PNG's
   rounding). Now warned (stderr, so the api's, and Freeze's list:
   normal_map_checks.premultiplied_problem, per line: LineFacts.byte_alpha_multiplied,
   float_alpha_multiplied), naming the image, the node, the count, the lowest alpha and the
   fix; an RGBA map whose alpha is all 1 is not warned about.
2. A two-channel (RG, BC5-style) normal map saved as RGB with blue 0 (what a BC5 texture
   converted back to PNG holds) or 0.5: exit 0, no word. Blue 0 through the Normal Map node
   baked every normal into the surface (z -1.00 to -0.87), 136.3 degrees off on average (up
   to 179.4) from what R and G mean; SG Normal Map (Listing 2's |z|) 2.0 (up to 5.1); blue
   0.5, both 66.0 (up to 79.7). Now warned where more than 5% of a map's texels hold blue at
   or below 0.5 (not counting black, a bake's untouched background, nor the zero vector),
   naming the image, the node, the count and how to rebuild blue (normal_map_checks.
   blue_problem). A byte map above 2048^2 texels is counted on a copy scaled down: read in
   full, a 16384^2 PNG normal map took a 16^2 bake from 3.9 s to 18.5 s and 2.2 to 5.6 GB
   (peak RSS); scaled, 12.7 s and 2.6 GB (the copy reloads the file).

Probed and fine (16^2 bakes through a Normal Map node, Non-Color, each against the RGB
Pillow decodes from the file: at most 0.04 degrees, exit 0, no warning): palette PNGs (8-bit,
4-bit, with a transparent entry), a 16-bit RGB PNG, a progressive JPEG, a CMYK JPEG, TGA
(plain and RLE), BMP, TIFF (plain, deflate, RGBA) and lossless WebP; an RGBA PNG or EXR
whose alpha is below 1 read as Non-Color under every Alpha mode. `compare --image` (Torus,
32^2, normal-map, triplanar, decal) with a 1 x 1, 1 x 16, 16 x 1 and 13 x 7 PNG, a blue 0 map
and an RGBA map with alpha 0 and 0.5: max 6e-5 degrees, exit 0 (it reads its image as data).
SG Height Map HQ (per image) over 1 x 1, 1 x 16, 16 x 1, 2 x 2 and 13 x 7 grey PNGs: finite
unit normals, flat where the heights are.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
Image = pytest.importorskip("PIL.Image")

from surfgrad_addon.addon import exit_codes, normal_map_checks  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from test_faults_images33 import _bake  # noqa: E402
from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image  # noqa: E402

pytestmark = pytest.mark.tier("bake")
WARNING = ("has 80 of its 256 texels with alpha below 1 (down to 0) and is read in colour "
           "space 'Linear Rec.709' with Alpha 'Straight': Cycles multiplies its colour by the "
           "alpha")
FIX = "set the image's Color Space to Non-Color (or its Alpha to Channel Packed)"


def _alpha():
    """16 x 16 alpha: 0.5 in the middle 8 x 8, 0 in a 4 x 4 corner, else 1 (80 below 1)."""
    a = np.ones((16, 16))
    a[4:12, 4:12] = 0.5
    a[0:4, 0:4] = 0.0
    return a


def _png(path, alpha):
    """An RGBA PNG written by Pillow (not Blender), and the unit normals its RGB holds (rows
    bottom up, as Blender's pixels)."""
    rgba = _normal_texels(16)
    rgba[..., 3] = alpha
    rgba[0:4, 0:4, :3] = (0.9, 0.1, 0.7)        # whatever lies under alpha 0
    u8 = np.round(rgba * 255).astype(np.uint8)
    Image.fromarray(u8[::-1], "RGBA").save(path)
    n = u8[..., :3] / 255.0 * 2 - 1
    return path, n / np.linalg.norm(n, axis=-1, keepdims=True)


def _baked(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        px = np.asarray(img.pixels[:], np.float64).reshape(16, 16, 4)[..., :3] * 2 - 1
    finally:
        bpy.data.images.remove(img)
    return px


def _degrees(a, b):
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip((a * b).sum(-1), -1, 1)))


def _set(blend, **settings):
    img = bpy.data.images["n.png"]
    for name, value in settings.items():
        setattr(img, name, value)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)


@pytest.mark.parametrize("via, node", [("ShaderNodeNormalMap", "Normal Map node 'Normal Map'"),
                                       ("SG Normal Map", "SG Normal Map node 'Group'")])
def test_a_straight_alpha_map_in_the_working_space_is_warned_about(via, node, tmp_path,
                                                                    capsys):
    """Before: exit 0 and no word, the alpha 0.5 texels over 60 degrees off. Now warned,
    naming the image, the node, the count and the fix (the map is Cycles' either way)."""
    path, expected = _png(tmp_path / "n.png", _alpha())
    blend = _scene(tmp_path / "s.blend", path, via=via, space="Linear Rec.709")
    _set(blend, alpha_mode="STRAIGHT")
    rc, err = _bake(blend, tmp_path / "m.exr", capsys)
    assert rc == exit_codes.OK, err
    assert f"image 'n.png', read by {node} (material 'Mat'), {WARNING}" in err, err
    assert FIX in err and err.count("with alpha below 1") == 1, err
    off = _degrees(_baked(tmp_path / "m.exr"), expected)
    assert off[_alpha() == 1].max() < 0.5, off           # the bake is Cycles' render:
    assert off[8, 8] > 60, off[8, 8]                     # the alpha bends those normals


@pytest.mark.parametrize("settings", [dict(colorspace_settings__name="Non-Color"),
                                      dict(alpha_mode="CHANNEL_PACKED")])
def test_the_fixes_read_the_file_as_it_is_and_are_not_warned_about(settings, tmp_path, capsys):
    """Non-Color, or an Alpha mode that leaves the colour alone: every texel its RGB's
    normal (the PNG's 8-bit rounding only), no warning."""
    path, expected = _png(tmp_path / "n.png", _alpha())
    blend = _scene(tmp_path / "s.blend", path, space="Linear Rec.709")
    img = bpy.data.images["n.png"]
    for name, value in settings.items():
        if name == "colorspace_settings__name":
            img.colorspace_settings.name = value
        else:
            setattr(img, name, value)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    rc, err = _bake(blend, tmp_path / "m.exr", capsys)
    assert rc == exit_codes.OK, err
    assert "alpha below 1" not in err, err
    assert _degrees(_baked(tmp_path / "m.exr"), expected).max() < 0.5


def test_freeze_warns_the_same_and_an_opaque_alpha_is_not_warned_about(tmp_path):
    """The add-on's list (Freeze reports it) has the line for alpha below 1; none for an RGBA
    map whose alpha is all 1, nor for an EXR with alpha below 1 (it loads Premultiplied)."""
    for alpha, expected in ((_alpha(), [WARNING]), (np.ones((16, 16)), [])):
        path, _ = _png(tmp_path / "n.png", alpha)
        _scene(tmp_path / "s.blend", path, via="SG Normal Map", space="Linear Rec.709")
        bpy.data.images["n.png"].alpha_mode = "STRAIGHT"
        found = [w for w in normal_map_checks.input_warnings(bpy.data.objects["Plane"])
                 if "alpha below 1" in w]
        assert [WARNING for w in found if WARNING in w and FIX in w] == expected, found
    rgba = _normal_texels(16)
    rgba[..., 3] = _alpha()
    _write_image(tmp_path / "n.exr", rgba, "OPEN_EXR", float_buffer=True, color_depth="32")
    _scene(tmp_path / "s.blend", tmp_path / "n.exr", space="Linear Rec.709")
    assert bpy.data.images["n.exr"].alpha_mode == "PREMUL"
    assert not [w for w in normal_map_checks.input_warnings(bpy.data.objects["Plane"])
                if "alpha below 1" in w]


@pytest.mark.parametrize("kind, mode", [("png", "STRAIGHT"), ("png", "PREMUL"),
                                        ("exr", "STRAIGHT"), ("exr", "PREMUL")])
def test_which_alpha_modes_multiply_is_the_line_fact_and_is_warned_so(kind, mode, tmp_path,
                                                                      capsys):
    """LineFacts.byte_alpha_multiplied / float_alpha_multiplied: 5.2 multiplies a PNG's and
    an EXR's colour by alpha under Straight only; up to 5.0 a PNG's under Straight and
    Premultiplied, an EXR's never. Measured against the RGB the file holds (the alpha 0.5
    texel: 73.7 degrees where multiplied), and the warning is given exactly there."""
    if kind == "png":
        path, expected = _png(tmp_path / "n.png", _alpha())
    else:
        rgba = _normal_texels(16)
        rgba[..., 3] = _alpha()
        path = tmp_path / "n.exr"
        _write_image(path, rgba, "OPEN_EXR", float_buffer=True, color_depth="32")
        expected = (rgba[..., :3] * 2 - 1) / np.linalg.norm(rgba[..., :3] * 2 - 1, axis=-1,
                                                           keepdims=True)
    blend = _scene(tmp_path / "s.blend", path, space="Linear Rec.709")
    bpy.data.images[path.name].alpha_mode = mode
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    line = facts_for(bpy.app.version)
    multiplied = mode in (line.byte_alpha_multiplied if kind == "png" else
                          line.float_alpha_multiplied)
    rc, err = _bake(blend, tmp_path / "m.exr", capsys)
    assert rc == exit_codes.OK, err
    off = _degrees(_baked(tmp_path / "m.exr"), expected)
    assert (off[8, 8] > 60) == multiplied and off[_alpha() == 1].max() < 0.5, off[8, 8]
    assert ("with alpha below 1" in err) == multiplied, err


def _blue_png(path, blue):
    """A 16 x 16 RGB PNG whose R and G hold _normal_texels' x and y and whose blue is `blue`
    (0: a two-channel map saved without its blue); the normals R and G mean."""
    rgb = np.round(_normal_texels(16)[..., :3] * 255).astype(np.uint8)
    rgb[..., 2] = blue
    Image.fromarray(rgb[::-1], "RGB").save(path)
    xy = rgb[..., :2] / 255.0 * 2 - 1
    return path, np.concatenate([xy, np.sqrt(1 - (xy * xy).sum(-1))[..., None]], -1)


BLUE = ("has 256 of its 256 texels with blue at or below 0.5: their normals point along or "
        "into the surface")
BLUE_FIX = "rebuild blue as 0.5 + 0.5 * sqrt(1 - x^2 - y^2)"


def test_a_two_channel_map_saved_with_blue_zero_is_warned_about(tmp_path, capsys):
    """Before: exit 0 and no word; the Normal Map node baked every normal into the surface
    (136 degrees off on average from what R and G mean). Now warned, naming the image, the
    node, the count and the fix; Freeze's list the same."""
    path, meant = _blue_png(tmp_path / "rg.png", 0)
    blend = _scene(tmp_path / "s.blend", path)
    rc, err = _bake(blend, tmp_path / "m.exr", capsys)
    assert rc == exit_codes.OK, err
    assert f"image 'rg.png', read by Normal Map node 'Normal Map' (material 'Mat'), {BLUE}" \
        in err and BLUE_FIX in err, err
    baked = _baked(tmp_path / "m.exr")
    assert baked[..., 2].max() < -0.8                   # into the surface, as Cycles renders
    assert _degrees(baked, meant).mean() > 120
    found = normal_map_checks.input_warnings(bpy.data.objects["Plane"])
    assert [w for w in found if BLUE in w and BLUE_FIX in w], found


def test_a_real_map_and_a_black_background_are_not_warned_about_for_blue(tmp_path, capsys):
    """The same map with its blue (z = sqrt(1 - x^2 - y^2)), and with a black quarter (a
    bake's untouched background, never on the UVs a material reads): no blue warning."""
    path, meant = _blue_png(tmp_path / "n.png", 0)
    rgb = np.round((meant * 0.5 + 0.5) * 255).astype(np.uint8)
    rgb[:8, :8] = 0
    Image.fromarray(rgb[::-1], "RGB").save(path)
    blend = _scene(tmp_path / "s.blend", path)
    rc, err = _bake(blend, tmp_path / "m.exr", capsys)
    assert rc == exit_codes.OK and "blue at or below" not in err, err


def test_a_large_byte_map_is_judged_on_a_scaled_copy_and_left_as_it_was(tmp_path):
    """Above 2048^2 texels a byte map is counted on a copy scaled down (its full float copy
    cost 15 s and 3.4 GB more for a 16384^2 PNG: measured on 5.2), removed again: the
    warning gives a share, and the file's images are as they were (none added, none loaded)."""
    rgb = np.zeros((2048, 4096, 3), np.uint8)
    rgb[..., :2] = 128 + np.arange(4096, dtype=np.uint8)[None, :, None] % 64
    path = tmp_path / "rg.png"
    Image.fromarray(rgb, "RGB").save(path, compress_level=1)
    _scene(tmp_path / "s.blend", path)
    bpy.data.images["rg.png"].buffers_free()
    before = sorted(bpy.data.images.keys())
    found = normal_map_checks.input_warnings(bpy.data.objects["Plane"])
    assert [w for w in found if "has about 100% of its texels with blue at or below 0.5" in w
            and BLUE_FIX in w], found
    assert sorted(bpy.data.images.keys()) == before
    assert not bpy.data.images["rg.png"].has_data


@pytest.mark.parametrize("space, warned", [("TANGENT", True), ("OBJECT", False),
                                           ("WORLD", False)])
def test_an_object_space_map_is_not_judged_by_its_blue(space, warned, tmp_path):
    """An object- or world-space map holds normals facing -Z too (blue below 0.5 on half a
    sphere): only a tangent-space read is judged by its blue."""
    path, _ = _blue_png(tmp_path / "os.png", 0)
    rgb = np.asarray(Image.open(path)).copy()
    rgb[:8, :, 2] = 230                                 # the half facing +Z
    Image.fromarray(rgb, "RGB").save(path)
    _scene(tmp_path / "s.blend", path)
    bpy.data.materials["Mat"].node_tree.nodes["Normal Map"].space = space
    found = [w for w in normal_map_checks.input_warnings(bpy.data.objects["Plane"])
             if "blue at or below 0.5" in w]
    assert bool(found) == warned, found
    assert not warned or "has 128 of its 256 texels with blue at or below 0.5" in found[0]
