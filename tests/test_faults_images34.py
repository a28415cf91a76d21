"""Red team 34: image files a bake meets, against what Blender loads from them.

- A luminance-chroma OpenEXR (Y with RY and / or BY: OpenEXR's YC files): Blender does not
  load luminance and chroma as RGB on any line (measured with 100 loads per line: full-size
  RY, BY give values far from the file's colours, the same each time on 4.2, mostly differing
  from load to load on 4.5 and later; Y with one of them loads 0 on 4.2; subsampled ones, as
  OpenEXR writes them, do not load at all; `ry`, `by` and `Y` load Y as a grey). Before: exit
  0 and a map of those values (or, by luck, a refusal for non-finite pixels); a subsampled one
  was refused as "damaged".
- An EXR with two of R, G and B, or with alpha and no colour: Cycles renders the file's
  channels as they lie (a grey of the first colour, the alpha after two as B, an alpha alone
  as a grey) on every line, not the R, G and B Blender shows (B 0 on 4.2, uninitialised on 4.5
  and later). 4.2 baked one with exit 0 and a warning that B reads 0 (every normal into the
  surface), untrue of the grey map Cycles baked; `compare --image` reported a correct group
  57-122 deg off. Now refused on every line.
- The frame file an Image Sequence reads: its header was never read, so an EXR with two of R,
  G and B (B uninitialised on 4.5 and later) or a luminance-chroma one baked with exit 0."""

import re

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.image_headers import file_channels  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from test_faults_images33 import _bake, _emitted, _pixels  # noqa: E402
from test_faults_pipeline_leftovers import (_exr_of_channels, _normal_texels,  # noqa: E402
                                            _scene, _write_image)
from test_faults_pipeline_more import _scene as _source_scene  # noqa: E402

pytestmark = pytest.mark.tier("bake")
LINE = facts_for(bpy.app.version)
REC709 = (0.2126, 0.7152, 0.0722)       # OpenEXR's luminance weights without chromaticities


def _yc_planes(names, subsampled=False):
    """({name: plane}, RGB (H, W, 3)) of a luminance-chroma EXR of the test normal map:
    Y = w . RGB, RY = (R - Y) / Y, BY = (B - Y) / Y (OpenEXR's ImfRgbaYca); `names` a
    comma-separated subset, in any case; chroma at half size when `subsampled`."""
    t = _normal_texels()
    r, g, b = t[..., 0], t[..., 1], t[..., 2]
    y = REC709[0] * r + REC709[1] * g + REC709[2] * b
    src = {"Y": y, "RY": (r - y) / y, "BY": (b - y) / y}
    planes = {n: src[n.upper()] for n in names.split(",")}
    if subsampled:
        planes = {n: p if n.upper() == "Y" else p[::2, ::2] for n, p in planes.items()}
    return planes, t[..., :3]


def _write_yc(path, names, subsampled=False):
    planes, rgb = _yc_planes(names, subsampled)
    _exr_of_channels(path, planes, {n: (2, 2) for n in planes if n.upper() != "Y"}
                     if subsampled else None)
    return rgb


def test_blender_loads_no_luminance_chroma_exr_as_its_colours(tmp_path):
    """The line fact behind the refusal, every line: 50 loads of a full-size Y, RY, BY file
    (an RGB file of the same size loaded between them) are each far from the file's colours,
    and so is what Cycles renders from it; a subsampled one does not load (0 x 0)."""
    rgb = _write_yc(tmp_path / "yc.exr", "Y,RY,BY")
    _exr_of_channels(tmp_path / "rgb.exr", {c: rgb[..., i] * 3 for i, c in enumerate("RGB")})
    loads = []
    for _ in range(50):
        _pixels(tmp_path / "rgb.exr")
        loads.append(_pixels(tmp_path / "yc.exr")[:, :3])
    want = rgb.reshape(-1, 3)
    errors = [float(np.nanmax(np.abs(px - want))) if np.isfinite(px).any() else np.inf
              for px in loads]
    assert min(errors) > 0.1, errors[:5]
    if LINE.exr_two_colours_fill_zero:      # 4.2: the same wrong colours every time
        assert all(np.array_equal(loads[0], px) for px in loads), errors[:5]
    # (4.5 and later fill them partly from uninitialised memory: most runs differ from load to
    # load, some give the same garbage 50 times, so sameness is not asserted there.)
    rendered = _emitted(tmp_path / "yc.exr").reshape(-1, 4)[:, :3]     # what Cycles bakes
    assert float(np.nanmax(np.abs(rendered - want))) > 0.1, rendered[:2]
    _write_yc(tmp_path / "sub.exr", "Y,RY,BY", subsampled=True)
    img = bpy.data.images.load(str(tmp_path / "sub.exr"))
    assert tuple(img.size) == (0, 0)
    bpy.data.images.remove(img)


