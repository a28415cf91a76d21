"""Red team 37a: the Python API as a pipeline TD scripts it in a running Blender.

- A group built for an image was named by the image's name alone and, per image, knew no
  extension: `api.node_group("SG Height Map HQ", image=...)` for a library's image "A" after a
  local image "A", or with extension EXTEND after REPEAT, took the first call's group. SG
  Height Map HQ rebuilt it in place (every material using it then sampled the library's image,
  or the other extension), SG Parallax and SG Triplanar Height returned it unchanged (the
  caller's image or extension silently not used). SG Triplanar Height with images=[A, None,
  None] or [None, A, None] was named as image=A ("SG Triplanar Height [A]"), each rebuilding
  the others. And SG Height Map HQ was rebuilt at every use (its size stamp, an
  IDPropertyArray, never equalled the list it was compared with), while SG Triplanar Height,
  whose texel step is built in as HQ's is, was never rebuilt for an image that changed size
  (a texture replaced by a larger file): its derivatives stayed scaled for the old size.
- Numbers a script computes with numpy (np.int64 resolution, samples, margin; bake_batch's
  settings and workers) were refused by bake_normal_map, bake_batch and the harness's compare
  as "resolution
  np.int64(16): use a whole number of texels" (it is one); log=None (quiet) raised a raw
  TypeError ('NoneType' object is not callable).
- bake_batch from a session holding a file, with workers=0 (which the CLI and farm tasks use
  in a fresh Blender): each .blend was opened in this session in place of the user's file,
  its unsaved changes lost and the script's objects gone (ReferenceError on the next use),
  without a word. Now refused naming the fix (workers >= 1, or blends=None). And one path
  (or object or collection name) given alone was taken letter by letter: "/tmp/a.blend" gave
  17 failed assets ('/:*', 't:*', ...), objects="Plane" five ('P', 'l', ...), a Path raised a
  raw TypeError. Now one path, name or object alone is that one.
- The Cycles add-on disabled (Preferences > Add-ons; a studio's EEVEE-only startup): the bake
  request's checks passed and the bake raised a raw AttributeError ('Scene' object has no
  attribute 'cycles'), from bake_normal_map, harness compare and Freeze alike. Now each refuses
  up front, naming the add-on and how to enable it.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402

pytestmark = pytest.mark.tier("blender")

IMAGE_GROUPS = ("SG Height Map HQ", "SG Parallax", "SG Triplanar Height")


def _taps(tree):
    """(image name, linked?, extension) of each Image Texture node of a group."""
    return {(n.image.name, n.image.library is not None, n.extension)
            for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"}


def _used_by_a_material(tree):
    mat = new_material("Uses " + tree.name)
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    return node


def test_each_image_and_extension_gets_its_own_group(fresh, tmp_path):
    library = tmp_path / "lib.blend"
    bpy.data.libraries.write(str(library), {bpy.data.images.new("A", 4, 4)})
    bpy.ops.wm.read_factory_settings(use_empty=True)
    local = bpy.data.images.new("A", 8, 8)
    with bpy.data.libraries.load(str(library), link=True) as (_, into):
        into.images = ["A"]
    linked = into.images[0]
    for name in IMAGE_GROUPS:
        first = _used_by_a_material(api.node_group(name, image=local))
        pointers = [n.as_pointer() for n in first.node_tree.nodes]
        other = api.node_group(name, image=linked)
        extend = api.node_group(name, image=local, extension="EXTEND")
        assert _taps(first.node_tree) == {("A", False, "REPEAT")}, name
        assert _taps(other) == {("A", True, "REPEAT")}, name
        assert _taps(extend) == {("A", False, "EXTEND")}, name
        again = api.node_group(name, image=local)
        assert again == first.node_tree, name
        # The same request again takes the group as it is (no rebuild of its nodes).
        assert [n.as_pointer() for n in again.nodes] == pointers, name


def _float_constants(tree):
    return {i.default_value for n in tree.nodes for i in n.inputs
            if not i.is_linked and isinstance(getattr(i, "default_value", None), float)}


def test_an_image_of_another_size_rebuilds_the_groups_that_build_it_in(fresh):
    image = bpy.data.images.new("A", 8, 8)
    for name in ("SG Height Map HQ", "SG Triplanar Height"):
        image.scale(8, 8)
        assert 8.0 in _float_constants(api.node_group(name, image=image)), name
        image.scale(13, 13)
        now = _float_constants(api.node_group(name, image=image))
        assert 13.0 in now and 8.0 not in now, name


def test_triplanar_height_refuses_a_plane_without_an_image(fresh):
    a = bpy.data.images.new("A", 8, 8)
    tree = api.node_group("SG Triplanar Height", image=a)
    before = {g.name for g in bpy.data.node_groups}
    for planes in ([a, None, None], [None, a, None]):
        with pytest.raises(ValueError, match="three `images`"):
            api.node_group("SG Triplanar Height", images=planes)
    assert {g.name for g in bpy.data.node_groups} == before
    assert _taps(tree) == {("A", False, "REPEAT")}
    assert len([n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"]) == 9


@pytest.mark.tier("bake")
def test_numpy_numbers_and_a_quiet_log(fresh, tmp_path, capsys):
    obj = scenes.new_scene(["Plane"])["Plane"]
    mat = new_material("API")
    obj.data.materials.append(mat)
    api.add_layer_stack(mat)
    size = np.int64(16)
    out = api.bake_normal_map(obj, tmp_path / "n.png", resolution=size, samples=np.int64(1),
                              margin=np.int64(2), tiles=np.array([1001]), log=None)
    image = bpy.data.images.load(str(out))
    assert tuple(image.size) == (16, 16)
    bpy.data.images.remove(image)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "a.blend"))
    report = api.bake_batch(None, str(tmp_path / "{object}.png"), resolution=size,
                            samples=np.int64(1), workers=np.int64(0), log=None)
    assert [a["status"] for a in report["assets"].values()] == ["baked"]
    assert (tmp_path / "Plane.png").is_file()
    # Only Blender's own "Info:" lines: surfgrad's progress went nowhere.
    assert all(line.startswith("Info:") for line in capsys.readouterr().out.splitlines())
    from surfgrad_addon.harness import api as harness_api
    report = harness_api.compare(obj, "normal-map", resolution=size)
    assert report["texels_compared"] > 100 and report["max_deg"] < 0.5


def test_a_bake_without_the_cycles_add_on_is_refused(fresh, tmp_path):
    import addon_utils
    from surfgrad_addon.addon import freeze
    from surfgrad_addon.harness import api as harness_api
    obj = scenes.new_scene(["Plane"])["Plane"]
    mat = new_material("API")
    obj.data.materials.append(mat)
    api.add_layer_stack(mat)
    before = ({g.name for g in bpy.data.node_groups}, {i.name for i in bpy.data.images},
              len(mat.node_tree.nodes), bpy.context.scene.render.engine)
    bpy.ops.preferences.addon_disable(module="cycles")
    try:
        for call in (lambda: api.bake_normal_map(obj, tmp_path / "n.png", resolution=16),
                     lambda: harness_api.compare(obj, "normal-map", resolution=16),
                     lambda: freeze.check(obj, 16)):
            with pytest.raises(ValueError, match=r"Cycles add-on is disabled.*enable it"):
                call()
    finally:
        bpy.ops.preferences.addon_enable(module="cycles")
    assert addon_utils.check("cycles")[1] and hasattr(bpy.context.scene, "cycles")
    assert not list(tmp_path.iterdir())
    assert before == ({g.name for g in bpy.data.node_groups}, {i.name for i in bpy.data.images},
                      len(mat.node_tree.nodes), bpy.context.scene.render.engine)


@pytest.mark.tier("bake")
def test_bake_batch_keeps_the_open_file_and_takes_one_path(fresh, tmp_path):
    obj = scenes.new_scene(["Plane"])["Plane"]
    mat = new_material("API")
    obj.data.materials.append(mat)
    api.add_layer_stack(mat)
    asset = tmp_path / "asset.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(asset), copy=True)
    bpy.ops.mesh.primitive_cube_add()
    mine = tmp_path / "mine.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(mine))
    with pytest.raises(ValueError, match=r"workers=0 bakes in this session.*mine\.blend.*"
                                         r"workers=1 or more"):
        api.bake_batch([str(asset)], str(tmp_path / "{object}.png"), workers=0, log=None)
    assert bpy.data.filepath == str(mine) and "Cube" in bpy.data.objects
    assert not list(tmp_path.glob("*.png"))
    # A fresh session (nothing open: what a `blender -b -P script` starts with) may.
    bpy.ops.wm.read_factory_settings(use_empty=True)
    report = api.bake_batch(str(asset), str(tmp_path / "{object}.png"), objects="Plane",
                            workers=0, resolution=16, log=None)
    assert {k: v["status"] for k, v in report["assets"].items()} == {f"{asset}:Plane": "baked"}
    assert (tmp_path / "Plane.png").is_file()
