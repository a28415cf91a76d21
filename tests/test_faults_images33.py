"""Red team 33: EXR channel sets whose loaded colours the header check misjudged. Measured on
4.2, 4.5, 5.0 and 5.2 by loading hand-written files (tests/test_exr_channels.py's method):
- alpha and no channel Blender loads as colour (`A` alone, `Z` and `A`): R, G and B are 0 on
  4.2 and left uninitialised on 4.5 and later, as B of a two-colour EXR is
  (LineFacts.exr_two_colours_fill_zero; Cycles renders a grey of the alpha: red team 34). The check read the file as "no colour we know" and
  said nothing, so a bake of it differed from run to run (NaN, 3e34, the previous load's pixels);
- lower case names (`r`, `g`): Blender matches R, G, B, A, X and Z in either case, so `r` and `g`
  are a two-colour EXR; the check, case-sensitive, let it bake (B uninitialised);
- `X`, `Y` and `Z` load into R, G and B; the check took the `Y` for grey and warned that every
  normal leans along (1, 1) (a false warning);
- a multilayer EXR reads 0 x 0 through bpy though Cycles renders it: it was refused as damaged."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.image_headers import file_channels  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_pipeline_leftovers import (_exr_of_channels, _normal_texels,  # noqa: E402
                                            _scene)

pytestmark = pytest.mark.tier("bake")
LINE = facts_for(bpy.app.version)


def _planes(names):
    """{name: plane} for `names` (one letter each; X, Y, Z stand for R, G, B, a for A)."""
    t = _normal_texels()
    src = {"R": t[..., 0], "G": t[..., 1], "B": t[..., 2], "A": t[..., 3] * 0.5,
           "X": t[..., 0], "Y": t[..., 1], "Z": t[..., 2]}
    return {n: src[n.upper()] for n in names}


def _pixels(path):
    img = bpy.data.images.load(str(path))
    px = np.empty(len(img.pixels), np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4)


def _bake(blend, output, capsys):
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(output), "--resolution", "16"])
    return rc, capsys.readouterr().err


@pytest.mark.parametrize("names, unfilled", [("A", "RGB"), ("AZ", "RGB"), ("rg", "B"),
                                             ("rga", "B")])
def test_colours_blender_does_not_fill_are_the_line_fact(names, unfilled, tmp_path):
    """The loaded channels the file lacks are 0 on 4.2 and not set on later lines: between
    loads, an RGB file of the same size is loaded, and its pixels are what they then hold."""
    planes = _planes(names)
    _exr_of_channels(tmp_path / "odd.exr", planes)
    _exr_of_channels(tmp_path / "full.exr", _planes("RGB"))
    with open(tmp_path / "odd.exr", "rb") as f:
        assert file_channels(f).unfilled == unfilled
    idle = ["RGB".index(c) for c in unfilled]
    for _ in range(3):
        _pixels(tmp_path / "full.exr")
        px = _pixels(tmp_path / "odd.exr")
        for name, plane in planes.items():       # R, G, A of the file are where they belong
            if name.upper() not in "RGBA":
                continue                        # Z: not loaded
            c = "RGBA".index(name.upper())
            assert np.allclose(px[:, c], plane.ravel(), atol=2e-3), (names, name)
        zero = np.array_equal(px[:, idle], np.zeros_like(px[:, idle]))
        assert zero == LINE.exr_two_colours_fill_zero, (LINE.line, px[:2])


@pytest.mark.parametrize("names", ["A", "AZ"])
def test_a_bake_from_an_exr_with_alpha_and_no_colour_is_refused_on_every_line(
        names, tmp_path, capsys):
    """Before: exit 0 and a map of whatever memory held (4.5 and later). Now refused, naming
    the file and the fix, on every line: Cycles renders a grey of its alpha (4.2 baked it
    with a warning that R, G and B read 0: red team 34, tests/test_faults_images34.py)."""
    _exr_of_channels(tmp_path / "n.exr", _planes(names))
    blend = _scene(tmp_path / "e.blend", tmp_path / "n.exr")
    rc, err = _bake(blend, tmp_path / "m.png", capsys)
    kind = {"A": "A", "AZ": "A and Z"}[names]
    assert rc == exit_codes.BAD_REQUEST and not (tmp_path / "m.png").exists(), err
    assert (f"image 'n.exr' holds no colour channel Blender reads in its file (n.exr: {kind} "
            f"EXR): Cycles renders one of its channels as a grey, but what Blender shows the "
            f"checks differs by line") in err, err


def test_a_lower_case_two_colour_exr_is_judged_as_its_upper_case_twin(tmp_path, capsys):
    """`r` and `g`: before, baked without a word (B uninitialised on 4.5 and later, 0 on 4.2).
    Now what `R` and `G` get: refused."""
    _exr_of_channels(tmp_path / "n.exr", _planes("rg"))
    rc, err = _bake(_scene(tmp_path / "e.blend", tmp_path / "n.exr"), tmp_path / "m.png",
                    capsys)
    assert rc == exit_codes.BAD_REQUEST, err
    assert ("image 'n.exr' holds two colour channels in its file (n.exr: r and g EXR): "
            f"Blender {LINE.line} shows them in R and G with B "
            f"{'0' if LINE.exr_two_colours_fill_zero else 'uninitialised'}") in err, err


@pytest.mark.parametrize("names", ["XYZ", "xyz"])
def test_an_xyz_exr_loads_as_rgb_and_bakes_without_a_grey_warning(names, tmp_path, capsys):
    """Before: `surfgrad: warning: ... holds 3 channels ... (X and Y (grey) and Z EXR):
    Blender spreads the grey ...`, yet Blender loads X, Y, Z into R, G, B: the map is the
    RGB file's, texel for texel. Now no warning."""
    planes = _planes(names)
    _exr_of_channels(tmp_path / "n.exr", planes)
    _exr_of_channels(tmp_path / "rgb.exr", _planes("RGB"))
    px = _pixels(tmp_path / "n.exr")
    for c, name in enumerate(names):
        assert np.allclose(px[:, c], planes[name].ravel(), atol=2e-3), name
    rc, err = _bake(_scene(tmp_path / "x.blend", tmp_path / "n.exr"), tmp_path / "x.png",
                    capsys)
    assert rc == exit_codes.OK and "surfgrad: warning" not in err, err
    rc, err = _bake(_scene(tmp_path / "c.blend", tmp_path / "rgb.exr"), tmp_path / "c.png",
                    capsys)
    assert rc == exit_codes.OK, err
    assert (tmp_path / "x.png").read_bytes() == (tmp_path / "c.png").read_bytes()


