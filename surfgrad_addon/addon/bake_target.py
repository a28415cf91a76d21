"""Whether an object can be baked as it is, and the visibility a bake needs, lent and given back.

Blender's bake operator works on selectable, visible objects of the active view layer, and
writes into the object's materials: an object linked from a library cannot take a temporary
material, and one hidden in the viewport makes the operator fail with "context is incorrect".
Holdout (the object's or a collection's) bakes zero-length normals and a view layer's material
override bakes that material instead: both are lifted for the bake, like the hiding. So are
two flags that make Cycles leave the object out (cycles_geometry.py): every ray visibility off
(Object > Visibility > Ray Visibility), and Show Instancer for Render off on an object that
instances (a particle emitter, vertex or face instancing); either baked the background, a
grey map of zero-length normals, with exit 0.
"""

from contextlib import contextmanager

from .cycles_geometry import RAYS
from .material_inputs import missing_library_problem


# What to call an object type in a refusal (else its name: "an empty", "a light").
_KINDS = {"CURVE": "a curve", "SURFACE": "a NURBS surface", "FONT": "a text object",
          "META": "a metaball", "CURVES": "a hair curves object", "POINTCLOUD": "a point cloud",
          "GPENCIL": "a grease pencil object", "GREASEPENCIL": "a grease pencil object"}
# Those that Object > Convert > Mesh turns into faces a bake can take (hair curves and point
# clouds become loose edges and vertices).
_CONVERTIBLE = ("CURVE", "SURFACE", "FONT", "META")


def not_a_mesh(name, kind, pick="pick a mesh object"):
    """The refusal of object `name` of type `kind` (Object.type), with the fix."""
    what = _KINDS.get(kind) or \
        f"{'an' if kind[:1] in 'AEIOU' else 'a'} {kind.lower().replace('_', ' ')}"
    fix = pick + (", or convert it (Object > Convert > Mesh) and unwrap the mesh"
                  if kind in _CONVERTIBLE else "")
    return f"object {name!r} is {what}, not a mesh: {fix}"


def object_not_a_mesh(obj, pick="pick a mesh object"):
    """not_a_mesh for obj; an Empty that instances a collection (an asset placed as a
    collection instance) also names the mesh objects it shows, the ones to bake."""
    text = not_a_mesh(obj.name, obj.type, pick)
    shown = obj.instance_collection if obj.instance_type == "COLLECTION" else None
    meshes = sorted(o.name for o in shown.all_objects if o.type == "MESH") if shown else []
    if not meshes:
        return text
    return (f"{text}; it shows collection {shown.name!r}, whose mesh object(s) {meshes} are "
            f"what to bake")


def bake_target_problem(obj, view_layer):
    """None when obj can be baked, else a message naming the problem and the fix."""
    if obj is None:
        return "no object given: pick a mesh object to bake"
    missing = missing_library_problem(obj)     # (its placeholder is an empty)
    if missing:
        return missing
    if obj.type != "MESH":
        return object_not_a_mesh(obj)
    for what, block in (("object", obj), ("mesh", obj.data)):
        if getattr(block, "library", None) is not None:
            return (f"{what} {block.name!r} of {obj.name!r} is linked from library "
                    f"{block.library.filepath!r} and cannot take the bake's material: make it "
                    f"local (Object > Relations > Make Local > Selected Objects and Data) or "
                    f"bake in the library file")
        if getattr(block, "override_library", None) is not None and block is obj.data:
            return (f"mesh {block.name!r} of {obj.name!r} is a library override: make it local "
                    f"(Object > Relations > Make Local) to bake")
    if not _in_view_layer(obj, view_layer.layer_collection):
        return _outside_view_layer(obj, view_layer)
    if len(obj.data.polygons) == 0:
        return f"mesh {obj.data.name!r} of {obj.name!r} has no faces to bake"
    return None


