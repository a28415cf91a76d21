"""Fault injection for inputs the red team found (issue 20): a .blend's own Python never runs,
whatever the user's Preferences say; inputs that would bake Cycles' magenta, a flat map or a
garbage map with exit 0 are refused before baking, naming the thing and the fix; bad option
values are refused up front. Each refusal: the message, the exit code, no file written, the
.blend byte for byte as it was."""

import hashlib
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _listing(folder):
    return sorted(p.name for p in Path(folder).iterdir()) if Path(folder).exists() else []


def _plane(name="Plane", uvs=None):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [], [(0, 1, 2, 3)])
    layer = mesh.uv_layers.new(name="UVMap")
    layer.data.foreach_set("uv", np.asarray(uvs or [(0, 0), (1, 0), (1, 1), (0, 1)],
                                            np.float32).ravel())
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _bake(capsys, blend, output, *options, obj="Plane"):
    """bake-normal-map at 32^2, in this process: (exit code, what it wrote to stderr)."""
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", obj,
                           "--output", str(output), "--resolution", "32", *options])
    return rc, capsys.readouterr().err


def _empty_folder(tmp_path):
    """Where the refused command was to write: it must stay empty."""
    out = tmp_path / "maps"
    out.mkdir()
    return out


def _save(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return path


# 1. a .blend's driver and registered text block never run -----------------------------------

def _scripted_blend(tmp_path):
    """A .blend whose Python driver and registered text block would each write a file."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = _plane()
    driver_mark, text_mark = tmp_path / "DRIVER_RAN", tmp_path / "TEXT_RAN"
    fc = obj.driver_add("location", 0)
    fc.driver.type = "SCRIPTED"
    fc.driver.expression = (f"__import__('pathlib').Path({str(driver_mark)!r})"
                            ".write_text('x') or 0.0")
    text = bpy.data.texts.new("autorun.py")
    text.write(f"import pathlib\npathlib.Path({str(text_mark)!r}).write_text('x')\n")
    text.use_module = True
    blend = _save(tmp_path / "scripted.blend")
    return blend, driver_mark, text_mark


@pytest.fixture
def auto_run_on():
    """The user's Preference "Auto Run Python Scripts" on (what `blender -c` loads)."""
    prefs = bpy.context.preferences.filepaths
    was = prefs.use_scripts_auto_execute
    prefs.use_scripts_auto_execute = True
    yield
    prefs.use_scripts_auto_execute = was


def test_a_blend_scripts_do_not_run_with_auto_run_on(tmp_path, auto_run_on):
    blend, driver_mark, text_mark = _scripted_blend(tmp_path)
    before = _sha(blend)
    out = tmp_path / "maps"
    # the command opens the file, then refuses the unknown object: nothing baked
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Nope",
                           "--output", str(out / "n.png"), "--resolution", "32"])
    assert rc == exit_codes.BAD_REQUEST
    assert bpy.data.filepath == str(blend)                   # it was opened
    bpy.context.view_layer.update()                          # drivers would evaluate here
    assert not driver_mark.exists() and not text_mark.exists()
    assert bpy.app.driver_namespace.get("__import__") is None
    from surfgrad_addon.addon.batch import session
    session._OPENED[0] = None
    session.open_blend(blend)
    bpy.context.view_layer.update()
    assert not driver_mark.exists() and not text_mark.exists()
    from surfgrad_addon.harness import compare
    with pytest.raises(compare.CompareError, match="no object named 'Nope'"):
        compare.run(blend, "Nope", "normal-map", 32, tmp_path / "c.json")
    bpy.context.view_layer.update()
    assert not driver_mark.exists() and not text_mark.exists()
    assert _listing(out) == [] and not (tmp_path / "c.json").exists()
    assert _sha(blend) == before


# 2. inputs that would bake magenta or a flat map with exit 0 ---------------------------------

def _write_png(path, size=8):
    img = bpy.data.images.new("tmp_png", size, size)
    img.pixels.foreach_set(np.tile(np.float32([0.5, 0.5, 1.0, 1.0]), size * size))
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def _material(obj, image=None, name="Mat"):
    """Image Texture -> Normal Map -> Diffuse -> Material Output (returns the tree)."""
    mat, tree, bsdf = diffuse_material(name)
    nm = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(nm.outputs[0], bsdf.inputs["Normal"])
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.name = "Bumps"
    tex.image = image
    tree.links.new(tex.outputs["Color"], nm.inputs["Color"])
    obj.data.materials.append(mat)
    return tree


