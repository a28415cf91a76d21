"""Review 54a: hostile review of round 53's merges (b91a8c8..abdec51).

1. The pose warning measured by face turn (rt53b, addon/deformed_mesh._face_turn) read the
   mesh from the viewport's depsgraph, while the bake evaluates it in render mode. Where the
   Armature modifier is shown in renders but not in the viewport (its monitor icon off, a
   common way to keep a heavy rig light), or the mesh is disabled in viewports, the viewport
   mesh is undeformed in both poses: the faces' turn read 0.0 degrees and the warning was
   dropped, while the bake baked the pose. Here the door of test_faults_assets53b with its
   right panel turned 30 degrees: the object-space map lay 30.0 degrees (median texel) off
   the rest pose's, exit 0, no warning (before: posed_armature_warning None in both cases;
   before rt53b both were warned). Now the face turn reads the mesh as the bake does
   (bake_uvs.read_as_baked: the render-mode pass for a modified object): warned, "its faces
   turned up to 30.0 degrees", the Pose Position put back.

2. Freeze's look inside the artist's wrapper groups (rt53a, freeze._tree_reads_object_space)
   counted a Texture Coordinate's Object (or a Geometry node's Position) only where it led to
   a node inside the group, not where it led straight to the Group Output: a coordinates group
   (Texture Coordinate > Object into Group Output, a common utility group) feeding the layered
   stack's SG Noise Vector was no object-space reader (object_space_readers: [] where the same
   Texture Coordinate node unwrapped is named), so a strip posed 60 degrees froze a map whose
   posed half lay 30.4 degrees (median texel, max 94) from the rest pose's, no warning. Now the
   Group Output counts as part of the group's stack: named, "'Coords' (Coords)", warned.

3. The render-mode pass (addon/render_mesh.read_in_render_mode, now 16 x 16 since rt53b) that
   every bake, Freeze and compare of an object with a modifier runs rendered into the Render
   Result's active slot: an artist's unsaved render there (F11, here 24 x 12 Cycles, mean
   colour (0.81, 0.50, 0.40)) was replaced by the probe's empty one, lost ("Image 'Render
   Result' could not be saved"), exit 0, on 5.2 and 4.2. Now the pass renders into a slot of
   its own ('surfgrad probe (empty)', made once, emptied after; Blender's Python cannot
   remove a slot) and the artist's active slot is made active again: their render is saved
   after the pass pixel for pixel as before it.

4. Slowdown: the pose check of an object-space bake (deformed_mesh._posed) walked every vertex's
   groups in Python (rt53a's followed bones) and then measured the faces' turn (rt53b), which
   answers the same question. On a 501,264-vertex grid, a rig of two bones, one slid: the
   check took 1.85 s (best of 4, 5.2, 2 shared cores), the walk ~0.9 s of it. Now an
   object-space check measures the faces alone and names the bone turn of the bones a vertex
   group names: 0.96 s, the same warnings (the walk stays for Freeze's check, which has no
   face measure, and where the faces cannot be measured: a linked armature).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.baked_normals import baked_normals, degrees_between  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from test_faults_assets50d import _pose, _skinned_strip  # noqa: E402
from test_faults_assets53b import _door, _panels, _positions  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16


def _turn_right_panel(arm):
    r = arm.pose.bones["R"]
    r.rotation_mode = "XYZ"
    r.rotation_euler = (np.radians(30.0), 0.0, 0.0)
    bpy.context.view_layer.update()


def _warning(obj):
    from surfgrad_addon.addon.deformed_mesh import posed_armature_warning
    return posed_armature_warning(obj, bpy.context.evaluated_depsgraph_get()) or ""


def test_a_pose_shown_in_renders_only_is_warned_of(tmp_path, capfd):
    """Finding 1: the Armature modifier off in the viewport, on in renders."""
    obj, arm = _door()
    arm.data.pose_position = "REST"
    rest = baked_normals(obj, tmp_path / "rest.exr", "object", RES)
    arm.data.pose_position = "POSE"
    obj.modifiers["Armature"].show_viewport = False
    _turn_right_panel(arm)
    before = _positions(obj)
    capfd.readouterr()
    posed = baked_normals(obj, tmp_path / "posed.exr", "object", RES)
    err = capfd.readouterr().err
    left, right = _panels()
    off = degrees_between(posed, rest)
    assert abs(np.median(off[1:-1, right]) - 30.0) < 0.5       # the bake took the pose
    assert off[1:-1, left].max() < 0.01
    assert "armature 'DoorRig'" in err and "its faces turned up to 30.0 degrees" in err, err
    assert arm.data.pose_position == "POSE"
    assert obj.modifiers["Armature"].show_viewport is False
    assert np.array_equal(_positions(obj), before)


def test_a_posed_mesh_disabled_in_viewports_is_warned_of():
    """Finding 1: the mesh disabled in viewports (Disable in Viewports), rendered."""
    obj, arm = _door()
    obj.hide_viewport = True
    _turn_right_panel(arm)
    text = _warning(obj)
    assert "armature 'DoorRig'" in text and "its faces turned up to 30.0 degrees" in text, text
    assert arm.data.pose_position == "POSE" and obj.hide_viewport


def test_a_pose_shown_everywhere_is_warned_of_as_before():
    obj, arm = _door()
    _turn_right_panel(arm)
    assert "its faces turned up to 30.0 degrees" in _warning(obj)


# 2 --------------------------------------------------------------------------------------------

def _coordinates_group(tree, output="Object"):
    """The stack's SG Noise given its Vector by the artist's group 'Coords': a Texture
    Coordinate node's `output` linked straight to the group's output."""
    noise = next(n for n in tree.nodes if n.type == "GROUP" and
                 n.node_tree.name.startswith("SG Noise"))
    group = bpy.data.node_groups.new("Coords", "ShaderNodeTree")
    group.interface.new_socket("Vector", in_out="OUTPUT", socket_type="NodeSocketVector")
    coords = group.nodes.new("ShaderNodeTexCoord")
    group.links.new(coords.outputs[output], group.nodes.new("NodeGroupOutput").inputs[0])
    node = tree.nodes.new("ShaderNodeGroup")
    node.name = "Coords"
    node.node_tree = group
    tree.links.new(node.outputs[0], noise.inputs["Vector"])


def test_a_coordinates_group_is_an_object_space_reader():
    for output, expected in (("Object", ["'Coords' (Coords)"]), ("UV", [])):
        obj, _arm = _skinned_strip()
        mat, _bsdf = layered_material(obj)
        _coordinates_group(mat.node_tree, output)
        _end, fed = F.find_stack(mat.node_tree)
        assert F.object_space_readers(mat.node_tree, fed) == expected, output


def _frozen(obj):
    mat, _bsdf = layered_material(obj)
    _coordinates_group(mat.node_tree)
    said = []
    F.freeze(obj, 32, log=lambda *_: None, warn=said.append)
    image = next(i for i in bpy.data.images if "frozen" in i.name)
    px = np.array(image.pixels[:]).reshape(32, 32, 4)[..., :3] * 2.0 - 1.0
    return px / np.linalg.norm(px, axis=-1, keepdims=True), said


def test_freezing_posed_through_a_coordinates_group_warns():
    obj, _arm = _skinned_strip()
    rest, quiet = _frozen(obj)
    assert quiet == []
    obj, arm = _skinned_strip()
    _pose(arm, 60.0)
    posed, said = _frozen(obj)
    off = degrees_between(posed, rest)
    assert off[:, :15].max() < 0.01 and np.median(off[:, 17:]) > 10.0, np.median(off[:, 17:])
    (text,) = [w for w in said if "armature" in w]
    assert "'Coords' (Coords)" in text and "Rest Position" in text, text


# 3 --------------------------------------------------------------------------------------------

def _saved_render(tmp_path, tag):
    """The Render Result's active slot saved and read back: (H, W, 4) pixels."""
    path = tmp_path / f"{tag}.png"
    bpy.data.images["Render Result"].save_render(str(path))
    image = bpy.data.images.load(str(path))
    try:
        return np.array(image.pixels[:]).reshape(image.size[1], image.size[0], 4)
    finally:
        bpy.data.images.remove(image)


