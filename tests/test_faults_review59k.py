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
2. normal_bake.no_tile_problem (27651ab), for a UV map with no area, named any other UV map
   with area as the other fix, where the bake then refused it: a Geometry Nodes modifier's
   map ('UVGen', stored on face corners: "has UV map 'UVGen' only from a modifier", exit 2),
   a map whose name is longer than the bake takes (66 bytes: refused so), a map with area
   only outside the UDIM range (u, v -0.9..-0.1: "has no faces in any UDIM tile", exit 2).
   Three runs for one fault, each the advice of the last. Now only a map on the mesh data,
   with a name the bake takes and faces in a UDIM tile, is named (a plain second unwrapped
   map still is, and bakes).
3. compare --image (harness_api.compare(..., image=path)) interrupted (Ctrl-C, a kernel's
   interrupt) while its image was read: rt59j's removal covers the images once
   prepare_inputs holds them, but _load_image's own load was not: reading a 4096^2 PNG takes
   2.0 s (load, foreach_get, finite check), and KeyboardInterrupt there left the image
   ('n.png', 0 users) in the TD's bpy.data, one per interrupted call. Now removed on any
   exception (compare._load_image).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes, normal_map_checks  # noqa: E402
from surfgrad_addon.harness import api as harness_api  # noqa: E402
from surfgrad_addon.reference import input_checks  # noqa: E402
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


def _gn_uv_map(obj, name):
    """A Geometry Nodes modifier storing `name` on face corners (2D): position + (0.5, 0.5)."""
    ng = bpy.data.node_groups.new("G", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    gi, go = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
    store = ng.nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "FLOAT2", "CORNER"
    store.inputs["Name"].default_value = name
    add = ng.nodes.new("ShaderNodeVectorMath")
    add.inputs[1].default_value = (0.5, 0.5, 0.0)
    ng.links.new(ng.nodes.new("GeometryNodeInputPosition").outputs[0], add.inputs[0])
    ng.links.new(add.outputs[0], store.inputs["Value"])
    ng.links.new(gi.outputs[0], store.inputs["Geometry"])
    ng.links.new(store.outputs[0], go.inputs[0])
    obj.modifiers.new("GN", "NODES").node_group = ng


LONG = "L" * 66                                 # over the bake's 63 bytes, a UV map takes it


def _second_map(obj, kind):
    me = obj.data
    if kind == "modifier":
        _gn_uv_map(obj, "Second")
        return
    quad = {"outside": [(-0.9, -0.9), (-0.1, -0.9), (-0.1, -0.1), (-0.9, -0.1)],
            "long": [(0, 0), (1, 0), (1, 1), (0, 1)], "plain": [(0, 0), (1, 0), (1, 1), (0, 1)]}
    layer = me.uv_layers.new(name=LONG if kind == "long" else "Second")
    assert layer is not None and len(me.polygons) == 1
    layer.data.foreach_set("uv", np.array(quad[kind], np.float32).ravel())
    me.uv_layers.active = me.uv_layers["UVMap"]


@pytest.mark.tier("bake")                       # (the plain map's fix is baked)
@pytest.mark.parametrize("kind, named", [("modifier", False), ("long", False),
                                         ("outside", False), ("plain", True)])
def test_a_collapsed_map_names_only_another_map_the_bake_can_use(kind, named, tmp_path, capsys):
    path = tmp_path / "n.png"
    _write_image(path, _normal_texels())
    blend = tmp_path / "s.blend"
    _scene(blend, path)
    obj = bpy.data.objects["Plane"]
    uv = obj.data.uv_layers["UVMap"]
    uv.data.foreach_set("uv", np.zeros(len(uv.data) * 2, np.float32))   # collapsed
    _second_map(obj, kind)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "m.png"
    args = ["bake-normal-map", "--blend", str(blend), "--object", "Plane", "--output",
            str(out), "--resolution", "16", "--samples", "1"]
    rc = commands.execute(args)
    err = capsys.readouterr().err
    assert rc != exit_codes.OK and "'UVMap' of object 'Plane' has no area" in err, err
    assert ("which has area" in err) == named, err
    if named:                                   # the fix named works
        rc = commands.execute(args + ["--uv-map", "Second"])
        assert rc == exit_codes.OK and out.exists(), capsys.readouterr().err


def _interrupt(*_args, **_kwargs):
    raise KeyboardInterrupt


def test_compare_interrupted_while_its_image_is_read_leaves_none(fresh, monkeypatch, tmp_path):
    path = tmp_path / "n.png"
    _write_image(path, _normal_texels(32))
    fresh.ops.mesh.primitive_plane_add()
    monkeypatch.setattr(input_checks, "pixels_problem", _interrupt)     # as the map is read
    with pytest.raises(KeyboardInterrupt):
        harness_api.compare(fresh.context.object, "normal-map", resolution=16, image=path)
    assert sorted(i.name for i in bpy.data.images) == []                # before: ['n.png']
