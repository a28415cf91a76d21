"""Red team 39a: a studio's colour management and environment.

- A studio OCIO configuration (the `OCIO` variable) without Blender's "Non-Color" space (its
  data space named otherwise, "raw" here, as ACES and many studio configurations name it):
  every bake named "Non-Color" for the image it bakes into, which Blender refuses under another
  configuration (`enum "Non-Color" not found in ('dim', 'lin_rec709', 'raw', ...)`), on every
  line: bake-normal-map and compare ended in a raw TypeError traceback, exit 1; bake-batch
  failed every asset with it, exit 1; Freeze raised it.
  Now they take the configuration's data space (`is_data`), and write the values written
  under Blender's own configuration, whatever its views and looks. The warning about a normal
  map read as colour told the artist to pick Non-Color there; now it names the data space.
- An ASCII locale (LC_ALL=C with Python's UTF-8 mode off: PYTHONUTF8=0, as some farms' images
  set it): `python -m surfgrad_addon` refused a UTF-8 --object or batch entry as "not UTF-8"
  (exit 2; a batch entry 'k.blend:Kugel_ü' failed its asset, exit 1), and a batch of a file
  whose objects have non-ASCII names ended with "'ascii' codec can't encode character", exit
  2. Now the command runs again in UTF-8 mode, as Blender's own Python does (only in an ASCII
  locale: one in Latin-1 decodes what its terminal sends as it should).
- Output Properties > Color Management set to Override: a `--depth half` bake (and
  api.bake_normal_map in a session) put the mode back, and Blender, on every line, copied the
  scene's view into the override: its own view, look, exposure, gamma, curves and linear space
  were lost. Now the half EXR is saved through a scene of its own.
"""

import json

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support import colour_bakes  # noqa: E402
from support.child import ROOT, run_python  # noqa: E402

pytestmark = pytest.mark.tier("child")

# A studio configuration: its own names, data space "raw", a view and a look of its own.
STUDIO_OCIO = """ocio_profile_version: 2
search_path: ""
strictparsing: true
luma: [0.2126, 0.7152, 0.0722]
roles:
  default: srgb_tx
  reference: lin_rec709
  scene_linear: lin_rec709
  rendering: lin_rec709
  default_byte: srgb_tx
  default_float: lin_rec709
  default_sequencer: srgb_tx
  color_picking: srgb_tx
  data: raw
  texture_paint: srgb_tx
  matte_paint: srgb_tx
  compositing_log: srgb_tx
  color_timing: srgb_tx
displays:
  sRGB:
    - !<View> {name: Standard, colorspace: srgb_tx}
    - !<View> {name: Dim, colorspace: dim}
active_displays: [sRGB]
active_views: [Standard, Dim]
looks:
  - !<Look>
    name: Punchy
    process_space: lin_rec709
    transform: !<ExponentTransform> {value: [1.4, 1.4, 1.4, 1]}
colorspaces:
  - !<ColorSpace>
    name: lin_rec709
    isdata: false
  - !<ColorSpace>
    name: srgb_tx
    isdata: false
    from_scene_reference: !<ExponentWithLinearTransform>
      {gamma: 2.4, offset: 0.055, direction: inverse}
  - !<ColorSpace>
    name: dim
    isdata: false
    from_scene_reference: !<ExponentTransform> {value: [2.0, 2.0, 2.0, 1], direction: inverse}
  - !<ColorSpace>
    name: raw
    isdata: true
"""


def test_a_studio_colour_configuration_bakes_the_same_data(tmp_path):
    """Under the studio configuration: the 8-bit PNG and half EXR of bake-normal-map and the
    frozen 16-bit PNG hold the values baked under Blender's own configuration, read as data
    (before: a TypeError at the first bake), and compare holds a correct SG Normal Map
    within its bar (before: a TypeError)."""
    config = tmp_path / "studio" / "config.ocio"
    config.parent.mkdir()
    config.write_text(STUDIO_OCIO)
    child = run_python([ROOT / "tests" / "support" / "colour_bakes.py", tmp_path / "studio_maps"],
                       env={"OCIO": str(config)}, timeout=240)
    assert child.returncode == 0, child.stderr[-3000:]
    studio = json.loads(child.stdout.strip().splitlines()[-1])
    assert "Non-Color" not in studio["spaces"] and "raw" in studio["spaces"]   # it took
    own = colour_bakes.bake_all(tmp_path / "own_maps")
    assert "Non-Color" in own["spaces"]
    for name in colour_bakes.FILES:
        theirs = colour_bakes.pixels(tmp_path / "studio_maps" / name)
        ours = colour_bakes.pixels(tmp_path / "own_maps" / name)
        assert ours.std(axis=0).min() > 0.01, name       # a bent map, not a flat one
        # Within one 16-bit step: the bake's floats round differently under another
        # configuration (1 of 768 values in frozen.png by 1 / 65535); a view, look or
        # colour space applied moves them by tenths (sRGB takes 0.5 to 0.735).
        np.testing.assert_allclose(theirs, ours, rtol=0, atol=1.01 / 65535, err_msg=name)
    assert studio["frozen_is_data"] is True and own["frozen_is_data"] is True
    assert studio["compared"] == own["compared"] > 150
    assert studio["p99"] <= 0.1 and studio["max"] <= 0.5, studio
    # The fix a warning names is a colour space the artist has.
    assert [w.split("; ")[-1] for w in studio["warnings"]] == [
        "set the image's Color Space to raw (Image Texture node, or the Image Editor's sidebar)"]
    assert own["warnings"][0].endswith("set the image's Color Space to Non-Color (Image "
                                       "Texture node, or the Image Editor's sidebar)")
    assert "'srgb_tx'" in studio["warnings"][0] and "'sRGB'" in own["warnings"][0]