@pytest.mark.parametrize("names, subsampled, kind", [
    ("Y,RY,BY", False, "Y and RY and BY"), ("Y,RY", False, "Y and RY"),
    ("Y,RY,BY", True, "Y and RY and BY"), ("ry,by,Y", False, "Y and ry and by")])
def test_a_bake_from_a_luminance_chroma_exr_is_refused(names, subsampled, kind, tmp_path,
                                                      capsys):
    """Before: exit 0 and a map far from the file's (full-size chroma; `ry,by,Y` a grey map
    of Y, without a word), or "could not be read (damaged ...): re-save it as PNG or EXR"
    (subsampled: it is an EXR, and not damaged). Now refused on every line, exit 2, no map,
    naming the file, what it is and the fix."""
    _write_yc(tmp_path / "n.exr", names, subsampled)
    with open(tmp_path / "n.exr", "rb") as f:
        assert file_channels(f).luma_chroma
    rc, err = _bake(_scene(tmp_path / "e.blend", tmp_path / "n.exr"), tmp_path / "m.png",
                    capsys)
    assert rc == exit_codes.BAD_REQUEST and not (tmp_path / "m.png").exists(), err
    assert (f"image 'n.exr' is a luminance-chroma OpenEXR (n.exr: {kind} EXR): Blender "
            f"{LINE.line} does not load its luminance and chroma as RGB") in err, err
    assert "save it as an RGB OpenEXR (R, G and B channels)" in err, err
    assert "damaged" not in err and "non-finite" not in err, err


@pytest.mark.parametrize("names", ["Y", "Y,A", "R,G,B,Y"])
def test_luminance_without_chroma_is_no_luminance_chroma_file(names, tmp_path):
    """Y and Y+A load as a defined grey (warned as such for a normal map); R, G, B and Y load
    R, G and B: neither is refused as luminance-chroma."""
    t = _normal_texels()
    src = {"Y": t[..., 1], "A": t[..., 3] * 0.5, "R": t[..., 0], "G": t[..., 1], "B": t[..., 2]}
    _exr_of_channels(tmp_path / "n.exr", {n: src[n] for n in names.split(",")})
    with open(tmp_path / "n.exr", "rb") as f:
        found = file_channels(f)
    assert not found.luma_chroma
    assert found.lacking == ("" if "R" in names else "grey")
    loads = [_pixels(tmp_path / "n.exr") for _ in range(3)]
    want = t[..., :3] if "R" in names else np.repeat(t[..., 1:2], 3, -1)
    for px in loads:
        assert np.allclose(px[:, :3], want.reshape(-1, 3), atol=2e-3)


@pytest.mark.parametrize("names, rendered", [
    ("R,G", "RRR"), ("G,B", "GGG"), ("r,g", "RRR"), ("R,G,A", "RGA"), ("G,B,A", "GBA"),
    ("A", "AAA"), ("A,Z", "AAA"), ("Z", "ZZZ"), ("y", "YYY"), ("y,a", "YYY")])
def test_cycles_renders_an_exr_lacking_colours_as_its_channels_lie(names, rendered, tmp_path):
    """The fact behind refusing such files on every line: what Cycles renders (an emission
    bake of the image's colour, no surfgrad check in the way) is the file's channels as they
    lie, the same on every line, and not the R, G and B Blender shows, which the checks and
    compare's reference read (B 0 on 4.2, uninitialised later)."""
    t = _normal_texels()
    src = {"R": t[..., 0], "G": t[..., 1], "B": t[..., 2], "A": t[..., 3] * 0.5,
           "Z": t[..., 2] * 0.25, "Y": t[..., 0] * 0.75}
    _exr_of_channels(tmp_path / "n.exr", {n: src[n.upper()] for n in names.split(",")})
    emitted = _emitted(tmp_path / "n.exr").reshape(-1, 4)[:, :3]
    want = np.stack([src[c].ravel() for c in rendered], -1)
    assert np.allclose(emitted, want, atol=2e-3), (LINE.line, emitted[:2], want[:2])
    shown = _pixels(tmp_path / "n.exr")[:, :3]
    if names not in ("Z", "y") or LINE.line in ("4.2", "4.5", "5.0"):   # (5.2 shows a lone
        assert not np.allclose(shown, emitted, atol=2e-3)                # Z or y as rendered)