def test_the_render_mode_pass_keeps_the_artists_render(tmp_path):
    from surfgrad_addon.addon.render_mesh import PROBE_SLOT, read_in_render_mode
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.render.resolution_x, scene.render.resolution_y = 24, 12
    scene.render.resolution_percentage = 100
    scene.world = bpy.data.worlds.new("Orange")
    if scene.world.node_tree is None:          # (5.x: a new world has its nodes)
        scene.world.use_nodes = True
    scene.world.node_tree.nodes["Background"].inputs[0].default_value = (1.0, 0.2, 0.1, 1.0)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -10.0, 0.0)
    camera.rotation_euler = (np.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    cube.modifiers.new("Subdivision", "SUBSURF")
    assert bpy.ops.render.render() == {"FINISHED"}             # the artist's render, unsaved
    slots = bpy.data.images["Render Result"].render_slots
    slots.active_index = 2
    assert bpy.ops.render.render() == {"FINISHED"}
    theirs = _saved_render(tmp_path, "theirs")
    assert theirs.shape == (12, 24, 4) and theirs[..., 0].mean() > 0.5     # orange, not black
    for _ in range(2):
        read_in_render_mode(cube, lambda _depsgraph: None)
        assert slots.active_index == 2
        assert np.array_equal(_saved_render(tmp_path, "after"), theirs)
    assert [s.name for s in slots].count(PROBE_SLOT) == 1
    assert (scene.render.resolution_x, scene.render.resolution_y) == (24, 12)


# 4 --------------------------------------------------------------------------------------------

def test_an_object_space_check_does_not_walk_the_vertices(monkeypatch):
    from surfgrad_addon.addon import deformed_mesh as D

    def walked(*_args):
        raise AssertionError("the vertex walk ran where the faces' turn was measured")
    monkeypatch.setattr(D, "_followed", walked)
    obj, arm = _door()
    arm.pose.bones["L"].location = (-0.42, 0.0, 0.1)       # slid: no face turns
    ctrl = arm.pose.bones["ctrl"]                           # weighted to nothing
    ctrl.rotation_mode = "XYZ"
    ctrl.rotation_euler = (np.radians(90.0), 0.0, 0.0)
    bpy.context.view_layer.update()
    assert _warning(obj) == ""
    _turn_right_panel(arm)
    text = _warning(obj)
    # the bone turn named is the weighted bone's 30, not the control bone's 90
    assert "a bone turned up to 30.0 degrees, its faces turned up to 30.0 degrees" in text, text