def _emitted(image_path):
    """What Cycles renders from `image_path` (an EMIT bake of its colour, 16 x 16), with none
    of surfgrad's checks in the way."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    mat, tree, bsdf = diffuse_material("M")
    tree.nodes.remove(bsdf)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(image_path))
    tex.image.colorspace_settings.name = "Non-Color"
    emit = tree.nodes.new("ShaderNodeEmission")
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree.links.new(tex.outputs["Color"], emit.inputs["Color"])
    tree.links.new(emit.outputs[0], out.inputs["Surface"])
    target = tree.nodes.new("ShaderNodeTexImage")
    target.image = bpy.data.images.new("t", 16, 16, float_buffer=True)
    tree.nodes.active = target
    bpy.context.object.data.materials.append(mat)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.device = "CPU"
    bpy.ops.object.bake(type="EMIT")
    px = np.empty(16 * 16 * 4, np.float32)
    target.image.pixels.foreach_get(px)
    return px


def test_a_multilayer_exr_is_not_called_damaged(tmp_path, capsys):
    """A multilayer EXR (channels `ViewLayer.Combined.R` ..., as Blender's renders write):
    Cycles renders its pass, texel for texel the single-layer file's, but its image reads 0 x 0
    through bpy. Before: refused as `could not be read (damaged, or a format Blender does not
    open): re-save it as PNG or EXR` (it is an EXR, and not damaged). Now refused naming what
    it is: its pixels cannot be checked here."""
    t = _normal_texels()
    _exr_of_channels(tmp_path / "ml.exr", {f"ViewLayer.Combined.{c}": t[..., i]
                                           for i, c in enumerate("RGBA")})
    _exr_of_channels(tmp_path / "rgb.exr", {c: t[..., i] for i, c in enumerate("RGBA")})
    emitted = _emitted(tmp_path / "ml.exr")
    assert np.array_equal(emitted, _emitted(tmp_path / "rgb.exr"))
    assert abs(float(emitted.reshape(-1, 4)[:, 2].mean()) - float(t[..., 2].mean())) < 0.02
    rc, err = _bake(_scene(tmp_path / "m.blend", tmp_path / "ml.exr"), tmp_path / "m.png",
                    capsys)
    assert rc == exit_codes.BAD_REQUEST and not (tmp_path / "m.png").exists(), err
    assert ("image 'ml.exr' ('//ml.exr') is a multilayer OpenEXR: Cycles bakes the layer and "
            "pass its Image Texture node picks, but surfgrad cannot read those pixels") in err
    assert "damaged" not in err, err


def test_a_multilayer_udim_tile_or_frame_is_not_called_damaged(tmp_path):
    """The same for the files a tiled image or a sequence reads beyond its first (each loaded
    into a probe image by image_checks.file_problem)."""
    from surfgrad_addon.addon import image_checks
    t = _normal_texels()
    path = tmp_path / "n.1002.exr"
    _exr_of_channels(path, {f"ViewLayer.Combined.{c}": t[..., i] for i, c in enumerate("RGBA")})
    said = image_checks.file_problem("tiled image 'n' (tile 1002)", path)
    assert said.startswith(f"tiled image 'n' (tile 1002) reads {str(path)!r}, which is a "
                           f"multilayer OpenEXR: Cycles bakes the layer and pass"), said


@pytest.mark.tier("child")
def test_a_multilayer_exr_cut_short_is_refused_without_a_load(tmp_path):
    """4.2 never returned from loading a multilayer EXR cut short (bpy.data.images.load of it
    hangs there): a bake of a file whose texture was cut so (a copy interrupted on the share)
    hung the farm job silently. Every line refuses a multilayer file anyway, so the checks read
    its header and never load it: one line, exit 2, no map, on every line. (Run in a child
    with a time limit: a hang fails the test instead of the suite.)"""
    from support.child import run_python
    t = _normal_texels()
    path = tmp_path / "ml.exr"
    _exr_of_channels(path, {f"ViewLayer.Combined.{c}": t[..., i] for i, c in enumerate("RGBA")})
    blend = _scene(tmp_path / "m.blend", path)           # whole while the scene is made
    path.write_bytes(path.read_bytes()[:400])
    res = run_python(["-m", "surfgrad_addon", "bake-normal-map", "--blend", str(blend),
                      "--object", "Plane", "--output", str(tmp_path / "m.png"),
                      "--resolution", "16"], timeout=120)
    assert res.returncode == exit_codes.BAD_REQUEST, res.stdout[-2000:] + res.stderr[-2000:]
    assert "is a multilayer OpenEXR" in res.stderr and "Traceback" not in res.stderr, res.stderr
    assert not (tmp_path / "m.png").exists()
    from surfgrad_addon.addon import image_checks
    said = image_checks.file_problem("tiled image 'n' (tile 1002)", path)
    assert "is a multilayer OpenEXR" in said, said
