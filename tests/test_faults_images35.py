"""Red team 35: bad pixels in the files a normal map's bake reads beyond the image's own load.

- A float UDIM tile stored in -1..1 (tile 1002, tile 1001 a 0..1 map): the range warning read
  the image's own pixels, its first tile only, so the bake exited 0 with no warning while
  tile 1002's normals were pulled toward (-1, -1). Now every tile baked is judged, and the
  warning names the tile.
- An Image Sequence's frame file: no range or grey-channel warning was given at all (a single
  image gets both). Now the frame file the bake reads is judged, and named.
- Each file's header was opened once per check (six opens of one EXR a bake); a packed UDIM
  image's tiles after the first were never read (a damaged or NaN tile 1002: exit 0), nor
  was one lacking a tile the UVs cover (magenta baked, exit 0); on
  4.2, --depth half converted the map into the file's Output colour override (18 degrees)."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from test_faults_images33 import _bake  # noqa: E402
from test_faults_pipeline_leftovers import (_exr_of_channels, _normal_texels,  # noqa: E402
                                            _write_image)
from test_faults_pipeline_more import _scene as _source_scene  # noqa: E402

pytestmark = pytest.mark.tier("bake")
RANGE = "it looks stored in -1..1, but a normal map is read as 0..1"
GREY = "Blender spreads the grey over R, G and B"


def _exr(path, signed):
    """A 16 x 16 RGB half EXR normal map, stored 0..1, or in -1..1 where `signed`."""
    t = _normal_texels()[..., :3]
    _exr_of_channels(path, {c: (t[..., i] * 2 - 1 if signed else t[..., i])
                            for i, c in enumerate("RGB")})


def _below_zero():
    """(R, G) shares of a signed _exr's texels below 0 as stored (half floats), in whole
    percent, as the warning words them."""
    t = (_normal_texels()[..., :3] * 2 - 1).astype(np.float16)
    return tuple(round(100 * float(np.mean(t[..., c] < 0))) for c in (0, 1))


def _sequence_at(blend, frame):
    """Open `blend`, make its Image Sequence read 3 frames, the scene at `frame`; save."""
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    node = next(n for n in bpy.data.materials["Mat"].node_tree.nodes
                if n.bl_idname == "ShaderNodeTexImage")
    node.image_user.frame_duration = 3
    bpy.context.scene.frame_current = frame
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)


def test_a_udim_tile_in_minus_one_to_one_is_warned_about_by_name(tmp_path, capsys):
    tex = tmp_path / "tex"
    tex.mkdir()
    _exr(tex / "n.1001.exr", signed=False)
    _exr(tex / "n.1002.exr", signed=True)
    blend = _source_scene(tmp_path / "s.blend", tex / "n.1001.exr", "TILED", second_tile=True)
    (tmp_path / "out").mkdir()
    rc, err = _bake(blend, tmp_path / "out" / "m.<UDIM>.png", capsys)
    assert rc == exit_codes.OK, err
    r, g = _below_zero()
    assert err.count(RANGE) == 1, err
    assert (f"image 'n.1001.exr', read by Normal Map node 'Normal Map' (material 'Mat'), has "
            f"{r}% of its texels below 0 in R and {g}% in G (tile 1002: n.1002.exr): "
            f"{RANGE}") in err, err


def test_a_tile_the_bake_does_not_write_is_not_judged(tmp_path, capsys):
    """Tile 1002 in -1..1 but no face in it: the bake reads only tile 1001, no warning."""
    tex = tmp_path / "tex"
    tex.mkdir()
    _exr(tex / "n.1001.exr", signed=False)
    _exr(tex / "n.1002.exr", signed=True)
    blend = _source_scene(tmp_path / "s.blend", tex / "n.1001.exr", "TILED")
    (tmp_path / "out").mkdir()
    rc, err = _bake(blend, tmp_path / "out" / "m.<UDIM>.png", capsys)
    assert rc == exit_codes.OK and RANGE not in err, err


def test_the_sequence_frame_read_now_is_judged_for_its_range(tmp_path, capsys):
    """Frames 1 and 3 are 0..1, frame 2 -1..1: at scene frame 2 the bake reads frame 2 and is
    warned of it; at frame 1 it reads a 0..1 map and is not."""
    tex = tmp_path / "tex"
    tex.mkdir()
    for f in (1, 2, 3):
        _exr(tex / f"seq.{f:04d}.exr", signed=f == 2)
    blend = _source_scene(tmp_path / "s.blend", tex / "seq.0001.exr", "SEQUENCE")
    _sequence_at(blend, 2)
    rc, err = _bake(blend, tmp_path / "m2.png", capsys)
    r, g = _below_zero()
    assert rc == exit_codes.OK, err
    assert (f"image 'seq.0001.exr', read by Normal Map node 'Normal Map' (material 'Mat'), has "
            f"{r}% of its texels below 0 in R and {g}% in G (frame file seq.0002.exr): "
            f"{RANGE}") in err, err
    _sequence_at(blend, 1)
    rc, err = _bake(blend, tmp_path / "m1.png", capsys)
    assert rc == exit_codes.OK and RANGE not in err, err


def test_a_grey_sequence_frame_is_warned_about(tmp_path, capsys):
    """Grey PNG frames (one channel): a single grey PNG is warned about, a sequence of them
    was not."""
    tex = tmp_path / "tex"
    tex.mkdir()
    grey = np.full((16, 16, 4), 0.5, np.float32)
    for f in (1, 2):
        _write_image(tex / f"seq.{f:04d}.png", grey, color_mode="BW")
    blend = _source_scene(tmp_path / "s.blend", tex / "seq.0001.png", "SEQUENCE")
    rc, err = _bake(blend, tmp_path / "m.png", capsys)
    assert rc == exit_codes.OK, err
    assert ("image 'seq.0001.png', read by Normal Map node 'Normal Map' (material 'Mat'), "
            f"holds 1 channel in its file (frame file seq.0001.png: grey PNG): {GREY}") in err, err


@pytest.mark.parametrize("source", ["FILE", "TILED"])
def test_a_bakes_checks_open_each_image_file_once(source, tmp_path, capsys, monkeypatch):
    """The header checks (layers, channels, cut short, the memory check's size, the normal map
    warnings) opened each file once each: five opens of one PNG, and for a packed image five
    copies of its data (0.29 s each for a 50 MB PNG on 5.2.3). Now one a file."""
    import builtins
    tex = tmp_path / "tex"
    tex.mkdir()
    names = ["n.1001.exr", "n.1002.exr"] if source == "TILED" else ["n.exr"]
    for name in names:
        _exr(tex / name, signed=False)
    blend = _source_scene(tmp_path / "s.blend", tex / names[0], source,
                          second_tile=source == "TILED")
    opened, real_open = [], builtins.open

    def counting_open(file, *args, **kwargs):
        if str(file).startswith(str(tex)):
            opened.append(str(file))
        return real_open(file, *args, **kwargs)
    monkeypatch.setattr(builtins, "open", counting_open)
    (tmp_path / "out").mkdir()
    rc, err = _bake(blend, tmp_path / "out" / "m.<UDIM>.png", capsys)
    assert rc == exit_codes.OK, err
    assert sorted(opened) == [str(tex / n) for n in names], opened


def _half_map(tmp_path, name, override=None):
    """The pixels of a 16^2 --depth half map of the scene of _exr's 0..1 map, the scene's
    output colour management overridden to linear space `override` where given."""
    from test_faults_pipeline_leftovers import _scene
    _exr(tmp_path / "n.exr", signed=False)
    blend = _scene(tmp_path / f"{name}.blend", tmp_path / "n.exr")
    settings = bpy.context.scene.render.image_settings
    if override:
        settings.color_management = "OVERRIDE"
        settings.linear_colorspace_settings.name = override
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    out = tmp_path / f"{name}.exr"
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out), "--resolution", "16", "--depth", "half"])
    assert rc == exit_codes.OK
    img = bpy.data.images.load(str(out), check_existing=False)
    px = np.empty(len(img.pixels), np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4)[:, :3]


def test_a_half_map_ignores_the_scenes_output_colour_override(tmp_path):
    """Output Properties > Color Management: Override, linear space Linear Rec.2020. The half
    EXR is rewritten through the scene's output settings: on 4.2 its data were converted into
    that space, exit 0 with a map up to 0.16 off (18 degrees); 4.5 and later did not.
    Now the same map as with no override, on every line."""
    plain = _half_map(tmp_path, "plain")
    px = _half_map(tmp_path, "rec2020", "Linear Rec.2020")
    n, m = (2 * a - 1 for a in (px, plain))
    cos = np.sum(n * m, -1) / np.linalg.norm(n, axis=-1) / np.linalg.norm(m, axis=-1)
    worst = np.degrees(np.arccos(np.clip(cos, -1, 1))).max()
    assert np.array_equal(px, plain), (float(np.abs(px - plain).max()), worst)


@pytest.mark.parametrize("source", ["FILE", "TILED"])
def test_a_packed_tiff_cut_short_names_its_packed_data_and_the_fix(source, tmp_path, capsys):
    """A TIFF packed into the .blend from a copy cut short (for a packed UDIM image, tile
    1002's). Before: refused as "image 'n.tif' reads 'packed', a TIFF cut short ...; copy or
    export the file again, whole", though no file is read and a new copy leaves the packed one
    as it is (tile 1002 of a packed UDIM image was not read at all: exit 0 and a map of the
    rows Blender fills in). Now the words say it is packed, and which tile, and how to
    replace it."""
    from test_faults_images34 import CUT, _picture
    from test_faults_pipeline_leftovers import _scene
    whole = _picture(tmp_path / "w.tif")
    cut = whole[:int(len(whole) * CUT[".tif"])]
    if source == "FILE":
        (tmp_path / "n.tif").write_bytes(cut)
        blend = _scene(tmp_path / "s.blend", tmp_path / "n.tif", pack=True)
        subject, files = "image 'n.tif'", ["n.tif"]
    else:
        (tmp_path / "n.1001.tif").write_bytes(whole)
        (tmp_path / "n.1002.tif").write_bytes(cut)
        blend = _source_scene(tmp_path / "s.blend", tmp_path / "n.1001.tif", "TILED",
                              second_tile=True)
        bpy.data.images["n.1001.tif"].pack()
        bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
        subject, files = "image 'n.1001.tif' (tile 1002)", ["n.1001.tif", "n.1002.tif"]
    for name in files:
        (tmp_path / name).unlink()
    out = tmp_path / "out"
    out.mkdir()
    rc, err = _bake(blend, out / "m.<UDIM>.png", capsys)
    assert rc == exit_codes.BAD_REQUEST and list(out.iterdir()) == [], err
    assert (f"{subject} is packed from a TIFF cut short (its image data runs past the end "
            "of the file: a copy or download interrupted): Blender loads it at full size with "
            "the part missing filled in, which Cycles would bake; replace it with the whole "
            "file (Image Editor: Image > Replace) and pack that") in err, err


@pytest.mark.parametrize("damage", ["png_cut", "exr_nan"])
def test_a_packed_udim_tile_is_loaded_and_checked(damage, tmp_path, capsys):
    """A packed UDIM image whose tile 1002 is a PNG cut in half (Blender cannot load it) or an
    EXR with one NaN. Before: exit 0 and both tiles' maps written (the image's own load reads
    tile 1001 only; the tile files' check read files on disk only). Now refused, naming the
    tile, as for a tile on disk."""
    from test_faults_pipeline_more import _write_png
    ext = "png" if damage == "png_cut" else "exr"
    for tile in (1001, 1002):
        if ext == "png":
            _write_png(tmp_path / f"n.{tile}.png")
        else:
            t = _normal_texels()
            if tile == 1002:
                t[3, 4, 0] = np.nan
            _exr_of_channels(tmp_path / f"n.{tile}.exr",
                             {c: t[..., i] for i, c in enumerate("RGB")})
    if ext == "png":
        half = (tmp_path / "n.1002.png").read_bytes()
        (tmp_path / "n.1002.png").write_bytes(half[:len(half) // 2])
    blend = _source_scene(tmp_path / "s.blend", tmp_path / f"n.1001.{ext}", "TILED",
                          second_tile=True)
    bpy.data.images[f"n.1001.{ext}"].pack()
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    for tile in (1001, 1002):
        (tmp_path / f"n.{tile}.{ext}").unlink()
    out = tmp_path / "out"
    out.mkdir()
    rc, err = _bake(blend, out / "m.<UDIM>.png", capsys)
    assert rc == exit_codes.BAD_REQUEST and list(out.iterdir()) == [], err
    said = {"png_cut": f"tiled image 'n.1001.png' (tile 1002) reads its packed data, which "
                       f"could not be read (damaged, or a format Blender does not open)",
            "exr_nan": "tiled image 'n.1001.exr' (tile 1002) (its packed data) has non-finite "
                       "pixels (NaN or Inf, 1 value(s))"}[damage]
    assert said in err, err


def test_a_packed_udim_image_lacking_a_tile_the_uvs_cover_is_refused(tmp_path, capsys):
    """A packed UDIM image with tile 1001 only, UVs in 1001 and 1002. Before: exit 0, tile
    1002's map baked from Cycles' magenta (its mean (0.79, 0.21, 0.79), no normal map's); the
    lacking tile was looked for in images on disk only. Now refused, as on disk."""
    from test_faults_pipeline_more import _write_png
    _write_png(tmp_path / "n.1001.png")
    blend = _source_scene(tmp_path / "s.blend", tmp_path / "n.1001.png", "TILED",
                          second_tile=True)
    image = bpy.data.images["n.1001.png"]
    image.tiles.remove(image.tiles[1])
    image.pack()
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    (tmp_path / "n.1001.png").unlink()
    out = tmp_path / "out"
    out.mkdir()
    rc, err = _bake(blend, out / "m.<UDIM>.png", capsys)
    assert rc == exit_codes.BAD_REQUEST and list(out.iterdir()) == [], err
    assert ("tiled image 'n.1001.png' has no tile 1002 (tiles: [1001]), but the UVs cover it"
            in err), err
