"""Red team 50d: the product on whole real assets of godotengine/godot-demo-projects
(mannequiny.glb: a skinned character, 3 materials, 2 UV maps, 2 colour attributes, custom
normals, 10 actions; the polyhaven dutch ship glTF: 3 objects with 1k normal maps, a hull on
tiles 1001-1002 and ropes with repeating UVs to v -10..7), imported on 5.2 and 4.2; each
finding is built here by code, a few faces, so no test reads a fetched or imported file.

1. An object-space bake of a mesh an Armature modifier deforms while its armature is posed
   (a character file saved on a frame of an animation, as the import leaves it: the glTF
   importer sets the first action, Blender shows its current frame): Blender bakes the mesh
   as it renders on that frame, so bake-normal-map, bake-batch and the API wrote the pose's
   normals with exit 0 and no word. mannequiny.glb saved on frame 10 of its idle action: its
   object-space map lay 87.3 degrees (median texel; p90 92.3) from the rest pose's, on 5.2
   and 4.2. Here a two-quad strip whose second bone is turned 60 degrees: that quad's texels
   60 degrees from the rest map's. Now a warning names the object, the armature, the
   modifier, the frame and the largest bone turn, and the fixes (Pose Position: Rest
   Position, or tangent space) (addon/deformed_mesh.py); with Rest Position, at rest, or in
   tangent space, no warning, and the rest-pose map is baked as before.

Probed and right on 5.2 and 4.2: tangent-space bakes of the posed mannequin (its constant
40-degree normal map baked back to 39.7 degrees median; the 7% of texels at 140 degrees lie
under its 5730 faces whose custom normals face away, which the bake warns of), compare
normal-map and triplanar on the posed mannequin at 32^2 (max 0.002 degrees on 5.2, 0.006 on
4.2; 80 backfacing texels left out and named), Add Layer Stack and Freeze on each of its 3
materials, bake-batch of the ship (hull on 1001 and 1002, sails; the ropes refused naming
--allow-partial, exit 0 for the batch with the failure listed).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.materials import diffuse_material  # noqa: E402

from support.baked_normals import baked_normals, degrees_between  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16
TURN_DEG = 60.0


def strip(name):
    """A fresh file holding two unit quads along x (vertices at x = 0, 1, 2; y = -0.5, 0.5),
    UVs: left half, right half; a diffuse material."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    verts = [(x, y, 0.0) for x in (0.0, 1.0, 2.0) for y in (-0.5, 0.5)]
    mesh = bpy.data.meshes.new("Strip")
    mesh.from_pydata(verts, [], [(0, 2, 3, 1), (2, 4, 5, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for poly in mesh.polygons:
        for li in poly.loop_indices:
            x, y, _z = verts[mesh.loops[li].vertex_index]
            uv.data[li].uv = (x / 2.0 * 0.98 + 0.01, (y + 0.5) * 0.98 + 0.01)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.data.materials.append(diffuse_material("Skin")[0])
    return obj


def _skinned_strip():
    """Two quads along x (UVs: left half, right half), bone 'A' over the first and 'B' over
    the second; B's vertices (x >= 1) follow B alone, so turning B turns the second quad
    rigidly about the joint and leaves the first in place."""
    obj = strip("Body")
    arm_data = bpy.data.armatures.new("Rig")
    arm = bpy.data.objects.new("Rig", arm_data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    for name, head, tail in (("A", (0, 0, 0), (1, 0, 0)), ("B", (1, 0, 0), (2, 0, 0))):
        bone = arm_data.edit_bones.new(name)
        bone.head, bone.tail = head, tail
    arm_data.edit_bones["B"].parent = arm_data.edit_bones["A"]
    bpy.ops.object.mode_set(mode="OBJECT")
    for name, ids in (("A", [0, 1]), ("B", [2, 3, 4, 5])):
        obj.vertex_groups.new(name=name).add(ids, 1.0, "REPLACE")
    md = obj.modifiers.new("Armature", "ARMATURE")
    md.object = arm
    return obj, arm


def _pose(arm, deg):
    pb = arm.pose.bones["B"]
    pb.rotation_mode = "XYZ"
    pb.rotation_euler = (np.radians(deg), 0.0, 0.0)     # about the bone's x: out of plane
    bpy.context.view_layer.update()


def _bake(obj, path, space):
    return baked_normals(obj, path, space, RES)


def _deg(a, b):
    return degrees_between(a, b)


def test_an_object_space_bake_of_a_posed_skinned_mesh_warns(tmp_path, capfd):
    """Finding 1: the map holds the pose (the second quad 60 degrees from the rest map), and
    the bake says so, naming the armature, the frame and the fixes."""
    obj, arm = _skinned_strip()
    rest = _bake(obj, tmp_path / "rest.exr", "object")
    assert "armature" not in capfd.readouterr().err
    assert _deg(rest, np.array([0.0, 0.0, 1.0])).max() < 0.5       # flat strip at rest
    _pose(arm, TURN_DEG)
    bpy.context.scene.frame_set(7)
    posed = _bake(obj, tmp_path / "posed.exr", "object")
    err = capfd.readouterr().err
    off = _deg(posed, rest)
    assert off[:, : RES // 2 - 1].max() < 0.5                       # the first quad stays
    assert abs(np.median(off[:, RES // 2 + 1:]) - TURN_DEG) < 1.0    # the second turned
    assert "armature 'Rig'" in err and "object 'Body'" in err, err
    assert "frame 7" in err and "60.0 degrees" in err and "Rest Position" in err, err
    assert "tangent space" in err


def test_no_warning_at_rest_or_in_tangent_space(tmp_path, capfd):
    """A tangent-space bake of the posed strip holds in every pose: no warning. With Pose
    Position: Rest Position, the object-space map is the rest map, and no warning."""
    obj, arm = _skinned_strip()
    _pose(arm, TURN_DEG)
    tangent = _bake(obj, tmp_path / "t.exr", "tangent")
    assert _deg(tangent, np.array([0.0, 0.0, 1.0])).max() < 0.5
    assert "armature" not in capfd.readouterr().err
    arm.data.pose_position = "REST"
    bpy.context.view_layer.update()
    rest = _bake(obj, tmp_path / "r.exr", "object")
    assert _deg(rest, np.array([0.0, 0.0, 1.0])).max() < 0.5
    assert "armature" not in capfd.readouterr().err
    arm.data.pose_position = "POSE"
    _pose(arm, 0.0)
    _bake(obj, tmp_path / "z.exr", "object")
    assert "armature" not in capfd.readouterr().err
