"""Fault injection, issue 20 (red-team findings on the command line): outputs and inputs that
are folders, files in the way, text that is not UTF-8 and named pipes are refused before
anything is baked, with a message naming the path and the fix, exit code 2 (a pipe named
.blend fails its asset at once instead of blocking); a bake Blender cancels (Geometry Nodes
Realize Instances + Set Material leave the evaluated mesh an empty material slot) names that
slot and exits 1 (a bake failure) in both bake-normal-map and compare."""

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from surfgrad_addon.harness.cli import main  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _code(argv):
    """main's exit code, also where the parser refuses (it exits, SystemExit(2))."""
    try:
        return main(argv)
    except SystemExit as stop:
        return stop.code


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in Path(folder).rglob("*"))


def _compare(json_path, *extra):
    return main(["compare", "--object", "Sphere", "--method", "normal-map", "--resolution",
                 "32", "--json", str(json_path), *extra])


def test_compare_refuses_a_folder_as_its_report(tmp_path, capsys):
    (tmp_path / "d.json").mkdir()
    assert _compare(tmp_path / "d.json", "--overwrite") == 2
    err = capsys.readouterr().err
    assert f"output '{tmp_path / 'd.json'}' is a folder; give a file path" in err
    assert "Traceback" not in err
    assert _files(tmp_path) == ["d.json"]                 # nothing written, folder empty


