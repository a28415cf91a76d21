"""Red team 39d: assets as a pipeline TD receives them from other tools (Blender's own
exporters and importers, run here on a few-face mesh made by code).

1. An Alembic import of an animated mesh reads its shape through a Mesh Sequence Cache
   modifier from the .abc file. Where that file is gone (the .blend moved to the farm without
   it, a relative path broken) or damaged, Blender only logs "Could not create cache reader"
   and renders the mesh the import stored (the first frame's): bake-normal-map wrote that
   stale shape's map with exit 0 (an object-space map 0.38 off in 0..1 on 5.2 against the
   cache's frame 10). Now refused, naming the modifier, the file and the fix
   (addon/cache_files.py). A USD import of time-sampled points reads through the same
   modifier and is held to the same rule (read: baked; missing: refused).
2. An asset list naming an object whose name ends in a space ("Rock " beside "Rock": a
   duplicate an importer or a script renamed): each line was stripped, so the batch baked
   "Rock" in its place, exit 0 (and "Rock " alone could not be named in a list at all). Now
   the name is kept as written; a name the file lacks falls back to it without the trailing
   spaces (a stray space an editor left), as before (batch/plan.read_asset_list,
   batch/session.scan_open_file).
3. An object name longer than Blender keeps (63 bytes up to 4.5, 255 from 5.0), as another
   tool's asset list gives it: Blender cut it when the object was made, at a whole UTF-8
   character (an "é" across the limit goes whole). bake-batch failed the asset with "no object
   named '...' in a.blend" (exit 1) and named no fix; bake-normal-map and compare listed the
   objects. Now each says the name's length, the line's limit and the name the file has
   (addon/object_names.py).
4. A .blend given to bake-batch as a symbolic link (a versioned asset store: proj/rock.blend
   links to store/rock_v3.blend, the textures beside the link): the batch resolved the link
   and opened the target, so Blender took the file's relative paths ('//stripes.png') from the
   target's folder, where an older flat map lay: a flat map with exit 0 (0.25 off in the PNG's
   0..1; the stripes 0.5 apart), while bake-normal-map of the same path, as Blender, read the
   textures beside the link. And {file} was the target's name. Now the batch opens the path
   as given (batch/plan.grouped_entries, batch/session.open_blend).
5. An object linked from a library under the name of a local object ("Rock" linked beside
   the file's own "Rock"): bake-batch of every object baked the local one and left the linked
   one out without a word, exit 0, where a linked object alone fails its asset naming the fix
   (exit 1). Now it fails the same way, named "Rock [lib.blend]" (batch/session.py).
"""

import hashlib
import json
import shutil

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.batch import plan  # noqa: E402
from surfgrad_addon.addon.cache_files import unread_cache_problems  # noqa: E402
from surfgrad_addon.addon.open_blend import open_mainfile  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_scene_settings import _pixels, _scene  # noqa: E402
from test_faults_unseen_meshes32 import _grid, _object  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16


