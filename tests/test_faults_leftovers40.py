"""Red team 40a: leftovers round 39 noticed and left.

1. Freeze of an object whose Mesh Sequence Cache file (an Alembic or USD import's) is missing
   or unreadable: bake-normal-map refuses it (addon/cache_files.py, round 39d), Freeze did not
   run the check and froze the map of the mesh the import stored (a flat tile here, where the
   cache's frame 10 is bent), reporting success. Now refused the same way, the material
   unchanged. `compare` on such an object compared the stored mesh without a word; it now says
   so in a warning (report and log). Not refused: the bake and the reference read the same
   stored mesh, so the figures are right for the mesh compared; only the shape is not the one
   the asset renders with its cache.
2. An object whose name holds ".blend:" ("Rock.blend:v2", a name another tool's export made)
   in a bake-batch asset list: the entry was split at the last ".blend:", so the batch looked
   for the file "a.blend:Rock.blend" and failed the asset (exit 1), and such an object could
   not be named at all. Now the file is the text up to the first ".blend:" naming an existing
   file, else up to the first (batch/plan.split_entry; docs/pipelines.md).
3. A normal map's image wired into a Normal Map node (or an SG group) through a muted link:
   Cycles reads the socket's own value there (pinned here by a bake), but the normal-map
   warnings' walk back to the image (image_checks.texture_feeding) followed the muted link
   and warned about an image the bake never reads ("read in colour space 'sRGB'"). Now it
   follows the links Cycles follows (material_inputs.live_links, which Freeze uses too).
"""

import json

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon.batch import plan  # noqa: E402
from surfgrad_addon.addon.normal_map_checks import colour_space_warnings  # noqa: E402
from surfgrad_addon.addon.open_blend import open_mainfile  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_imports39 import USDA  # noqa: E402
from test_faults_materials39 import _cycles_plane, _emission_outputs  # noqa: E402
from test_faults_unseen_meshes32 import _grid, _object  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def test_freeze_and_compare_of_a_mesh_whose_cache_file_is_missing(tmp_path):
    usd = tmp_path / "anim.usda"
    usd.write_text(USDA)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=str(usd), relative_path=True)
    tile = bpy.data.objects["Tile"]
    tile.data.uv_layers[0].name = "UVMap"
    layered_material(tile)
    bpy.context.scene.frame_set(10)
    blend = tmp_path / "usd.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), relative_remap=True)
    usd.rename(tmp_path / "moved.usda")
    open_mainfile(str(blend))
    tile = bpy.data.objects["Tile"]
    before = material_dump(tile.active_material)
    with pytest.raises(F.FreezeError) as err:
        F.freeze(tile, resolution=16, log=lambda *_: None)
    text = str(err.value)
    assert "modifier 'MeshSequenceCache'" in text and "'//anim.usda'" in text, text
    assert "which is missing" in text and "Find Missing Files" in text, text
    assert material_dump(tile.active_material) == before and F.RECORD not in tile.active_material
    said = []
    report, _ = compare.compare_object(tile, "normal-map", 16, log=said.append)
    (warning,) = [w for w in report["warnings"] if "anim.usda" in w]
    assert "which is missing" in warning and "compared: the stored mesh" in warning, warning
    assert f"warning: {warning}" in said


def test_an_asset_list_names_an_object_whose_name_holds_dot_blend_colon(tmp_path, capsys):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    _object("Rock.blend:v2", [_grid(n=1)]).data.materials.append(diffuse_material("Mat")[0])
    odd = tmp_path / "odd.blend:x"                 # a folder whose name holds ".blend:" too
    odd.mkdir()
    blend = odd / "a.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    listing = tmp_path / "list.txt"
    listing.write_text("odd.blend:x/a.blend:Rock.blend:v2\ngone.blend:Rock.blend:v2\n")
    entries = plan.read_asset_list(listing)
    assert entries == [f"{blend}:Rock.blend:v2", f"{tmp_path / 'gone.blend'}:Rock.blend:v2"]
    assert plan.grouped_entries(entries)[0] == {str(blend): ["Rock.blend:v2"],
                                                str(tmp_path / "gone.blend"): ["Rock.blend:v2"]}
    listing.write_text("odd.blend:x/a.blend:Rock.blend:v2\n")
    rc = commands.execute(["bake-batch", "--asset-list", str(listing), "--output",
                           str(tmp_path / "maps" / "{object}.png"), "--resolution", "16",
                           "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.OK, err
    manifest = json.loads((tmp_path / "maps" / "surfgrad-bake-manifest.json").read_text())
    assert [a["object"] for a in manifest["assets"].values()] == ["Rock.blend:v2"]


def test_a_normal_map_read_through_a_muted_link_is_not_warned_about():
    obj = _cycles_plane()
    target = bpy.data.images.new("Emit", 4, 4, float_buffer=True)
    mat, _ = _emission_outputs(obj, target, [("G", "ALL")], 0)
    tree = mat.node_tree
    red = bpy.data.images.new("Red", 4, 4)
    red.generated_color = (1.0, 0.0, 0.0, 1.0)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = red
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    link = tree.links.new(tex.outputs["Color"], emission.inputs["Color"])
    baked = {}
    for muted in (True, False):          # Cycles' fact: a muted link leaves the socket's value
        link.is_muted = muted
        bpy.ops.object.bake(type="EMIT")
        baked[muted] = np.array(target.pixels[:]).reshape(-1, 4)[0, :3]
    assert np.allclose(baked[True], (0, 1, 0), atol=0.01), baked
    assert np.allclose(baked[False], (1, 0, 0), atol=0.01), baked
    mat, _, bsdf = diffuse_material("Normals")
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    tree = mat.node_tree
    srgb = tree.nodes.new("ShaderNodeTexImage")
    srgb.image = bpy.data.images.new("Bumps", 4, 4)       # read as sRGB: a warned slip
    assert srgb.image.colorspace_settings.name == "sRGB"
    reroute = tree.nodes.new("NodeReroute")
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    into_reroute = tree.links.new(srgb.outputs["Color"], reroute.inputs[0])
    into_map = tree.links.new(reroute.outputs[0], nmap.inputs["Color"])
    tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    (warning,) = colour_space_warnings(obj)
    assert "image 'Bumps' is read in colour space 'sRGB'" in warning, warning
    for muted in (into_map, into_reroute):
        muted.is_muted = True
        assert colour_space_warnings(obj) == []
        muted.is_muted = False