def _rg_planes():
    t = _normal_texels()
    return {"R": t[..., 0], "G": t[..., 1]}


@pytest.mark.parametrize("frame", ["two_colours", "luminance_chroma"])
def test_an_image_sequence_frame_is_judged_by_its_header(frame, tmp_path, capsys):
    """An Image Sequence whose frame files are an R, G EXR or a luminance-chroma one. Before:
    the header check read no sequence frame, so on 5.2 three bakes in a row gave a refusal
    for non-finite pixels (by luck) and then exit 0 twice with a map of uninitialised B.
    Now refused as the same file read as a plain image is, every run."""
    tex = tmp_path / "tex"
    tex.mkdir()
    for f in (1, 2, 3):
        if frame == "two_colours":
            _exr_of_channels(tex / f"seq.{f:04d}.exr", _rg_planes())
        else:
            _write_yc(tex / f"seq.{f:04d}.exr", "Y,RY,BY")
    blend = _source_scene(tmp_path / "s.blend", tex / "seq.0001.exr", "SEQUENCE")
    shown = "0" if LINE.exr_two_colours_fill_zero else "uninitialised"
    for run in range(3):
        out = tmp_path / f"m{run}.png"
        rc, err = _bake(blend, out, capsys)
        assert rc == exit_codes.BAD_REQUEST and not out.exists(), err
        said = {"two_colours": f"holds two colour channels in its file (seq.0001.exr: R and G "
                               f"EXR): Blender {LINE.line} shows them in R and G with B "
                               f"{shown}, but Cycles renders a grey of the first of them",
                "luminance_chroma": f"is a luminance-chroma OpenEXR (seq.0001.exr: Y and RY "
                                    f"and BY EXR): Blender {LINE.line} does not load"}[frame]
        assert f"image sequence 'seq.0001.exr' {said}" in err, err
        assert "non-finite" not in err, err


@pytest.mark.parametrize("names", ["R,G", "Y,RY,BY"])
def test_compare_refuses_an_image_whose_loads_are_not_its_colours(names, tmp_path):
    """`compare --image` reads the image's pixels for the reference from one load and Cycles
    bakes from its own. Before, on 5.2, a correct SG Normal Map group was reported 57-66 deg
    off at worst for an R, G EXR and 113-122 deg for a luminance-chroma one, a different figure
    each run (an RGB EXR of the same map: 0.0012 deg); on 4.2, 71 deg for the R, G one, whose
    twin with B = 0 in the file compares at 0.0015 deg (the reference read B as 0, Cycles
    rendered a grey of R). Now refused as the bake refuses the file, on every line."""
    from surfgrad_addon.harness import compare, scenes as test_scenes
    path = tmp_path / "n.exr"
    if names == "R,G":
        _exr_of_channels(path, _rg_planes())
    else:
        _write_yc(path, names)
    plane = test_scenes.new_scene(["Plane"])["Plane"]
    said = {"R,G": "holds two colour channels in its file (n.exr: R and G EXR)",
            "Y,RY,BY": "is a luminance-chroma OpenEXR (n.exr: Y and RY and BY EXR)"}[names]
    with pytest.raises(compare.CompareError, match=re.escape(f"image {str(path)!r} {said}")):
        compare.compare_object(plane, "normal-map", 16, image=str(path), log=lambda *a: None)


def _space_bake(tmp_path, space, working=None, name="m"):
    """(exit code, stderr, map bytes) of a bake of an RGB EXR normal map read in colour space
    `space`, in a file whose working space is `working` (5.0 and later; None: the default)."""
    import contextlib
    import io
    t = _normal_texels()
    _exr_of_channels(tmp_path / "n.exr", {c: t[..., i] for i, c in enumerate("RGBA")})
    blend = _scene(tmp_path / f"{name}.blend", tmp_path / "n.exr")
    if working:
        bpy.ops.wm.set_working_color_space(working_space=working, convert_colors=False)
    bpy.data.images["n.exr"].colorspace_settings.name = space
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    out = tmp_path / f"{name}.png"
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                               "--output", str(out), "--resolution", "16"])
    return rc, err.getvalue(), out.read_bytes()


@pytest.mark.parametrize("space, converts", [("Linear Rec.709", False), ("sRGB", True),
                                             ("Linear Rec.2020", True)])
