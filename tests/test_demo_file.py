"""The repository's demo.blend opens and renders on every supported line. It is saved with
Blender 4.5 LTS, the oldest line that has every feature it shows (SG Displace needs 4.5's Set
Mesh Normal): 4.5, 5.0 and 5.2 open it whole; 4.2 opens it with Blender's "newer file" warning
and one undefined node, SG Displace's Set Mesh Normal, so its displacement exhibit shows the
mesh undisplaced (README, docs/versions.md)."""

from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.tier("blender")


DEMO = Path(__file__).resolve().parents[1] / "demo.blend"
EXHIBITS = ("layered", "triplanar", "decal", "noise", "height", "displacement", "parallax",
            "decal-shapes")
# The Sampler exhibit needs closures (5.0+): its own file, saved with 5.0.
CLOSURES = Path(__file__).resolve().parents[1] / "demo_closures.blend"


@pytest.fixture(scope="module")
def demo_file():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=str(DEMO))
    yield
    bpy.ops.wm.read_factory_settings(use_empty=True)


def test_demo_blend_is_saved_by_the_oldest_line_with_every_feature(demo_file):
    assert tuple(bpy.data.version[:2]) == (4, 5)
    cams = {o.name.removeprefix("Camera ") for o in bpy.data.objects if o.type == "CAMERA"}
    assert set(EXHIBITS) <= cams
    undefined = [(g.name, n.name) for g in bpy.data.node_groups for n in g.nodes
                 if n.bl_idname == "NodeUndefined"]
    undefined += [(m.name, n.name) for m in bpy.data.materials if m.node_tree
                  for n in m.node_tree.nodes if n.bl_idname == "NodeUndefined"]
    if bpy.app.version >= (4, 5, 0):
        assert undefined == []
    else:
        assert undefined == [("SG Displace", "Set Mesh Normal")]
    assert all(img.packed_file is not None for img in bpy.data.images)


@pytest.mark.tier("bake")
@pytest.mark.parametrize("exhibit", ["decal", "triplanar", "decal-shapes"])
def test_demo_exhibit_renders(demo_file, exhibit, tmp_path):
    """A small Cycles render of an exhibit: finite, not blank, and the surface-gradient side
    (right half) is shaded."""
    scene = bpy.context.scene
    saved = (scene.camera, scene.render.resolution_x, scene.render.resolution_y,
             scene.render.resolution_percentage, scene.cycles.samples, scene.render.filepath,
             scene.render.image_settings.file_format)
    try:
        scene.camera = bpy.data.objects[f"Camera {exhibit}"]
        scene.render.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.render.resolution_x, scene.render.resolution_y = 96, 54
        scene.render.resolution_percentage = 100
        scene.cycles.samples = 4
        scene.render.image_settings.file_format = "OPEN_EXR"
        scene.render.filepath = str(tmp_path / f"{exhibit}.exr")
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(str(tmp_path / f"{exhibit}.exr"))
        px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
        img.pixels.foreach_get(px)
        px = px.reshape(img.size[1], img.size[0], 4)[..., :3]
        bpy.data.images.remove(img)
    finally:
        (scene.camera, scene.render.resolution_x, scene.render.resolution_y,
         scene.render.resolution_percentage, scene.cycles.samples, scene.render.filepath,
         scene.render.image_settings.file_format) = saved
    assert np.isfinite(px).all()
    right = px[:, px.shape[1] // 2:]
    assert right.mean() > 0.02 and right.std() > 0.01          # lit and shaded, not blank


@pytest.mark.skipif(not hasattr(bpy.types, "NodeEvaluateClosure"),
                    reason="demo_closures.blend shows Sampler closures, which exist from "
                           "Blender 5.0 (docs/versions.md)")
def test_closure_demo_opens_whole_from_5_0():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        bpy.ops.wm.open_mainfile(filepath=str(CLOSURES))
        assert tuple(bpy.data.version[:2]) == (5, 0)
        assert "Camera sampler" in bpy.data.objects
        nodes = [n for m in bpy.data.materials if m.node_tree for n in m.node_tree.nodes]
        nodes += [n for g in bpy.data.node_groups for n in g.nodes]
        assert not [n.name for n in nodes if n.bl_idname == "NodeUndefined"]
        assert sum(n.bl_idname == "NodeClosureOutput" for n in nodes) == 2
        assert all(img.packed_file is not None for img in bpy.data.images)
    finally:
        bpy.ops.wm.read_factory_settings(use_empty=True)