def _fault_blend(tmp_path, fault):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tex = tmp_path / "tex.png"
    _write_png(tex)
    if fault == "udim":                         # UVs in 1001 and 1002, the image lists 1001
        obj = _plane(uvs=[(0, 0), (2, 0), (2, 1), (0, 1)])
        _write_png(tmp_path / "t.1001.png")
        image = bpy.data.images.load(str(tmp_path / "t.1001.png"))
        image.source = "TILED"
        _material(obj, image)
    elif fault == "sequence":                   # frame 1 read at frame 1; only seq_002 exists
        obj = _plane()
        _write_png(tmp_path / "seq_002.png")
        image = bpy.data.images.load(str(tmp_path / "seq_002.png"))
        image.source = "SEQUENCE"
        tree = _material(obj, image)
        tree.nodes["Bumps"].image_user.frame_start = 1
        tree.nodes["Bumps"].image_user.frame_duration = 10
        tree.nodes["Bumps"].image_user.frame_offset = 0
        bpy.context.scene.frame_current = 1
    elif fault == "cycles_output":              # active output for EEVEE, Cycles' reads a
        obj = _plane()                          # missing file
        tree = _material(obj, bpy.data.images.load(str(tex)))
        tree.nodes["Material Output"].target = "EEVEE"
        cyc = tree.nodes.new("ShaderNodeOutputMaterial")
        cyc.target = "CYCLES"
        gone = tmp_path / "gone.png"
        _write_png(gone)
        tex2 = tree.nodes.new("ShaderNodeTexImage")
        tex2.name = "CyclesBumps"
        tex2.image = bpy.data.images.load(str(gone))
        bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
        nm2 = tree.nodes.new("ShaderNodeNormalMap")       # (a Color alone is not baked:
        tree.links.new(tex2.outputs["Color"], nm2.inputs["Color"])      # round 54)
        tree.links.new(nm2.outputs[0], bsdf.inputs["Normal"])
        tree.links.new(bsdf.outputs[0], cyc.inputs["Surface"])
        tree.nodes["Material Output"].is_active_output = True
    elif fault == "library":                    # the material from lib.blend, then it goes
        obj = _plane()
        mat = new_material("LibMat")
        bpy.data.libraries.write(str(tmp_path / "lib.blend"), {mat})
        bpy.data.materials.remove(mat)
        with bpy.data.libraries.load(str(tmp_path / "lib.blend"), link=True) as (src, dst):
            dst.materials = ["LibMat"]
        obj.data.materials.append(dst.materials[0])
    elif fault in ("normal_map_uv", "uv_node"):
        obj = _plane()
        tree = _material(obj, bpy.data.images.load(str(tex)))
        if fault == "normal_map_uv":
            tree.nodes["Normal Map"].uv_map = "UVMap.001"
        else:
            uvn = tree.nodes.new("ShaderNodeUVMap")
            uvn.uv_map = "UVMap.001"
            tree.links.new(uvn.outputs[0], tree.nodes["Bumps"].inputs["Vector"])
    blend = _save(tmp_path / "scene.blend")
    if fault == "cycles_output":
        gone.unlink()
    if fault == "library":
        (tmp_path / "lib.blend").unlink()
    return blend


MAGENTA_FAULTS = [
    ("udim", ["tiled image 't.1001.png' has no tile 1002", "tiles: [1001]", "Add Tile"]),
    ("sequence", ["image sequence 'seq_002.png' reads frame 1 at scene frame 1",
                  "seq_001.png", "does not exist", "Start Frame / Offset"]),
    ("cycles_output", ["gone.png", "does not exist", "'CyclesBumps'"]),
    ("library", ["material 'LibMat' is linked from library", "lib.blend", "is missing",
                 "relink it"]),
    ("normal_map_uv", ["node 'Normal Map' (material 'Mat') reads UV map 'UVMap.001'",
                       "UV maps: ['UVMap']"]),
    ("uv_node", ["node 'UV Map' (material 'Mat') reads UV map 'UVMap.001'",
                 "UV maps: ['UVMap']"]),
]