def test_only_a_colour_space_that_converts_is_warned_about(space, converts, tmp_path):
    """Before: every colour space but Non-Color was warned as bending every normal, the
    working space too (Linear Rec.709, what Blender gives an EXR it loads), whose map is
    Non-Color's, byte for byte, on every line. Now warned only where the map differs."""
    rc, err, data = _space_bake(tmp_path, space)
    rc0, err0, plain = _space_bake(tmp_path, "Non-Color", name="plain")
    assert rc == rc0 == exit_codes.OK and "surfgrad: warning" not in err0, (err, err0)
    assert (data != plain) == converts
    said = f"surfgrad: warning: image 'n.exr' is read in colour space {space!r}"
    assert (said in err) == converts, err


@pytest.mark.skipif(not hasattr(bpy.data, "colorspace"), reason="no working space setting "
                    "before 5.0 (Linear Rec.709: the test above)")
def test_the_working_space_is_the_files_own(tmp_path):
    """5.0 and later: a file's working space is its own (File > Color Management). In one set
    to Linear Rec.2020 an image read in Linear Rec.2020 bakes Non-Color's map and is not
    warned; one read in Linear Rec.709 is converted, and warned."""
    _, _, plain = _space_bake(tmp_path, "Non-Color", "Linear Rec.2020", name="plain")
    rc, err, data = _space_bake(tmp_path, "Linear Rec.2020", "Linear Rec.2020")
    assert rc == exit_codes.OK and data == plain and "surfgrad: warning" not in err, err
    rc, err, data = _space_bake(tmp_path, "Linear Rec.709", "Linear Rec.2020", name="b")
    assert rc == exit_codes.OK and data != plain, err
    assert "read in colour space 'Linear Rec.709'" in err, err


CUT = {".jpg": 0.9, ".tif": 0.5, ".rgb": 0.9}    # cuts that still load at full size (.rgb: 4.2)


def _picture(path):
    """A 64 x 64 normal map as a JPEG, TIFF or SGI image (by `path`'s suffix), written by
    Blender."""
    fmt = {".jpg": ("JPEG", "RGB"), ".tif": ("TIFF", "RGBA"), ".rgb": ("IRIS", "RGBA")}[
        path.suffix]
    _write_image(path, _normal_texels(64), fmt[0], color_mode=fmt[1])
    return path.read_bytes()


def _loaded(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    w, h = img.size
    px = np.empty(w * h * 4, np.float32)
    if w:
        img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)


def test_blender_loads_a_jpeg_cut_short_with_the_rest_grey(tmp_path):
    """The fact, every line: a JPEG cut at 90% of its bytes loads at full size, its last rows
    (the bottom of the picture: rows from v = 0) not the file's; Cycles bakes that. (A TIFF
    cut short loads at full size too, its missing strips left as memory held: measured as
    the rows of an image freed before, zeros, or other values, by line and run.)"""
    whole = _picture(tmp_path / "n.jpg")
    (tmp_path / "cut.jpg").write_bytes(whole[:int(len(whole) * CUT[".jpg"])])
    ref, cut = _loaded(tmp_path / "n.jpg"), _loaded(tmp_path / "cut.jpg")
    assert cut.shape == ref.shape == (64, 64, 4)
    wrong = np.abs(cut - ref).max(-1) > 0.02
    assert wrong[0].all() and not wrong[-1].any(), wrong.sum(1)
    assert 0.05 < wrong.mean() < 0.5, wrong.mean()
    grey = (np.abs(cut[0, :, :3] - 0.502) < 2e-3).all(-1)     # the grey libjpeg fills in
    assert grey.any(), cut[0, :, :3]


@pytest.mark.parametrize("suffix, tail", [(".jpg", "cut"), (".jpg", "whole"), (".jpg", "trailing"),
                                          (".tif", "cut"), (".tif", "whole"), (".rgb", "cut"),
                                          (".rgb", "whole")])
