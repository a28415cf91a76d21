"""Far from the origin, as precise as at the origin: a bake's temporary second user of the mesh.

For a mesh used by one object, Cycles stores the triangles in world space, float32
(SD_OBJECT_TRANSFORM_APPLIED); 10 km out the grid is 2^-10 m and every derivative the Bump node
takes of the shading point is rounded with it (README, "Far from the origin"). A mesh with two
object users stays in object space. So a bake of a far object links, for the bake only, a
second object sharing its mesh: visible to camera rays alone, which a bake never casts (it
starts on the surface itself), so nothing in the map can see it; with every ray type off, or
hidden from render, Cycles does not count it (measured: no precision gained). The twin is
removed after the bake: no object, link or orphan is left, the mesh's users are as before.

Where an object's evaluated mesh is its own (render-enabled modifiers), Cycles keys its geometry
by the object and no second object can share it: the route cannot help, and a warning says so.
"""

from contextlib import contextmanager

# Beyond this distance from the origin (any corner of the world bounding box) a bake takes the
# precise route. Measured without it (compare, 64^2, worst of Sphere and Transformed, 5.2):
# parallax max 0.11 / 0.34 / 1.5 deg at 100 m / 300 m / 1 km, the other Bump-node methods p99
# 0.002 and max 0.005 at 100 m. Nearer, the single-user storage (the one renders use) is kept.
FAR_METRES = 100.0
# The sidebar warns for renders from here on: the Bump-based groups' error passes ~0.05 deg
# p99 and 1 deg max around 1 km (README table).
RENDER_WARN_METRES = 1000.0
TWIN_SUFFIX = " (surfgrad precise bake)"
_RAYS = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
         "visible_volume_scatter", "visible_shadow")


def distance_from_origin(obj):
    """The largest distance (m) of obj's world bounding box corners from the origin."""
    m = obj.matrix_world
    return max((m @ _vec(c)).length for c in obj.bound_box)


def _vec(corner):
    from mathutils import Vector
    return Vector(corner)


def has_own_geometry(obj):
    """True when obj's render mesh is its own (a modifier enabled for render): Cycles then keys
    the geometry by the object and a second object cannot share it."""
    return any(md.show_render for md in obj.modifiers)


def far_warning(obj):
    """Why a bake of obj far out cannot be made precise, or None."""
    if obj is None or obj.type != "MESH" or not has_own_geometry(obj):
        return None
    d = distance_from_origin(obj)
    if d <= FAR_METRES:
        return None
    return (f"object {obj.name!r} is {_km(d)} from the origin and has modifiers: Cycles keeps "
            f"its evaluated mesh in world space (float32), so Bump-based detail (height maps, "
            f"parallax, detail layers) may be off by up to a few degrees; apply the modifiers "
            f"or move it near the origin for a bake as precise as at the origin")


def _km(d):
    return f"{d / 1000:.1f} km" if d >= 1000 else f"{d:.0f} m"


@contextmanager
def precise_far(obj, log=None):
    """For the duration: obj's mesh has a second user Cycles counts and no bake ray sees, when
    obj is farther out than FAR_METRES (else nothing is done). The twin, its link and its
    object are removed on exit, whatever happens. Yields the twin or None."""
    import bpy
    if obj is None or obj.type != "MESH" or distance_from_origin(obj) <= FAR_METRES:
        yield None
        return
    warning = far_warning(obj)
    if warning:
        if log:
            log(f"warning: {warning}")
        yield None
        return
    twin = bpy.data.objects.new(obj.name + TWIN_SUFFIX, obj.data)
    try:
        twin.matrix_world = obj.matrix_world
        for flag in _RAYS:
            setattr(twin, flag, flag == "visible_camera")
        bpy.context.scene.collection.objects.link(twin)
        bpy.context.view_layer.update()
        yield twin
    finally:
        bpy.data.objects.remove(twin, do_unlink=True)
        bpy.context.view_layer.update()     # else the view layer lists a stale empty base


def uses_surfgrad_groups(obj):
    """True when a material of obj holds a surface-gradient group node (at any depth)."""
    from .node_builder import VERSION_KEY
    seen = set()

    def walk(tree):
        if tree is None or tree.name_full in seen:
            return False
        seen.add(tree.name_full)
        for node in tree.nodes:
            sub = getattr(node, "node_tree", None)
            if node.bl_idname == "ShaderNodeGroup" and sub is not None and \
                    (VERSION_KEY in sub or walk(sub)):
                return True
        return False
    return any(s.material is not None and walk(s.material.node_tree)
               for s in getattr(obj, "material_slots", ()))


def render_precision_warning(obj):
    """The sidebar's note for renders: None, or the text saying obj is far enough out for the
    groups to lose precision and what to do."""
    if obj is None or obj.type != "MESH" or not uses_surfgrad_groups(obj):
        return None
    d = distance_from_origin(obj)
    if d <= RENDER_WARN_METRES:
        return None
    return (f"{obj.name} is {_km(d)} from the origin: Cycles renders its single-user mesh in "
            f"float32 world space, so Bump-based groups (height maps, parallax, detail "
            f"layers) lose precision. Move the scene near the origin, or give the mesh a "
            f"second user (a linked duplicate, Alt+D, out of view). Bakes do this themselves.")