@pytest.mark.parametrize("fault,words", MAGENTA_FAULTS, ids=[f for f, _ in MAGENTA_FAULTS])
def test_an_input_that_would_bake_magenta_or_flat_is_refused(tmp_path, fault, words, capsys):
    blend = _fault_blend(tmp_path, fault)
    before = _sha(blend)
    out = _empty_folder(tmp_path)
    rc, err = _bake(capsys, blend, out / "n.<UDIM>.png")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    for word in words:
        assert word in err, (word, err[-2000:])
    assert "Traceback" not in err
    assert _listing(out) == []
    assert _sha(blend) == before


# 3. a zero scale axis; 4. reversed tiles, threads 0, the far-from-origin distance ------------

def _good_blend(tmp_path, location=(0, 0, 0), scale=(1, 1, 1)):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tex = tmp_path / "tex.png"
    _write_png(tex)
    obj = _plane()
    obj.location, obj.scale = location, scale
    _material(obj, bpy.data.images.load(str(tex)))
    return _save(tmp_path / "scene.blend")


def test_a_zero_scale_axis_is_refused_by_the_bake_and_compare(tmp_path, capsys):
    blend = _good_blend(tmp_path, scale=(1, 1, 0))
    before = _sha(blend)
    out = _empty_folder(tmp_path)
    rc, err = _bake(capsys, blend, out / "n.png")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert "object 'Plane': its scale has a zero axis (scale (1.0, 1.0, 0.0)" in err
    assert "apply a non-zero scale" in err
    from surfgrad_addon.harness import compare
    with pytest.raises(compare.CompareError, match="its scale has a zero axis") as exc:
        compare.run(blend, "Plane", "normal-map", 32, out / "c.json")
    assert "Singular" not in str(exc.value)
    assert _listing(out) == [] and _sha(blend) == before


@pytest.mark.parametrize("tiles,words", [
    ("1011-1002", "the range '1011-1002' runs backwards (no tiles); write it low to high, "
                  "like 1002-1011"),
    (",", "tiles ',': no tile given"),
])
def test_reversed_or_empty_tiles_are_refused(tmp_path, capsys, tiles, words):
    blend = _good_blend(tmp_path)
    before = _sha(blend)
    out = _empty_folder(tmp_path)
    rc, err = _bake(capsys, blend, out / "n.<UDIM>.png", "--tiles", tiles)
    assert rc == exit_codes.BAD_REQUEST and words in err, err[-2000:]
    rc = commands.execute(["bake-batch", str(blend), "--output", str(out / "{object}.png"),
                           "--resolution", "32", "--workers", "0", "--tiles", tiles])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST and words in err, err[-2000:]
    assert _listing(out) == [] and _sha(blend) == before


@pytest.mark.parametrize("threads", ["0", "-3"])
def test_threads_below_one_are_refused_up_front(tmp_path, capsys, threads):
    blend = _good_blend(tmp_path)
    before = _sha(blend)
    out = tmp_path / "out"
    rc = commands.execute(["bake-batch", str(blend), "--output", str(out / "{object}.png"),
                           "--resolution", "32", "--workers", "0", "--threads", threads])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert f"threads {threads}: use a whole number from 1 to 1024" in err
    assert not out.exists() and _sha(blend) == before


def test_far_from_origin_warning_names_the_euclidean_distance(tmp_path):
    from surfgrad_addon.addon import bake_request as BR
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = _plane()
    obj.location = (6000.0, 6000.0, 6000.0)       # the far corner (6001, 6001, 6000)
    bpy.context.view_layer.update()
    warnings = []
    assert BR.mesh_problems(obj, "UVMap", warnings) == []
    expected = np.linalg.norm([6001.0, 6001.0, 6000.0])          # 10393 m, not 6001
    assert any(f"reaches {expected:.0f} m from the origin" in w for w in warnings), warnings


# 5. messages that name what is wrong ----------------------------------------------------------

