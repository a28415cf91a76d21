"""Far from the origin, as precise as at the origin: a bake's temporary second user of the mesh.

For geometry used by one object, Cycles stores the triangles in world space, float32
(SD_OBJECT_TRANSFORM_APPLIED); 10 km out the grid is 2^-10 m and every derivative the Bump node
takes of the shading point is rounded with it (README, "Far from the origin"). Geometry with two
object users stays in object space (the rule: cycles_geometry.py). So a bake of a far object
links, for the bake only, a second object sharing its mesh: visible to camera rays alone, which
a bake never casts (it starts on the surface itself), so nothing in the map can see it; with
every ray type off, or hidden from render, Cycles does not count it (measured: no precision
gained).

An object modified for renders (modifiers, shape keys) has geometry of its own in Cycles, keyed
by the object, which no second object can share. For those, the route first bakes the render
mesh into a temporary mesh: Blender's own render-mode evaluation (render_mesh.py) copied with
every data layer (UV maps, custom normals, sharp edges and faces, attributes, material slots),
given to the object in place of its mesh while its modifiers are off for renders and the
viewport. The object then shades exactly as before (tested at the origin: the same map) but its
geometry is a plain mesh the twin can share.

On exit everything is put back, whatever happens: the twin and the temporary mesh are removed
(no object, link or orphan is left), the object's mesh, modifier switches, Multires levels,
material slots and shape-key settings are as before, and so are the mesh's users.
"""

from contextlib import ExitStack, contextmanager

from .cycles_geometry import RAYS as _RAYS, own_geometry

# Beyond this distance from the origin (any corner of the world bounding box) a bake takes the
# precise route. Measured without it (compare, 64^2, worst of Sphere and Transformed, 5.2):
# parallax max 0.11 / 0.34 / 1.5 deg at 100 m / 300 m / 1 km, the other Bump-node methods p99
# 0.002 and max 0.005 at 100 m. Nearer, the single-user storage (the one renders use) is kept.
FAR_METRES = 100.0
# The sidebar warns for renders from here on: the Bump-based groups' error passes ~0.05 deg
# p99 and 1 deg max around 1 km (README table).
RENDER_WARN_METRES = 1000.0
TWIN_SUFFIX = " (surfgrad precise bake)"


def distance_from_origin(obj):
    """The largest distance (m) of obj's world bounding box corners from the origin."""
    m = obj.matrix_world
    return max((m @ _vec(c)).length for c in obj.bound_box)


def _vec(corner):
    from mathutils import Vector
    return Vector(corner)


def _km(d):
    return f"{d / 1000:.1f} km" if d >= 1000 else f"{d:.0f} m"


def is_far(obj):
    """True when a bake of obj takes the precise route."""
    return obj is not None and obj.type == "MESH" and distance_from_origin(obj) > FAR_METRES


@contextmanager
def precise_far(obj, log=None):
    """For the duration: obj's geometry has a second user Cycles counts and no bake ray sees,
    when obj is farther out than FAR_METRES (else nothing is done). An object modified for
    renders first gets its render mesh as a plain mesh (render_mesh_swapped). Everything is
    put back on exit, whatever happens. Yields the twin or None."""
    import bpy
    if not is_far(obj):
        yield None
        return
    with ExitStack() as stack:
        if own_geometry(obj, bpy.context.scene):
            if obj.library is not None:         # a linked object's mesh cannot be swapped
                if log:
                    log(f"warning: object {obj.name!r} is {_km(distance_from_origin(obj))} from "
                        f"the origin, modified for renders and linked from "
                        f"{obj.library.filepath!r}: Cycles keeps its evaluated mesh in world "
                        f"space (float32), so Bump-based detail (height maps, parallax, detail "
                        f"layers) may be off by up to a few degrees; make it local or move it "
                        f"near the origin for a bake as precise as at the origin")
                yield None
                return
            stack.enter_context(render_mesh_swapped(obj))
            if log:
                log(f"      {obj.name}: {_km(distance_from_origin(obj))} from the origin; its "
                    f"render mesh is baked from a temporary copy shared with a hidden twin")
        twin = bpy.data.objects.new(obj.name + TWIN_SUFFIX, obj.data)
        stack.callback(_remove_twin, twin)
        twin.matrix_world = obj.matrix_world
        for flag in _RAYS:
            setattr(twin, flag, flag == "visible_camera")
        bpy.context.scene.collection.objects.link(twin)
        bpy.context.view_layer.update()
        yield twin


def _remove_twin(twin):
    import bpy
    bpy.data.objects.remove(twin, do_unlink=True)
    bpy.context.view_layer.update()     # else the view layer lists a stale empty base


_MULTIRES = ("levels", "sculpt_levels", "render_levels")
_SHAPE = ("active_shape_key_index", "show_only_shape_key", "use_shape_key_edit_mode")


@contextmanager
def render_mesh_swapped(obj):
    """For the duration, obj's mesh is a temporary copy of its RENDER-evaluated mesh and its
    modifiers are off (renders and viewport), so its shading is unchanged but its geometry is a
    plain mesh (no modifier, no shape key). Yields the temporary mesh. On exit: obj's own mesh,
    modifier switches, Multires levels (reset by Blender when the mesh changes), material slots
    and shape-key settings are put back and the temporary mesh is removed."""
    import bpy
    from .render_mesh import read_in_render_mode

    original = obj.data
    switches = [(md, md.show_render, md.show_viewport) for md in obj.modifiers]
    levels = [(md, {k: getattr(md, k) for k in _MULTIRES}) for md in obj.modifiers
              if md.type == "MULTIRES"]
    slots = [(s.link, s.material) for s in obj.material_slots]
    shape = {k: getattr(obj, k) for k in _SHAPE}
    made = []

    def copy(depsgraph):
        made.append(bpy.data.meshes.new_from_object(
            obj.evaluated_get(depsgraph), preserve_all_data_layers=True, depsgraph=depsgraph))
    try:
        read_in_render_mode(obj, copy)
    except BaseException:
        for mesh in made:                       # the pass failed after the copy was made
            bpy.data.meshes.remove(mesh)
        raise
    mesh = made[0]
    mesh.name = f".{original.name} (surfgrad precise bake)"
    try:
        obj.data = mesh
        for md, _, _ in switches:
            md.show_render = md.show_viewport = False
        _put_slots(obj, slots)
        bpy.context.view_layer.update()
        yield mesh
    finally:
        obj.data = original
        for md, render, viewport in switches:
            md.show_render, md.show_viewport = render, viewport
        for md, values in levels:
            for k, v in values.items():
                if getattr(md, k) != v:
                    setattr(md, k, v)
        _put_slots(obj, slots)
        for k, v in shape.items():
            if getattr(obj, k) != v:
                setattr(obj, k, v)
        bpy.data.meshes.remove(mesh)
        bpy.context.view_layer.update()


def _put_slots(obj, slots):
    """obj's material slots as in `slots` [(link, material)] where the mesh has as many."""
    for slot, (link, material) in zip(obj.material_slots, slots):
        if slot.link != link:
            slot.link = link
        if link == "OBJECT" and slot.material != material:
            slot.material = material


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
