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
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.baked_normals import baked_normals, degrees_between  # noqa: E402
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