def test_a_file_that_is_not_a_blend_is_named_once(tmp_path, capsys):
    bad = tmp_path / "notes.txt"
    bad.write_text("not a blend")
    before = _sha(bad)
    out = _empty_folder(tmp_path)
    rc, err = _bake(capsys, bad, out / "n.png")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert f".blend file {str(bad)!r} could not be opened (File format is not supported" in err
    assert "Error: Error" not in err and "error: Error" not in err
    assert _listing(out) == [] and _sha(bad) == before


def test_folder_where_a_file_belongs_and_a_curve_object_are_named(tmp_path, capsys):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    folder_image = tmp_path / "tex.png"
    _write_png(folder_image)
    obj = _plane()
    _material(obj, bpy.data.images.load(str(folder_image)))
    curve = bpy.data.objects.new("Path", bpy.data.curves.new("Path", "CURVE"))
    bpy.context.scene.collection.objects.link(curve)
    blend = _save(tmp_path / "scene.blend")
    folder_image.unlink()
    folder_image.mkdir()                         # the image's path is now a folder
    before = _sha(blend)
    out = _empty_folder(tmp_path)
    rc, err = _bake(capsys, blend, out / "n.png")
    assert rc == exit_codes.BAD_REQUEST
    assert f"reads {str(folder_image)!r}, which is a folder, not an image file" in err, err
    (out / "afile").write_text("x")
    rc, err = _bake(capsys, blend, out / "afile" / "n.png")
    assert rc == exit_codes.BAD_REQUEST
    assert f"output folder {str(out / 'afile')!r} is a file, not a folder" in err, err
    rc, err = _bake(capsys, blend, out / "n.png", obj="Path")
    assert rc == exit_codes.BAD_REQUEST
    assert "object 'Path' is a curve, not a mesh: pick a mesh object" in err, err
    assert _listing(out) == ["afile"] and _sha(blend) == before
    from surfgrad_addon.harness import compare
    with pytest.raises(compare.CompareError, match="is a folder, not an image file"):
        compare._load_image(folder_image)


def test_a_sequence_whose_current_frame_exists_is_not_refused(tmp_path):
    """The check follows the frame the bake reads: the path's own frame (001) missing does not
    matter when the scene's frame (3, offset 0) reads seq_003.png, which exists."""
    from surfgrad_addon.addon.image_checks import image_problems
    bpy.ops.wm.read_factory_settings(use_empty=True)
    _write_png(tmp_path / "seq_003.png")
    _write_png(tmp_path / "seq_001.png")
    obj = _plane()
    image = bpy.data.images.load(str(tmp_path / "seq_001.png"))
    image.source = "SEQUENCE"
    tree = _material(obj, image)
    user = tree.nodes["Bumps"].image_user
    user.frame_start, user.frame_duration, user.frame_offset = 1, 10, 0
    (tmp_path / "seq_001.png").unlink()
    bpy.context.scene.frame_current = 3
    assert image_problems(obj) == []
    bpy.context.scene.frame_current = 2                 # seq_002.png: missing
    problems = image_problems(obj)
    assert len(problems) == 1 and "reads frame 2 at scene frame 2" in problems[0], problems
    user.frame_offset = 1                               # frame 2 + 1 = seq_003.png
    assert image_problems(obj) == []
    user.use_cyclic, user.frame_duration, user.frame_offset = True, 2, 1
    bpy.context.scene.frame_current = 4                 # (4 % 2 -> 2) + 1 = 3
    assert image_problems(obj) == []


def test_a_tiled_image_is_checked_for_the_tiles_the_bake_writes(tmp_path, capsys):
    """--tiles 1001 of a layout in 1001 and 1002: the image's missing 1002 is not read by this
    bake (a farm task per tile), so it is not refused; the whole layout is."""
    from surfgrad_addon.addon.image_checks import image_problems
    blend = _fault_blend(tmp_path, "udim")
    bpy.ops.wm.open_mainfile(filepath=str(blend), use_scripts=False)
    obj = bpy.data.objects["Plane"]
    assert image_problems(obj, [1001]) == []
    problems = image_problems(obj, [1001, 1002])
    assert len(problems) == 1 and "has no tile 1002" in problems[0], problems
