"""Red team 41: bad texel values in the float normal maps a bake or compare reads.

Measured with 16^2 bakes of a float EXR normal map whose middle 8 x 8 texels were set to one
value in R, G and B, read by a Normal Map node or SG Normal Map (and SG Triplanar, SG Height
Map Forward, the same):
- 50 (any finite value above 1): exit 0 and no word; those normals tilted as the value points
  (55 deg). Only a map with a share of texels below 0 was warned about (as stored in -1..1).
  Now any texel above 1 in R, G or B of a float normal map is warned about, naming the image,
  the count and the largest value (Freeze's warnings are the same list).
- 1e30 or 3e38 (finite, so not refused as NaN and Inf are): a shader's float32 squares of them
  overflow to Inf. 5.0 and 5.2 and SG Normal Map on every line gave the flat normal there,
  4.2 and 4.5's Normal Map node a zero vector (written as 0.5 grey: not a normal; the line
  fact normal_map_replaces_non_finite); exit 0 with no word. `compare --image` with it
  reported a correct SG Normal Map 54.7 deg off (mean 17 deg; the float64 reference tilts as
  the value points), exit 0. Now values beyond 1e18 are refused as NaN and Inf are
  (reference/input_checks.OVERFLOWING), by the bake, Freeze and compare alike.
Left as they were, their normals finite and unit on every line: texels that decode to the zero
vector (Listing 2's clamp: no tilt) or point into the surface."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import exit_codes, normal_map_checks  # noqa: E402
from surfgrad_addon.harness import cli  # noqa: E402
from test_faults_images33 import _bake  # noqa: E402
from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image  # noqa: E402

pytestmark = pytest.mark.tier("bake")
ABOVE = ("has 64 of its 256 texels above 1 in R, G or B (up to 50): a normal map is read "
         "as 0..1")
BEYOND = ("has 192 pixel value(s) beyond +-1e+18 (up to 1e+30), which overflow a shader's "
          "float32 arithmetic to Inf")
NODES = {"ShaderNodeNormalMap": "Normal Map node 'Normal Map'",
         "SG Normal Map": "SG Normal Map node 'Group'"}


def _map(path, value=None):
    """A 16 x 16 float EXR normal map; its middle 8 x 8 texels `value` in R, G and B."""
    px = _normal_texels()
    if value is not None:
        px[4:12, 4:12, :3] = value
    _write_image(path, px, "OPEN_EXR", float_buffer=True, color_depth="32")
    return path


@pytest.mark.parametrize("via", sorted(NODES))
def test_a_normal_map_with_texels_above_one_is_warned_about_by_count(via, tmp_path, capsys):
    """Before: exit 0 and no warning. The map baked is still finite unit normals."""
    blend = _scene(tmp_path / "s.blend", _map(tmp_path / "big.exr", 50.0), via=via)
    out = tmp_path / "m.exr"
    rc, err = _bake(blend, out, capsys)
    assert rc == exit_codes.OK, err
    assert f"image 'big.exr', read by {NODES[via]} (material 'Mat'), {ABOVE}" in err, err
    assert err.count("above 1 in R, G or B") == 1, err
    img = bpy.data.images.load(str(out))
    try:
        n = np.asarray(img.pixels[:], np.float64).reshape(16, 16, 4)[..., :3] * 2 - 1
    finally:
        bpy.data.images.remove(img)
    assert np.isfinite(n).all()
    assert np.allclose(np.linalg.norm(n, axis=-1), 1, atol=1e-3)
    assert np.allclose(n[8, 8], np.full(3, 3 ** -0.5), atol=2e-3)   # tilted as (1, 1, 1)


def test_a_clean_map_is_not_warned_about_and_freeze_warns_the_same(tmp_path):
    """The add-on's list (Freeze reports it) has the line; a 0..1 map none."""
    for name, value, expected in (("clean.exr", None, []), ("big.exr", 50.0, [ABOVE])):
        _scene(tmp_path / "s.blend", _map(tmp_path / name, value), via="SG Normal Map")
        found = [w for w in normal_map_checks.input_warnings(bpy.data.objects["Plane"])
                 if "above 1" in w]
        assert [ABOVE for w in found if ABOVE in w] == expected, found


@pytest.mark.parametrize("via", sorted(NODES))
def test_a_map_whose_values_overflow_a_shader_is_refused(via, tmp_path, capsys):
    """Before: exit 0, flat normals there (a zero vector on 4.2 and 4.5 through the Normal
    Map node). Now refused before the bake, no file written."""
    blend = _scene(tmp_path / "s.blend", _map(tmp_path / "huge.exr", 1e30), via=via)
    out = tmp_path / "m.exr"
    rc, err = _bake(blend, out, capsys)
    assert rc == exit_codes.BAD_REQUEST, err
    assert BEYOND in err and "'huge.exr'" in err, err
    assert not out.exists()


def test_compare_refuses_an_image_whose_values_overflow_a_shader(tmp_path, capsys):
    """Before: exit 0, a correct SG Normal Map reported 54.7 deg off. Now refused, and no
    report written."""
    blend = _scene(tmp_path / "s.blend", _map(tmp_path / "huge.exr"), via="SG Normal Map")
    _map(tmp_path / "huge.exr", 1e30)
    capsys.readouterr()
    rc = cli.main(["compare", "--blend", str(blend), "--object", "Plane", "--method",
                   "normal-map", "--resolution", "16", "--image", str(tmp_path / "huge.exr"),
                   "--json", str(tmp_path / "c.json")])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert BEYOND in err, err
    assert not (tmp_path / "c.json").exists()


def test_the_normal_map_node_on_overflowing_texels_is_the_line_fact():
    """Why such a map is refused, not only warned about: Cycles' Normal Map node (tangent
    space) on texels of 1e30 gives the flat normal where LineFacts.normal_map_replaces_non_finite
    (5.0+), else a zero vector (4.2, 4.5): no normal either way, and not the float64 tilt."""
    from support import bake_probe as probe
    from surfgrad_addon.reference.blender_lines import facts_for
    probe.new_scene()
    pr = probe.EmissionProbe(probe.add_uv_plane())
    tex = pr.nodes.new("ShaderNodeTexImage")
    tex.image = probe.new_float_image("huge", 4, 4, np.full((4, 4, 4), 1e30, np.float32))
    tex.interpolation = "Closest"
    nm = pr.nodes.new("ShaderNodeNormalMap")
    nm.uv_map = "UVMap"
    pr.links.new(pr.uv.outputs["UV"], tex.inputs["Vector"])
    pr.links.new(tex.outputs["Color"], nm.inputs["Color"])
    out = pr.bake(nm.outputs["Normal"], 4, 4)[..., :3].reshape(-1, 3)
    flat = np.tile([0.0, 0.0, 1.0], (16, 1))
    expected = flat if facts_for(bpy.app.version).normal_map_replaces_non_finite else 0 * flat
    assert np.allclose(out, expected, atol=1e-6), out[0]
