"""Cycles' rule for where it stores an object's triangles: world space or object space.

Cycles (blender/geometry.cpp, sync_geometry) keys the geometry it builds by the OBJECT when the
object is modified for renders (Object.is_modified(scene, 'RENDER'): a modifier enabled for
renders, or shape keys) and the instance's data is the object's own, else by the instance's
evaluated data (unmodified objects sharing a mesh share one evaluated mesh: measured, 4.2 and
5.2; a modified object's evaluated mesh is its own). It skips instances with every ray type off
("don't export completely invisible objects") and those not shown (show_self). Its scene then
applies the object transform, float32 world space (SD_OBJECT_TRANSFORM_APPLIED), to geometry
used by exactly one object. Fake users, users in other scenes, and objects hidden from render
are not in the render depsgraph, so they do not count.
"""

RAYS = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
        "visible_volume_scatter", "visible_shadow")


def own_geometry(obj, scene):
    """True when Cycles keys obj's geometry by the object (no second object can share it)."""
    return obj.type == "MESH" and bool(obj.is_modified(scene, "RENDER"))


def _key(iter_object, real_object, scene):
    data = iter_object.data
    if data is None:
        return None
    original = real_object.original
    if data == real_object.data and original.is_modified(scene, "RENDER"):
        return ("object", original.as_pointer())
    return ("data", data.as_pointer())


def _exported(inst):
    o = inst.object
    return inst.show_self and any(getattr(o, ray, True) for ray in RAYS)


def geometry_users(obj, depsgraph):
    """How many objects Cycles builds from obj's geometry in `depsgraph` (instances included)."""
    scene = depsgraph.scene
    eval_obj = obj.evaluated_get(depsgraph)
    mine = _key(eval_obj, eval_obj, scene)
    count = 0
    for inst in depsgraph.object_instances:
        if inst.object.type != obj.type or not _exported(inst):
            continue
        real = inst.instance_object if inst.is_instance else inst.object
        if _key(inst.object, real, scene) == mine:
            count += 1
    return count


def transform_applied(obj, depsgraph):
    """True when Cycles stores obj's triangles in world space (float32): its geometry has one
    user in `depsgraph` (an object not in it is taken as that one user)."""
    return geometry_users(obj, depsgraph) <= 1
