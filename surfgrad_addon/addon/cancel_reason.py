"""Why Blender's bake operator cancelled without a report (it returns {'CANCELLED'} and says
nothing in background mode): the conditions it cancels on that surfgrad can see, told with the
fix. Used after a cancelled bake so the error names the cause, not just the outcome."""


def cancel_reason(obj, depsgraph=None):
    """A sentence naming what in `obj` makes Blender's bake cancel, or None if none is seen.
    Blender bakes the evaluated object (after modifiers and Geometry Nodes), whose material
    slots can differ from the object's own: Realize Instances / Set Material add slots, and an
    empty slot or a material without an Image Texture node to bake into cancels the bake."""
    import bpy
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    slots = [s.material for s in evaluated.material_slots]
    own = len(obj.material_slots)
    where = "" if len(slots) == own else \
        (f" (after its modifiers / Geometry Nodes it has {len(slots)} material slot(s), "
         f"the object itself {own})")
    for i, material in enumerate(slots):
        if material is None:
            return (f"material slot {i + 1} of the evaluated {obj.name!r} is empty{where}; "
                    f"Blender cancels a bake with an empty slot: give every slot a material "
                    f"(a Set Material node also needs the object to hold that material "
                    f"in its own slots), or apply the modifiers")
        nodes = material.node_tree.nodes if material.node_tree else ()
        if not any(n.type == "TEX_IMAGE" for n in nodes):
            return (f"material {material.name!r} (slot {i + 1}) of the evaluated {obj.name!r} "
                    f"has no Image Texture node to bake into{where}; add one or remove the "
                    f"slot")
    return None


def cancelled_text(obj, outcome):
    """The error for a bake that returned `outcome` instead of {'FINISHED'}."""
    try:
        reason = cancel_reason(obj)
    except Exception:                       # noqa: BLE001 - the outcome is still told
        reason = None
    text = f"the bake of {obj.name!r} did not finish ({outcome})"
    return f"{text}: {reason}" if reason else \
        f"{text}; Blender gave no reason (check its materials and modifiers)"