def test_an_ascii_locale_bakes_objects_named_in_utf8(tmp_path):
    """`LC_ALL=C PYTHONUTF8=0 python -m surfgrad_addon bake-batch 'k.blend:Kugel_ü' ...`:
    the asset is baked into 'Kugel_ü.png' (its UTF-8 name), exit 0, the same map as baked
    here; the progress line names it."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=8, ring_count=6, calc_uvs=True)
    obj = bpy.context.active_object
    obj.name = "Kugel_ü"
    obj.data.uv_layers[0].name = "UVMap"
    from support.materials import diffuse_material
    obj.data.materials.append(diffuse_material("M")[0])
    blend = tmp_path / "kugel_ü.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    from surfgrad_addon import api
    api.bake_normal_map(obj, str(tmp_path / "here.png"), space="object", resolution=16,
                        log=None)
    out = tmp_path / "maps"
    child = run_python(["-m", "surfgrad_addon", "bake-batch", f"{blend}:Kugel_ü", "--output",
                        str(out / "{object}.png"), "--workers", "0", "--resolution", "16",
                        "--space", "object"],
                       env={"LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0",
                            "PYTHONCOERCECLOCALE": "0"}, timeout=240)
    assert child.returncode == 0, child.stderr[-3000:]
    assert "baked kugel_ü.blend:Kugel_ü" in child.stdout
    assert sorted(p.name for p in out.iterdir()) == ["Kugel_ü.png",
                                                     "surfgrad-bake-manifest.json"]
    np.testing.assert_array_equal(colour_bakes.pixels(out / "Kugel_ü.png"),
                                  colour_bakes.pixels(tmp_path / "here.png"))


def _output_colour(scene):
    """The Output properties' colour management: mode, and the override's own settings."""
    s = scene.render.image_settings
    curve = s.view_settings.curve_mapping.curves[3]
    return (s.color_management, s.view_settings.view_transform, s.view_settings.look,
            s.view_settings.exposure, s.view_settings.gamma, s.view_settings.use_curve_mapping,
            tuple(tuple(p.location) for p in curve.points),
            s.display_settings.display_device, s.linear_colorspace_settings.name)


@pytest.mark.tier("bake")
def test_a_half_exr_bake_keeps_the_output_colour_override(tmp_path):
    """Output Properties > Color Management set to Override (its own view, look, exposure,
    gamma, curves and linear space, as a studio sets it for its EXR renders): a --depth half
    bake puts its scene's settings back. Before, on every line: back to Override, but with the
    scene's view copied in (AgX / Punchy / -3 / 0.5 / Linear Rec.2020 became the scene's
    Standard / None / 0 / 1 / Linear Rec.709, curves off), the user's Output settings lost;
    saved with the file from the API or a session. The map is the same as without the
    override."""
    from surfgrad_addon import api
    from support.materials import diffuse_material
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=8, ring_count=6, calc_uvs=True)
    obj = bpy.context.active_object
    obj.data.uv_layers[0].name = "UVMap"
    obj.data.materials.append(diffuse_material("M")[0])
    scene = bpy.context.scene
    scene.view_settings.view_transform = "Standard"
    api.bake_normal_map(obj, str(tmp_path / "plain.exr"), space="object", resolution=16,
                        depth="half", log=None)
    s = scene.render.image_settings
    s.color_management = "OVERRIDE"
    s.view_settings.view_transform = "AgX"
    s.view_settings.look = "AgX - Punchy"
    s.view_settings.exposure = -3.0
    s.view_settings.gamma = 0.5
    s.view_settings.use_curve_mapping = True
    s.view_settings.curve_mapping.curves[3].points[0].location = (0.0, 0.25)
    s.linear_colorspace_settings.name = "Linear Rec.2020"
    before = _output_colour(scene)
    assert before[1:3] != (scene.view_settings.view_transform, scene.view_settings.look)
    api.bake_normal_map(obj, str(tmp_path / "override.exr"), space="object", resolution=16,
                        depth="half", log=None)
    assert _output_colour(scene) == before
    np.testing.assert_array_equal(colour_bakes.pixels(tmp_path / "override.exr"),
                                  colour_bakes.pixels(tmp_path / "plain.exr"))
