"""An object-space bake of a mesh an Armature modifier deforms while its armature is posed
away from its rest pose (a character file saved on a frame of an animation): Blender bakes the
mesh as it renders on the current frame, so the object-space map holds that pose's normals and
reads back right in that pose alone; in the rest pose (the bind pose an engine skins from) and
every other pose it is off by the bones' turns. Measured (red team 50d,
tests/test_faults_assets50d.py): godot-demo-projects' mannequiny.glb saved on frame 10 of its
idle action baked an object-space map 87 degrees (median texel) from the rest pose's, exit 0
and no word. A tangent-space map follows the deformation and holds in every pose."""

import numpy as np

# A bone turned less than this from its rest (float noise of an imported rest pose) is at rest.
MAX_TURN_DEG = 0.01


def _turn_deg(posed, rest):
    """Degrees between the rotation parts of two bone matrices (armature space)."""
    a = np.asarray(posed, dtype=np.float64)[:3, :3]
    b = np.asarray(rest, dtype=np.float64)[:3, :3]
    a = a / np.linalg.norm(a, axis=0)
    b = b / np.linalg.norm(b, axis=0)
    c = (np.trace(a.T @ b) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _moved(posed, rest):
    """The bone's pose moves or scales it (not only turns it) away from its rest."""
    a = np.asarray(posed, dtype=np.float64)[:3, :4]
    b = np.asarray(rest, dtype=np.float64)[:3, :4]
    scale = max(1.0, float(np.abs(b).max()))
    return bool(np.abs(a - b).max() > 1e-5 * scale)


def posed_armature_warning(obj, depsgraph):
    """None, or the warning for an object-space bake of obj while an Armature modifier it
    renders with deforms it by a pose other than the rest pose, naming the armature, the
    frame, the largest bone turn and the fixes."""
    import bpy
    frame = bpy.context.scene.frame_current
    for md in obj.modifiers:
        arm = getattr(md, "object", None) if md.type == "ARMATURE" else None
        if not md.show_render or arm is None or arm.type != "ARMATURE" \
                or arm.data.pose_position != "POSE" or arm.pose is None:
            continue
        evaluated = arm.evaluated_get(depsgraph)
        bones = evaluated.pose.bones if evaluated.pose else ()
        turns = [(_turn_deg(pb.matrix, pb.bone.matrix_local), _moved(pb.matrix, pb.bone.matrix_local))
                 for pb in bones]
        worst = max((t for t, _m in turns), default=0.0)
        if worst <= MAX_TURN_DEG and not any(m for _t, m in turns):
            continue
        return (f"object {obj.name!r} is deformed by armature {arm.name!r} (modifier "
                f"{md.name!r}) in a pose other than its rest pose on frame {frame} (a bone "
                f"turned up to {worst:.1f} degrees): the object-space map holds this pose's "
                f"normals and reads back right in this pose alone. For a map that fits the "
                f"rest pose, set the armature's Pose Position to Rest Position (Object Data > "
                f"Skeleton) before baking; or bake in tangent space, which holds in every pose")
    return None