def test_a_picture_cut_short_is_refused(suffix, tail, tmp_path, capsys):
    """A JPEG, TIFF or SGI image normal map whose copy was cut short (CUT). Before: exit 0 and
    a map whose bottom rows came from texels the file does not hold (a JPEG: 1086 of 4096 off,
    on every line; an SGI image on 4.2, 512 of 4096; later lines do not open one, and said
    "damaged"). Now refused, naming the file and the fix. A whole file, and a JPEG
    with bytes after its end marker (appended metadata, as some cameras write), bake as
    before."""
    whole = _picture(tmp_path / f"w{suffix}")
    data = {"cut": whole[:int(len(whole) * CUT[suffix])], "whole": whole,
            "trailing": whole + b"\0appended metadata" * 8}[tail]
    (tmp_path / f"n{suffix}").write_bytes(data)
    rc, err = _bake(_scene(tmp_path / "e.blend", tmp_path / f"n{suffix}"), tmp_path / "m.png",
                    capsys)
    if tail != "cut":
        assert rc == exit_codes.OK and "cut short" not in err, err
        return
    lacks = {".jpg": "JPEG cut short (no end-of-image marker after its image data",
             ".tif": "TIFF cut short (its image data runs past the end of the file",
             ".rgb": "SGI image cut short (its image data runs past the end of the file"}[suffix]
    assert rc == exit_codes.BAD_REQUEST and not (tmp_path / "m.png").exists(), err
    assert (f"image 'n{suffix}' reads 'n{suffix}', a {lacks}: a copy or download interrupted): "
            f"Blender loads it at full size with the part missing filled in, which Cycles "
            f"would bake; copy or export the file again, whole") in err, err


@pytest.mark.parametrize("source", ["TILED", "SEQUENCE"])
def test_a_udim_tile_or_sequence_frame_jpeg_cut_short_is_refused(source, tmp_path, capsys):
    """The same for a tile the image's own load does not read (tile 1002) and for the frame
    file an Image Sequence reads."""
    tex = tmp_path / "tex"
    tex.mkdir()
    names = {"TILED": ("n.1001.jpg", "n.1002.jpg"), "SEQUENCE": ("seq.0002.jpg", "seq.0001.jpg")}
    whole = _picture(tex / names[source][0])
    (tex / names[source][1]).write_bytes(whole[:int(len(whole) * CUT[".jpg"])])
    first = tex / ("n.1001.jpg" if source == "TILED" else "seq.0001.jpg")
    blend = _source_scene(tmp_path / "s.blend", first, source, second_tile=True)
    (tmp_path / "out").mkdir()
    rc, err = _bake(blend, tmp_path / "out" / "m.<UDIM>.png", capsys)
    assert rc == exit_codes.BAD_REQUEST and list((tmp_path / "out").iterdir()) == [], err
    said = {"TILED": "image 'n.1001.jpg' reads 'n.1002.jpg', a JPEG cut short",
            "SEQUENCE": f"image sequence 'seq.0001.jpg' reads {str(first)!r}, a JPEG cut "
                        f"short"}[source]
    assert said in err, err


@pytest.mark.parametrize("texture", ["cut.jpg", "rg.exr", "missing.png"])
def test_freeze_refuses_the_images_a_bake_refuses(texture, tmp_path):
    """The Freeze operator's bake ran none of bake-normal-map's image checks: a stack reading a
    missing texture froze Cycles' magenta into the map, a JPEG cut short its grey rows, an R, G
    EXR a grey of R, each without a word. Now refused before anything changes, with the same
    words (the material keeps its nodes and no image is added)."""
    from support.materials import diffuse_material
    from surfgrad_addon import api
    from surfgrad_addon.addon import freeze
    from surfgrad_addon.harness import scenes as test_scenes
    whole = _picture(tmp_path / "w.jpg")
    (tmp_path / "cut.jpg").write_bytes(whole[:int(len(whole) * CUT[".jpg"])])
    _exr_of_channels(tmp_path / "rg.exr", _rg_planes())
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = test_scenes.build(["Plane"])["Plane"]
    bpy.context.view_layer.objects.active = obj
    mat, tree, bsdf = diffuse_material("M")
    tex = tree.nodes.new("ShaderNodeTexImage")
    if texture == "missing.png":
        tex.image = bpy.data.images.new(texture, 4, 4)
        tex.image.source, tex.image.filepath = "FILE", str(tmp_path / texture)
    else:
        tex.image = bpy.data.images.load(str(tmp_path / texture))
    tex.image.colorspace_settings.name = "Non-Color"
    sg, resolve = (tree.nodes.new("ShaderNodeGroup") for _ in range(2))
    sg.node_tree, resolve.node_tree = api.node_group("SG Normal Map"), api.node_group("SG Resolve")
    tree.links.new(tex.outputs["Color"], sg.inputs["Color"])
    tree.links.new(sg.outputs["Surface Gradient"], resolve.inputs["Surface Gradient"])
    tree.links.new(resolve.outputs["Normal"], bsdf.inputs["Normal"])
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    nodes, images = len(tree.nodes), len(bpy.data.images)
    said = {"cut.jpg": "image 'cut.jpg' reads 'cut.jpg', a JPEG cut short",
            "rg.exr": "image 'rg.exr' holds two colour channels in its file",
            "missing.png": f"image 'missing.png' reads {str(tmp_path / texture)!r}, which does "
                           f"not exist: Cycles would bake its magenta"}[texture]
    with pytest.raises(freeze.FreezeError, match=re.escape(said)):
        freeze.freeze(obj, resolution=16)
    assert len(tree.nodes) == nodes and len(bpy.data.images) == images
    assert freeze.frozen_record(mat) is None


