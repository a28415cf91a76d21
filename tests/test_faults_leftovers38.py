"""Fault injection, red team 38b: leftovers earlier rounds noticed and left.

- `api.bake_normal_map(..., log=callback)` whose callback raised on the '[3/3] wrote' line:
  the caller got BakeFailed "the bake of 'Plane' failed: ..." while the complete map was on
  disk. Now the callback's own exception reaches the caller as raised (at any step: before
  the map is in place no file is left), and after the write it carries a note that the map
  is written and complete.
- `api.node_group(..., filter_width=np.float32(2))`: refused "give a positive number" while
  numpy integers are taken elsewhere; now numpy floats are taken where floats are.
- bake-batch given an Empty that instances a collection said only "is an empty, not a mesh";
  bake-normal-map names the collection and its meshes. Now the batch says the same.
- bake-batch `--asset-index 0` with an asset list of only comments: "(0 to -1)".
- A UV map that only a modifier makes (Geometry Nodes' Store Named Attribute), given as the
  bake's UV map: "has no UV map 'Proj'; it has ['UVMap']" though it renders. Now the message
  says Blender's bake needs it on the mesh data and how to get it there.
"""

import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402

LINE = facts_for(bpy.app.version)

pytestmark = pytest.mark.tier("bake")

SMALL = ["--resolution", "16", "--samples", "1", "--margin", "0"]


def _plane(bpy):
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.active_object
    obj.data.materials.append(new_material("M"))
    return obj


def test_a_log_callback_error_is_the_callers_and_says_the_map_is_written(fresh, tmp_path):
    """The callback raises on each of the bake's steps in turn. Before: at '[3/3] wrote' the
    call raised BakeFailed 'the bake of ... failed' with the complete map on disk. Now the
    callback's RuntimeError comes back as itself; raised before the map is placed, no file
    is left; raised after, the map is there, complete, and the error's note says so."""
    obj = _plane(fresh)
    for step in ("[2/3]", "[3/3]"):
        folder = tmp_path / step[1]
        folder.mkdir()
        out = folder / "n.png"

        def log(line):
            if line.startswith(step):
                raise RuntimeError("log sink closed")
        with pytest.raises(RuntimeError) as caught:
            api.bake_normal_map(obj, out, resolution=16, samples=1, margin=0, log=log)
        assert str(caught.value) == "log sink closed"
        assert "failed" not in str(caught.value)
        notes = getattr(caught.value, "__notes__", [])
        if step == "[2/3]":
            assert os.listdir(folder) == [] and notes == []
        else:
            assert os.listdir(folder) == ["n.png"]
            assert notes == [f"surfgrad: raised by the log callback after the bake; the map is "
                             f"written and complete: {out}"]
            image = fresh.data.images.load(str(out))
            px = np.array(image.pixels[:]).reshape(16, 16, 4)
            fresh.data.images.remove(image)
            assert np.abs(px[..., :3] - [0.5, 0.5, 1.0]).max() < 2 / 255   # flat: +Z


@pytest.mark.tier("blender")
def test_numpy_float_filter_widths_are_taken_as_floats(fresh):
    """np.float32(2) was refused "give a positive number"; a NaN one is still refused."""
    tree = api.node_group("SG Height Map Forward", filter_width=np.float32(2))
    widths = [n.inputs["Filter Width"].default_value for n in tree.nodes
              if n.bl_idname == "ShaderNodeBump" and "Filter Width" in n.inputs]
    assert widths == [2.0] * len(widths)
    assert len(widths) == (1 if LINE.bump_filter_width else 0)   # (4.2's Bump has none)
    with pytest.raises(ValueError, match="give a positive number"):
        api.node_group("SG Height Map Forward", filter_width=np.float32("nan"))