def _sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _alembic_asset(tmp_path):
    """tmp_path/scene.blend: an Alembic import (cache tmp_path/anim.abc, relative) of a grid
    whose shape key bends it over frames 1..10, at frame 10, with a material."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = _object("Grid", [_grid(n=4)])
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Bend")
    co = np.array([v.co for v in obj.data.vertices])
    co[:, 2] += 0.5 * co[:, 0] ** 2
    key.data.foreach_set("co", co.ravel())
    for frame, value in ((1, 0.0), (10, 1.0)):
        key.value = value
        key.keyframe_insert("value", frame=frame)
    abc = tmp_path / "anim.abc"
    bpy.ops.wm.alembic_export(filepath=str(abc), start=1, end=10)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.alembic_import(filepath=str(abc), relative_path=True)
    (obj,) = [o for o in bpy.data.objects if o.type == "MESH"]
    assert [m.type for m in obj.modifiers] == ["MESH_SEQUENCE_CACHE"]
    obj.data.materials.clear()
    obj.data.materials.append(diffuse_material("Mat")[0])
    bpy.context.scene.frame_set(10)
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), relative_remap=True)
    return blend, abc, obj.name


def _bake(capsys, blend, name, out):
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", name,
                           "--output", str(out), "--resolution", str(RES), "--space",
                           "object", "--margin", "0"])
    return rc, capsys.readouterr().err


def test_an_alembic_cache_that_cannot_be_read_is_refused(tmp_path, capsys):
    blend, abc, name = _alembic_asset(tmp_path)
    sha = _sha(blend)
    rc, err = _bake(capsys, blend, name, tmp_path / "read.png")
    assert rc == exit_codes.OK, err
    bent = _pixels(tmp_path / "read.png")
    # The cache's frame 10 is bent along x: object-space normals lean in x (not the flat
    # first frame's, which the stale mesh gives).
    assert np.abs(bent[..., 0] * 2 - 1).max() > 0.3
    gone = tmp_path / "elsewhere"
    gone.mkdir()
    shutil.move(abc, gone / abc.name)
    rc, err = _bake(capsys, blend, name, tmp_path / "missing.png")
    assert rc == exit_codes.BAD_REQUEST, err
    assert "modifier 'MeshSequenceCache'" in err and "//anim.abc" in err and "missing" in err, err
    assert "Find Missing Files" in err and "Traceback" not in err
    abc.write_bytes(b"not an archive " * 8)          # damaged
    rc, err = _bake(capsys, blend, name, tmp_path / "damaged.png")
    assert rc == exit_codes.BAD_REQUEST, err
    assert "could not read" in err and "//anim.abc" in err, err
    assert not (tmp_path / "missing.png").exists() and not (tmp_path / "damaged.png").exists()
    assert _sha(blend) == sha
    shutil.move(gone / abc.name, abc)                  # back: bakes the cache's frame again
    rc, err = _bake(capsys, blend, name, tmp_path / "again.png")
    assert rc == exit_codes.OK, err
    assert np.array_equal(_pixels(tmp_path / "again.png"), bent)


USDA = """#usda 1.0
(
    defaultPrim = "Root"
    startTimeCode = 1
    endTimeCode = 10
    upAxis = "Z"
)
def Xform "Root"
{
    def Mesh "Tile"
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points.timeSamples = {
            1: [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)],
            10: [(-1, -1, 0), (1, -1, 0.8), (1, 1, 0.8), (-1, 1, 0)],
        }
        texCoord2f[] primvars:st = [(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)] (
            interpolation = "faceVarying"
        )
    }
}
"""


def test_a_usd_mesh_cache_is_read_or_refused(tmp_path):
    usd = tmp_path / "anim.usda"
    usd.write_text(USDA)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=str(usd), relative_path=True)
    assert [m.type for m in bpy.data.objects["Tile"].modifiers] == ["MESH_SEQUENCE_CACHE"]
    bpy.context.scene.frame_set(10)
    blend = tmp_path / "usd.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), relative_remap=True)
    open_mainfile(str(blend))
    assert unread_cache_problems(bpy.data.objects["Tile"]) == []
    usd.rename(tmp_path / "moved.usda")
    open_mainfile(str(blend))
    (problem,) = unread_cache_problems(bpy.data.objects["Tile"])
    assert "'//anim.usda'" in problem and "which is missing" in problem, problem
    (tmp_path / "moved.usda").rename(usd)
    open_mainfile(str(blend))
    tile = bpy.data.objects["Tile"]
    evaluated = tile.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    assert max(v.co.z for v in evaluated.vertices) > 0.1       # frame 10 read from the cache
    tile.modifiers[0].object_path = "/Root/Nope"      # a path the file lacks: the stored mesh
    evaluated = tile.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    assert max(abs(v.co.z) for v in evaluated.vertices) < 1e-6
    (problem,) = unread_cache_problems(tile)
    assert "holds no object '/Root/Nope'" in problem and "'/Root/Tile'" in problem, problem


def test_an_asset_list_keeps_an_object_name_s_trailing_spaces(tmp_path, capsys):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat = diffuse_material("Mat")[0]
    # "Rock" flat, "Rock " bumped: an object-space map tells them apart.
    for name, n, bump in (("Rock", 1, 0.0), ("Rock ", 4, 1.0), ("Stone", 1, 0.0)):
        verts, faces, uvs = _grid(n=n)
        verts[:, 2] *= bump
        _object(name, [(verts, faces, uvs)]).data.materials.append(mat)
    blend = tmp_path / "a.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    listing = tmp_path / "list.txt"
    listing.write_text("a.blend:Rock \n  a.blend:Stone \t\n")
    assert plan.read_asset_list(listing) == [f"{blend}:Rock ", f"{blend}:Stone \t"]
    rc = commands.execute(["bake-batch", "--asset-list", str(listing), "--output",
                           str(tmp_path / "maps" / "{object}.png"), "--resolution", str(RES),
                           "--space", "object", "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.OK, err
    manifest = json.loads((tmp_path / "maps" / "surfgrad-bake-manifest.json").read_text())
    assert sorted(a["object"] for a in manifest["assets"].values()) == ["Rock ", "Stone"]
    rock = _pixels(tmp_path / "maps" / "Rock.png") * 2 - 1
    assert np.abs(rock[..., 0]).max() > 0.2                 # the bumped "Rock ", not "Rock"
    stone = _pixels(tmp_path / "maps" / "Stone.png") * 2 - 1
    assert np.abs(stone - (0, 0, 1)).max() < 0.02           # flat: the stray tab was dropped


def test_a_name_longer_than_blender_keeps_is_refused_with_the_name_the_file_has(tmp_path,
                                                                               capsys):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    limit = bpy.types.ID.bl_rna.properties["name"].length_max - 1
    assert limit == (63 if bpy.app.version < (5, 0, 0) else 255)     # the line's fact
    full = "x" * (limit - 1) + "\u00e9"        # the 2-byte "é" crosses the limit
    obj = _object(full, [_grid(n=1)])
    obj.data.materials.append(diffuse_material("Mat")[0])
    assert obj.name == "x" * (limit - 1)          # Blender dropped the "é" whole
    cut = obj.name
    blend = tmp_path / "a.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    listing = tmp_path / "list.txt"
    listing.write_text(f"a.blend:{full}\n", encoding="utf-8")
    out = tmp_path / "maps" / "{object}.png"
    rc = commands.execute(["bake-batch", "--asset-list", str(listing), "--output", str(out),
                           "--resolution", str(RES), "--workers", "0"])
    err = capsys.readouterr().err
    fix = f"is {limit + 1} bytes, and Blender {bpy.app.version[0]}.{bpy.app.version[1]} " \
          f"keeps {limit}, so the object is called {cut!r} in the file: give that name"
    assert rc == exit_codes.BAKE_FAILED and fix in err, err
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", full,
                           "--output", str(tmp_path / "one.png"), "--resolution", str(RES)])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST and fix in err, err
    assert not (tmp_path / "one.png").exists() and not list((tmp_path / "maps").glob("*.png"))


def test_a_blend_given_as_a_symbolic_link_reads_its_textures_beside_the_link(tmp_path,
                                                                            capsys):
    proj, store = tmp_path / "proj", tmp_path / "store"
    proj.mkdir()
    store.mkdir()
    blend = _scene(proj)                     # proj/plain.blend reads '//stripes.png'
    assert [i.filepath for i in bpy.data.images] == ["//stripes.png"]
    shutil.move(blend, store / "plain_v3.blend")
    blend.symlink_to(store / "plain_v3.blend")
    flat = bpy.data.images.new("flat", 8, 8)        # an older, flat map beside the target
    flat.pixels.foreach_set(np.tile(np.float32([0.5, 0.5, 1.0, 1.0]), 64))
    flat.filepath_raw, flat.file_format = str(store / "stripes.png"), "PNG"
    flat.save()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(tmp_path / "single.png"), "--resolution", str(RES)])
    assert rc == exit_codes.OK, capsys.readouterr().err
    rc = commands.execute(["bake-batch", str(blend), "--output",
                           str(tmp_path / "maps" / "{file}_{object}.png"), "--resolution",
                           str(RES), "--workers", "0"])
    assert rc == exit_codes.OK, capsys.readouterr().err
    single = _pixels(tmp_path / "single.png")
    assert np.ptp(single[..., 0]) > 0.4              # the stripes beside the link
    (batch,) = (tmp_path / "maps").glob("*.png")
    assert np.array_equal(_pixels(batch), single)
    assert batch.name == "plain_Plane.png"            # {file}: the name given, not the target's


def test_a_linked_object_under_a_local_object_s_name_is_named(tmp_path, capsys):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    _object("Rock", [_grid(n=1)]).data.materials.append(diffuse_material("Mat")[0])
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "lib.blend"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    _object("Rock", [_grid(n=2)]).data.materials.append(diffuse_material("Own")[0])
    with bpy.data.libraries.load(str(tmp_path / "lib.blend"), link=True) as (_, linked):
        linked.objects = ["Rock"]
    bpy.context.scene.collection.objects.link(linked.objects[0])
    assert sorted(bool(o.library) for o in bpy.data.objects) == [False, True]
    blend = tmp_path / "main.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    rc = commands.execute(["bake-batch", str(blend), "--output",
                           str(tmp_path / "maps" / "{object}.png"), "--resolution", str(RES),
                           "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAKE_FAILED, err
    assert "main.blend:Rock [lib.blend]: object 'Rock' linked from library" in err, err
    assert "Make Local" in err
    manifest = json.loads((tmp_path / "maps" / "surfgrad-bake-manifest.json").read_text())
    assert sorted((a["object"], a["status"]) for a in manifest["assets"].values()) == [
        ("Rock", "baked"), ("Rock [lib.blend]", "failed")]
