"""Objects as artists leave them: linked from a library, hidden, outside the view layer; and
images that cannot be used. Each gets a clear error, or is baked with its state given back."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import compare, scenes as test_scenes  # noqa: E402

pytestmark = pytest.mark.tier("bake")


@pytest.fixture()
def plane(fresh):
    return test_scenes.new_scene(["Plane"])["Plane"]


def _linked_object(tmp_path):
    """A library file with a Plane, linked (not appended) into an empty file."""
    lib = tmp_path / "library.blend"
    test_scenes.new_scene(["Plane"])
    bpy.ops.wm.save_as_mainfile(filepath=str(lib))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with bpy.data.libraries.load(str(lib), link=True) as (src, dst):
        dst.objects = ["Plane"]
    obj = dst.objects[0]
    bpy.context.scene.collection.objects.link(obj)
    return obj


def test_an_object_linked_from_a_library_gets_a_clear_error(fresh, tmp_path):
    obj = _linked_object(tmp_path)
    with pytest.raises(compare.CompareError, match="linked from library .*Make Local"):
        compare.compare_object(obj, "normal-map", 16)
    assert not [m for m in bpy.data.materials if m.name.startswith("surfgrad")]


def test_a_hidden_object_is_baked_and_stays_hidden(plane):
    obj = plane
    view_layer = bpy.context.view_layer
    obj.hide_set(True)
    obj.hide_viewport = True
    obj.hide_select = True
    report, _ = compare.compare_object(obj, "normal-map", 24)
    assert report["max_deg"] <= 0.5 and report["texels_compared"] > 200
    assert obj.hide_get(view_layer=view_layer) and obj.hide_viewport and obj.hide_select
    assert not obj.hide_render


def test_an_object_outside_the_view_layer_gets_a_clear_error(plane):
    obj = plane
    coll = bpy.data.collections.new("Excluded")
    bpy.context.scene.collection.children.link(coll)
    for c in list(obj.users_collection):
        c.objects.unlink(obj)
    coll.objects.link(obj)
    bpy.context.view_layer.layer_collection.children["Excluded"].exclude = True
    with pytest.raises(compare.CompareError, match="not in view layer .*enable its collection"):
        compare.compare_object(obj, "normal-map", 16)


def test_a_non_finite_image_is_refused_and_not_left_behind(plane, tmp_path):
    img = bpy.data.images.new("nan", 8, 8, float_buffer=True)
    img.pixels.foreach_set(np.full(8 * 8 * 4, np.nan, dtype=np.float32))
    path = tmp_path / "nan.exr"
    img.filepath_raw = str(path)
    img.file_format = "OPEN_EXR"
    img.save()
    bpy.data.images.remove(img)
    before = len(bpy.data.images)
    with pytest.raises(compare.CompareError, match="non-finite pixels"):
        compare.compare_object(plane, "normal-map", 16, image=str(path))
    assert len(bpy.data.images) == before


def test_bake_normal_map_inside_blender_honours_blend(plane, tmp_path, capsys):
    """Inside Blender (blender -b --python blender_cli.py -- bake-normal-map --blend F), F is
    opened like anywhere else: a missing file is an error, not a bake of the open file."""
    from surfgrad_addon.harness import cli
    out = tmp_path / "n.png"
    code = cli.main(["bake-normal-map", "--blend", str(tmp_path / "nope.blend"), "--object",
                     "Plane", "--output", str(out), "--resolution", "16"], in_blender=True)
    assert code == 2 and not out.exists()
    assert "nope.blend' does not exist" in capsys.readouterr().err


def _with_material(obj):
    from surfgrad_addon.addon.compat import new_material
    mat = new_material("Plain")
    obj.data.materials.append(mat)
    return mat


def test_bake_normal_map_bakes_a_hidden_object_and_hides_it_again(plane, tmp_path):
    from surfgrad_addon.addon.normal_bake import bake_normal_map
    _with_material(plane)
    plane.hide_set(True)
    plane.hide_render = True
    out = bake_normal_map(plane, tmp_path / "n.png", resolution=16, log=lambda *a: None)
    assert out.is_file()
    img = bpy.data.images.load(str(out))
    px = np.array(img.pixels[:]).reshape(16, 16, 4)
    # A flat plane in tangent space is (0.5, 0.5, 1) everywhere: a real bake, not a blank.
    assert np.abs(px[..., :3] - [0.5, 0.5, 1.0]).max() < 0.01
    assert plane.hide_get() and plane.hide_render


def test_bake_normal_map_refuses_a_linked_object(fresh, tmp_path):
    from surfgrad_addon.addon.normal_bake import NormalBakeError, bake_normal_map
    obj = _linked_object(tmp_path)
    with pytest.raises(NormalBakeError, match="linked from library .*Make Local"):
        bake_normal_map(obj, tmp_path / "n.png", resolution=16, log=lambda *a: None)
    assert not (tmp_path / "n.png").exists()