def test_compare_refuses_a_report_under_a_file(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    assert _compare(tmp_path / "afile" / "x.json") == 2
    err = capsys.readouterr().err
    assert f"'{tmp_path / 'afile'}' is a file, not a folder" in err
    assert "File exists" not in err and "Traceback" not in err
    assert _files(tmp_path) == ["afile"] and (tmp_path / "afile").read_text() == "x"


def test_compare_refuses_an_existing_heat_map_before_baking(tmp_path, capsys):
    (tmp_path / "c_error.png").write_bytes(b"old")
    assert _compare(tmp_path / "c.json") == 2
    assert "c_error.png exists; pass --overwrite" in capsys.readouterr().err
    assert _files(tmp_path) == ["c_error.png"]
    assert (tmp_path / "c_error.png").read_bytes() == b"old"


@pytest.fixture
def asset(tmp_path):
    return BA.write_asset(tmp_path / "in" / "a.blend", ("Rock",), tiles=(1001,), image_size=32)


def _batch(tmp_path, *args):
    return main(["bake-batch", "--resolution", "32", "--output",
                 str(tmp_path / "out" / "{file}.png"), *map(str, args)])


@pytest.mark.parametrize("option", ["--manifest", "--settings"])
def test_bake_batch_refuses_a_folder_for_its_manifest_or_settings(asset, tmp_path, capsys,
                                                                  option):
    before = _sha(asset)
    folder = tmp_path / "d.json"
    folder.mkdir()
    assert _batch(tmp_path, asset, option, folder) == 2
    err = capsys.readouterr().err
    what = {"--manifest": "manifest", "--settings": "settings file"}[option]
    assert f"surfgrad: error: {what} {folder}" in err and "is a folder" in err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists() and _files(folder) == []
    assert _sha(asset) == before


@pytest.mark.parametrize("which", ["asset list", "settings file"])
def test_bake_batch_names_a_file_that_is_not_utf8(asset, tmp_path, capsys, which):
    bad = tmp_path / "list.txt"
    bad.write_bytes(str(asset).encode() + b"\n# caf\xe9\n")        # Latin-1, not UTF-8
    args = ["--asset-list", bad] if which == "asset list" else [asset, "--settings", bad]
    assert _batch(tmp_path, *args) == 2
    err = capsys.readouterr().err
    assert f"{which} {bad} is not UTF-8 text" in err and "save it as UTF-8" in err
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_bake_batch_fails_a_named_pipe_at_once(tmp_path, capsys):
    pipe = tmp_path / "pipe.blend"
    os.mkfifo(pipe)                   # opening it to read would block until a writer came
    assert _batch(tmp_path, pipe) == 1
    err = capsys.readouterr().err
    assert f"{pipe} is not a regular file (a pipe or device?)" in err
    assert "Traceback" not in err
    assert [p for p in _files(tmp_path / "out") if p.endswith(".png")] == []


def _gn_set_material_blend(path):
    """A plane whose Geometry Nodes put a Cube on each vertex, realize the instances and set
    the material: the evaluated mesh gets slots [empty, Mat] (the cube primitive has none)."""
    import bmesh
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("Plane")
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_grid(bm, x_segments=2, y_segments=2, size=1, calc_uvs=True)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new("Obj", mesh)
    bpy.context.scene.collection.objects.link(obj)
    mat = bpy.data.materials.new("Mat")
    mat.use_nodes = True
    mat.node_tree.nodes.new("ShaderNodeTexImage")
    mesh.materials.append(mat)
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    n = tree.nodes
    gi, go = n.new("NodeGroupInput"), n.new("NodeGroupOutput")
    points, inst = n.new("GeometryNodeMeshToPoints"), n.new("GeometryNodeInstanceOnPoints")
    cube, real = n.new("GeometryNodeMeshCube"), n.new("GeometryNodeRealizeInstances")
    setmat = n.new("GeometryNodeSetMaterial")
    setmat.inputs["Material"].default_value = mat
    cube.inputs["Size"].default_value = (0.3, 0.3, 0.3)
    link = tree.links.new
    link(gi.outputs[0], points.inputs[0])
    link(points.outputs[0], inst.inputs["Points"])
    store = n.new("GeometryNodeStoreNamedAttribute")        # the cube's UVs, as UVMap
    store.data_type, store.domain = "FLOAT2", "CORNER"
    store.inputs["Name"].default_value = "UVMap"
    link(cube.outputs["Mesh"], store.inputs["Geometry"])
    link(cube.outputs["UV Map"], store.inputs["Value"])
    link(store.outputs[0], inst.inputs["Instance"])
    link(inst.outputs[0], real.inputs[0])
    link(real.outputs[0], setmat.inputs[0])
    link(setmat.outputs[0], go.inputs[0])
    obj.modifiers.new("GN", "NODES").node_group = tree
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


@pytest.mark.tier("bake")
@pytest.mark.parametrize("command", ["bake-normal-map", "compare"])
def test_a_bake_blender_cancels_names_the_empty_slot_and_exits_1(tmp_path, capsys, command):
    blend = _gn_set_material_blend(tmp_path / "gn.blend")
    before = _sha(blend)
    out = tmp_path / "out"
    out.mkdir()
    if command == "compare":
        code = main(["compare", "--blend", str(blend), "--object", "Obj", "--method",
                     "normal-map", "--resolution", "32", "--json", str(out / "c.json")])
    else:
        code = main(["bake-normal-map", "--blend", str(blend), "--object", "Obj", "--output",
                     str(out / "n.png"), "--resolution", "32"])
    err = capsys.readouterr().err
    if command == "bake-normal-map" and bpy.app.version >= (5, 2, 0):
        # 5.2: the stored 'UVMap' is not the rendered mesh's active UV map, so the bake goes
        # through a copy of the render mesh (addon/tangent_uv.py), whose empty slot (no face
        # in it) Blender's bake only notes: every face is Mat's, which perturbs nothing.
        assert code == 0, err
        img = bpy.data.images.load(str(out / "n.png"))
        px = np.array(img.pixels[:]).reshape(-1, 4)[:, :3]
        assert np.abs(px - [128 / 255, 128 / 255, 1.0]).max() < 1e-6, np.unique(px, axis=0)[:4]
        assert _sha(blend) == before
        return
    if command == "compare":
        # The Set Material gives the instances 'Mat' whatever the slots hold, where compare's
        # own material must be: refused before the bake (tests/test_faults_unseen_meshes42.py).
        assert code == 2, err
        assert "object 'Obj' renders material(s) ['Mat'] on faces whatever" in err
        assert "Traceback" not in err and _files(out) == [] and _sha(blend) == before
        return
    assert code == 1, err                       # a bake failure, as bake-normal-map says
    assert "did not finish ({'CANCELLED'})" in err
    assert ("material slot 1 of the evaluated 'Obj' is empty (after its modifiers / Geometry "
            "Nodes it has 2 material slot(s), the object itself 1)") in err
    assert "give every slot a material" in err and "Traceback" not in err
    assert _files(out) == []
    assert _sha(blend) == before


@pytest.mark.parametrize("extra, message", [
    (["--only", "heigth"], "no bench scenario 'heigth'; --only takes some of height, noise"),
    # Numbers are refused while parsing since round 54 (addon/number_options.py).
    (["--resolution", "0"], "argument --resolution: 0: use a whole number from 8 to 8192"),
    (["--repeats", "-1"], "argument --repeats: -1: use a whole number from 1 to 100")])
def test_bench_refuses_a_bad_request_before_any_work(tmp_path, capsys, extra, message):
    """A misspelt --only used to run the displacement and stability suites and then end in
    matplotlib's 'Number of rows must be a positive integer, not 0'; --resolution 0 ran at
    the default size."""
    out = tmp_path / "b" / "bench"
    assert _code(["bench", "--quick", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert f"error: {message}" in err and "Traceback" not in err
    assert _files(tmp_path) == []                       # nothing made, parents included


@pytest.mark.parametrize("extra, message", [
    (["--resolution", "0"], "argument --resolution: 0: use a whole number from 8 to 8192"),
    (["--compare-resolution", "-3"], "argument --compare-resolution: -3: use a whole")])
def test_the_main_job_refuses_a_bad_size_before_its_first_stage(tmp_path, capsys, extra,
                                                                message):
    """--compare-resolution 0 used to be refused only at stage 2, after the reference stage."""
    assert _code(["demo", "--out", str(tmp_path / "demo"), *extra]) == 2
    captured = capsys.readouterr()
    assert f"error: {message}" in captured.err and "[1/" not in captured.out
    assert _files(tmp_path) == []