def _outside_view_layer(obj, view_layer):
    """Why obj, not in view_layer, is not (another scene, only a collection instance shows it,
    an excluded collection), and the fix."""
    import bpy
    scene = view_layer.id_data
    here = f"scene {scene.name!r}"
    others = [s.name for s in obj.users_scene if s != scene]
    if scene not in obj.users_scene:
        shown_by = [(o.name, o.instance_collection.name) for o in bpy.data.objects
                    if o.instance_type == "COLLECTION" and o.instance_collection is not None
                    and o.instance_collection.all_objects.get(obj.name) == obj]
        if shown_by:
            instance, collection = shown_by[0]
            return (f"object {obj.name!r} is not in {here} itself, only in collection "
                    f"{collection!r}, which collection instance {instance!r} shows (a bake "
                    f"needs the object): link collection {collection!r} into {here}, or make "
                    f"the instance real (Object > Apply > Make Instances Real) and bake the "
                    f"copy")
        if others:
            return (f"object {obj.name!r} is in scene(s) {', '.join(map(repr, others))}, not "
                    f"in {here}, which the bake renders: save the file with that scene active "
                    f"(the bake uses the active scene), or link the object into {here}")
        return (f"object {obj.name!r} is in no collection of {here}: link it into the scene "
                f"(Object > Collection > Link to Collection)")
    names = ", ".join(repr(c.name) for c in obj.users_collection)
    return (f"object {obj.name!r} is not in view layer {view_layer.name!r}: its collection "
            f"({names}) is excluded from it; enable its collection (its checkbox in the "
            f"Outliner)")


def _in_view_layer(obj, layer_collection):
    """obj is in a collection of the view layer that is not excluded (nor a parent of it)."""
    if layer_collection.exclude:
        return False
    if layer_collection.collection.objects.get(obj.name) is obj:
        return True
    return any(_in_view_layer(obj, child) for child in layer_collection.children)


_HIDING = ("hide_viewport", "hide_select", "hide_render")
# Holdout makes Cycles bake (0, 0, 0): a grey map of zero-length normals, with exit 0.
_OBJECT_FLAGS = _HIDING + ("is_holdout",)
# The collections holding obj: hidden ones make the operator fail ("No valid selected
# objects"); a holdout one bakes the grey map.
_COLLECTION_FLAGS = _HIDING
_LAYER_COLLECTION_FLAGS = ("hide_viewport", "holdout")
# Cycles skips an object with every ray type off, and an instancer not shown in renders:
# one ray (the camera's) and the instancer are turned on for the bake.
_SHOWN_FLAGS = ("visible_camera", "show_instancer_for_render")


def _chains(obj, layer_collection, above=()):
    """Every chain of layer collections, from below the view layer's root down to one that
    holds obj, through collections that are not excluded."""
    if layer_collection.exclude:
        return
    chain = above + (layer_collection,)
    if layer_collection.collection.objects.get(obj.name) is obj:
        yield chain
    for child in layer_collection.children:
        yield from _chains(obj, child, chain)


@contextmanager
def visible_for_bake(obj, view_layer):
    """Unhide obj (eye, monitor, pointer, camera) and the collections that hold it, lift
    holdout from both, and make Cycles keep obj (_SHOWN_FLAGS), for the bake; put every flag
    back after."""
    blocks = [(obj, _OBJECT_FLAGS)]
    for chain in _chains(obj, view_layer.layer_collection):
        for layer in chain[1:]:                  # the root (scene collection) has no flags
            blocks += [(layer, _LAYER_COLLECTION_FLAGS), (layer.collection, _COLLECTION_FLAGS)]
    saved = []
    for block, names in blocks:
        if getattr(block, "library", None) is not None:     # linked: not ours to change
            continue
        saved += [(block, name, getattr(block, name)) for name in names
                  if hasattr(block, name)]
    shown = [] if getattr(obj, "library", None) is not None else \
        [name for name in _SHOWN_FLAGS if not getattr(obj, name, True)]
    if any(getattr(obj, ray, False) for ray in RAYS):
        shown = [name for name in shown if name != "visible_camera"]   # a ray sees it already
    hidden = obj.hide_get(view_layer=view_layer)
    try:
        for block, name, _ in saved:
            setattr(block, name, False)
        for name in shown:
            setattr(obj, name, True)
        if hidden:
            obj.hide_set(False, view_layer=view_layer)
        yield
    finally:
        for name in shown:
            setattr(obj, name, False)
        if hidden:
            obj.hide_set(True, view_layer=view_layer)
        for block, name, value in reversed(saved):
            setattr(block, name, value)


@contextmanager
def own_materials(view_layer):
    """Lift the view layer's material override for the bake (Cycles would bake the override
    material in place of the object's own: a flat map, with exit 0); put it back after."""
    override = getattr(view_layer, "material_override", None)
    try:
        if override is not None:
            view_layer.material_override = None
        yield
    finally:
        if override is not None:
            view_layer.material_override = override