def test_bake_batch_of_an_empty_showing_a_collection_names_its_meshes(tmp_path, capsys):
    """An asset placed as a collection instance, picked by its Empty. Before: "object 'Holder'
    is an empty, not a mesh: pick mesh objects". Now it names the collection and its meshes,
    as bake-normal-map does; exit 1, no map."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16,
                           collection="Kit")
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    holder = bpy.data.objects.new("Holder", None)
    holder.instance_type = "COLLECTION"
    holder.instance_collection = bpy.data.collections["Kit"]
    bpy.context.scene.collection.objects.link(holder)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    out = tmp_path / "out"
    capsys.readouterr()
    rc = commands.execute(["bake-batch", f"{blend}:Holder", "--output",
                           str(out / "{object}.png"), "--workers", "0"] + SMALL)
    err = capsys.readouterr().err
    assert rc == 1, err
    assert ("object 'Holder' is an empty, not a mesh: pick mesh objects; it shows collection "
            "'Kit', whose mesh object(s) ['Rock'] are what to bake") in err, err
    assert not out.exists() or not list(out.glob("*.png"))


@pytest.mark.tier("numpy")
def test_an_asset_index_into_an_empty_list_says_the_list_is_empty(tmp_path, capsys):
    listed = tmp_path / "assets.txt"
    listed.write_text("# nothing yet\n\n")
    rc = commands.execute(["bake-batch", "--asset-list", str(listed), "--asset-index", "0",
                           "--output", str(tmp_path / "o" / "{object}.png")])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST
    assert err.strip().splitlines()[-1].endswith(
        f"asset index 0: the list {listed} has no entries: add one .blend path a line"), err
    # (the temporary folder's "pytest-1NNN" holds a "-1" of its own)
    assert "-1" not in err.replace(str(tmp_path), "") and not (tmp_path / "o").exists()


def _modifier_uv_plane(bpy, name="Proj"):
    """A plane whose Geometry Nodes modifier stores a 2D corner attribute `name`: a UV map of
    the rendered mesh only."""
    obj = _plane(bpy)
    ng = bpy.data.node_groups.new("MakeUV", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    gi, go = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
    store = ng.nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "FLOAT2", "CORNER"
    store.inputs["Name"].default_value = name
    ng.links.new(gi.outputs[0], store.inputs["Geometry"])
    ng.links.new(ng.nodes.new("GeometryNodeInputPosition").outputs[0], store.inputs["Value"])
    ng.links.new(store.outputs[0], go.inputs[0])
    obj.modifiers.new("GN", "NODES").node_group = ng
    return obj


MODIFIER_UV = ("object 'Plane' has UV map 'Proj' only from a modifier; Blender's bake needs the "
               "UV map on the mesh data: apply the modifier (Object > Apply), or add a UV map "
               "of that name to the mesh (Object Data > UV Maps) and unwrap it")


@pytest.mark.tier("blender")
def test_a_uv_map_only_a_modifier_makes_is_refused_saying_how_to_bake_it(fresh, tmp_path):
    """Before: "has no UV map 'Proj'; it has ['UVMap']" though the render has it. The batch
    planner (from its scan) says the same. Nothing written."""
    from surfgrad_addon.addon.batch import plan, session
    obj = _modifier_uv_plane(fresh)
    evaluated = obj.evaluated_get(fresh.context.evaluated_depsgraph_get()).data
    assert "Proj" in evaluated.uv_layers and "Proj" not in obj.data.uv_layers
    with pytest.raises(ValueError) as caught:
        api.bake_normal_map(obj, tmp_path / "n.png", resolution=16, uv_map="Proj", log=None)
    assert str(caught.value).endswith(MODIFIER_UV), caught.value
    scan = session.scan_open_file(["Plane"])["assets"][0]
    settings = dict(plan.DEFAULTS, uv_map="Proj")
    assert plan.asset_problem(scan, settings) == MODIFIER_UV
    assert list(tmp_path.iterdir()) == []


@pytest.mark.tier("blender")
def test_compare_reads_a_uint8_image_as_blender_reads_the_file(fresh):
    """harness compare(image=<uint8 array>) gave both sides the values 0..255 (the bake's
    image and the reference's pixels): they agreed, about a map no file holds. Now both
    take value / 255, as Blender reads the PNG."""
    from surfgrad_addon.harness.compare import prepare_inputs
    obj = _plane(fresh)
    rng = np.random.default_rng(5)
    png = rng.integers(0, 256, size=(8, 8, 3), dtype=np.uint8)
    inp = prepare_inputs(obj, image=png)
    reference, image = inp.images["normal"]
    blender = np.array(image.pixels[:], dtype=np.float64).reshape(8, 8, 4)[..., :3]
    expected = png.astype(np.float64) / 255.0
    assert np.abs(reference - expected).max() < 1e-7
    assert np.abs(blender - expected).max() < 1e-7


@pytest.mark.tier("blender")
def test_a_packed_udim_image_is_written_out_once_per_check(tmp_path, monkeypatch):
    """A packed 2-tile normal map, tile 1002 in -1..1. Before: the image check and the
    normal-map check each wrote every packed tile to a temporary file and loaded it (4-tile
    2048^2 float: 8 writes, 403 MB, 8.7-10.2 s a check on 5.2.3; now 4, 202 MB, 5.7-6.9 s).
    Now each tile is written once a check, the warning still names tile 1002, and no
    temporary file is left."""
    import pathlib
    import tempfile
    from test_faults_images35 import RANGE, _exr
    from test_faults_pipeline_more import _scene as _source_scene
    from surfgrad_addon.addon import bake_request as BR
    for tile in (1001, 1002):
        _exr(tmp_path / f"n.{tile}.exr", signed=tile == 1002)
    _source_scene(tmp_path / "s.blend", tmp_path / "n.1001.exr", "TILED", second_tile=True)
    bpy.data.images["n.1001.exr"].pack()
    temp = tmp_path / "temp"
    temp.mkdir()
    (tmp_path / "out").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    written = []
    write_bytes = pathlib.Path.write_bytes
    monkeypatch.setattr(pathlib.Path, "write_bytes",
                        lambda self, data: written.append(self.name) or write_bytes(self, data))
    checked = BR.check(BR.BakeRequest("Plane", str(tmp_path / "out" / "m.<UDIM>.png")),
                       warn=lambda message: None)
    assert sorted(written) == ["tile1001.exr", "tile1002.exr"]
    assert [w for w in checked.warnings if RANGE in w and "(tile 1002: its packed data)" in w]
    assert list(temp.iterdir()) == []