def _group_around(inner_tree, name):
    """A shader group `name` holding a Normal Map node (or, if `inner_tree` is given, a group
    node of it) between its Color input and Normal output."""
    g = bpy.data.node_groups.new(name, "ShaderNodeTree")
    g.interface.new_socket("Color", in_out="INPUT", socket_type="NodeSocketColor")
    g.interface.new_socket("Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
    gi, go = g.nodes.new("NodeGroupInput"), g.nodes.new("NodeGroupOutput")
    if inner_tree is None:
        mid = g.nodes.new("ShaderNodeNormalMap")
    else:
        mid = g.nodes.new("ShaderNodeGroup")
        mid.node_tree = inner_tree
    g.links.new(gi.outputs[0], mid.inputs[0] if inner_tree else mid.inputs["Color"])
    g.links.new(mid.outputs[0] if inner_tree else mid.outputs["Normal"], go.inputs[0])
    return g


@pytest.mark.parametrize("depth, space", [(1, "sRGB"), (2, "sRGB"), (2, "Non-Color")])
def test_a_normal_map_read_through_a_node_group_is_warned_about(depth, space, tmp_path,
                                                                capsys):
    """An Image Texture outside a group (the artist's own "My Normal" wrapper, one or two
    levels deep) whose Normal Map node is inside. Before: an sRGB normal map baked bent with
    exit 0 and no warning (the warnings followed reroutes only). Now the warning names the
    node inside the group; a Non-Color one still says nothing."""
    from support.materials import diffuse_material
    _write_image(tmp_path / "n.png", _normal_texels())
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    mat, tree, bsdf = diffuse_material("Mat")
    group = _group_around(None, "Inner")
    if depth == 2:
        group = _group_around(group, "Outer")
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(tmp_path / "n.png"))
    tex.image.colorspace_settings.name = space
    tree.links.new(tex.outputs["Color"], node.inputs[0])
    tree.links.new(node.outputs[0], bsdf.inputs["Normal"])
    bpy.context.object.data.materials.append(mat)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "g.blend"), compress=False)
    rc, err = _bake(tmp_path / "g.blend", tmp_path / "m.png", capsys)
    assert rc == exit_codes.OK, err
    inside = {1: "Group > Normal Map", 2: "Group > Group > Normal Map"}[depth]
    said = (f"surfgrad: warning: image 'n.png' is read in colour space 'sRGB' by Normal Map "
            f"node {inside!r} (material 'Mat')")
    assert (said in err) == (space == "sRGB"), err
    assert ("surfgrad: warning" in err) == (space == "sRGB"), err


@pytest.mark.parametrize("names, kind", [("Z", "Z"), ("y", "y"), ("a,y", "y and a")])
def test_an_exr_of_channels_blender_does_not_read_as_colour_is_refused(names, kind, tmp_path,
                                                                        capsys):
    """A lone Z (a depth pass saved as a height map), a lower case y, a lower case y with a:
    Cycles renders one of them as a grey, what the checks read is 0 (4.2), uninitialised
    memory (4.5, 5.0: measured -8e14) or, for y and a on 5.2, 0. Before: baked with exit 0
    and no word (the header check called the set unknown). Now refused, as an alpha alone."""
    t = _normal_texels()
    _exr_of_channels(tmp_path / "n.exr", {n: t[..., i] for i, n in enumerate(names.split(","))})
    rc, err = _bake(_scene(tmp_path / "e.blend", tmp_path / "n.exr"), tmp_path / "m.png",
                    capsys)
    assert rc == exit_codes.BAD_REQUEST and not (tmp_path / "m.png").exists(), err
    assert (f"image 'n.exr' holds no colour channel Blender reads in its file (n.exr: {kind} "
            f"EXR): Cycles renders one of its channels as a grey") in err, err
