"""Whether an object can be baked as it is, and the visibility a bake needs, lent and given back.

Blender's bake operator works on selectable, visible objects of the active view layer, and
writes into the object's materials: an object linked from a library cannot take a temporary
material, and one hidden in the viewport makes the operator fail with "context is incorrect".
"""

from contextlib import contextmanager


def bake_target_problem(obj, view_layer):
    """None when obj can be baked, else a message naming the problem and the fix."""
    if obj is None:
        return "no object given: pick a mesh object to bake"
    if obj.type != "MESH":
        return f"object {obj.name!r} is a {obj.type.lower()}, not a mesh: pick a mesh object"
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
        return (f"object {obj.name!r} is not in view layer {view_layer.name!r} (its collection "
                f"is excluded, or it belongs to another scene): enable its collection")
    if len(obj.data.polygons) == 0:
        return f"mesh {obj.data.name!r} of {obj.name!r} has no faces to bake"
    return None


def _in_view_layer(obj, layer_collection):
    """obj is in a collection of the view layer that is not excluded (nor a parent of it)."""
    if layer_collection.exclude:
        return False
    if layer_collection.collection.objects.get(obj.name) is obj:
        return True
    return any(_in_view_layer(obj, child) for child in layer_collection.children)


_HIDING = ("hide_viewport", "hide_select", "hide_render")


@contextmanager
def visible_for_bake(obj, view_layer):
    """Unhide obj (eye, monitor, pointer, camera) for the bake; put every flag back after."""
    saved = {name: getattr(obj, name) for name in _HIDING}
    hidden = obj.hide_get(view_layer=view_layer)
    try:
        for name in _HIDING:
            setattr(obj, name, False)
        if hidden:
            obj.hide_set(False, view_layer=view_layer)
        yield
    finally:
        if hidden:
            obj.hide_set(True, view_layer=view_layer)
        for name, value in saved.items():
            setattr(obj, name, value)
