"""Faces in an empty material slot (an importer's leftover slot, a material unlinked from the
object, a material index past the slots). Blender's bake writes each face into its material's
image node; a face whose slot is empty has none, so the bake writes nothing there: a hole in
the map, which the margin fills from the neighbouring faces, with exit 0 (5.2 and 4.2 alike;
Cycles renders such a face with its default surface). A material index past the last slot
counts as the last, as Cycles clamps it (tests/test_faults_unseen_meshes35.py)."""

import numpy as np

from ..reference.input_checks import faces_text


def empty_slot_problem(obj_name, face_materials, filled_slots, obj=None, own_empty_ok=False):
    """None, or the refusal naming the faces whose slot is empty. face_materials: (F,) each
    face's material index; filled_slots: per slot of the rendered object, whether it holds a
    material (no slots at all: the request's "no material" says it). obj: the object, whose
    own slot may hold a material that the rendered mesh's lacks: a Geometry Nodes tree that
    makes the mesh anew (a Mesh Grid, a Mesh Line) gives its faces no material, whatever the
    object's slots hold, and Cycles renders them with its default surface.
    own_empty_ok (Freeze, which bakes one material's faces): faces in a slot that is empty on
    the object itself too pass, as another material's faces do: Blender's bake skips them (no
    material, no image), and the material's map is whole. Only faces whose slot the object
    fills or lacks are refused there: Blender bakes those with the object's own slot (30 deg
    off) or cancels (tests/test_faults_objects57b.py, test_faults_review58a.py)."""
    if not filled_slots or all(filled_slots):
        return None
    index = np.asarray(face_materials, dtype=np.int64)
    slot = np.clip(index, 0, len(filled_slots) - 1)
    empty = ~np.asarray(filled_slots, dtype=bool)[slot]
    if own_empty_ok and obj is not None:
        own_empty = np.array([s.material is None for s in obj.material_slots] + [False])
        empty &= ~own_empty[np.minimum(slot, len(own_empty) - 1)]
    if not empty.any():
        return None
    faces = np.flatnonzero(empty)
    slots = ", ".join(str(s + 1) for s in np.unique(slot[empty]))
    past = " (a material index past the last slot counts as the last)" \
        if (index[empty] != slot[empty]).any() else ""
    made = _made_without(obj, np.unique(slot[empty]))
    if made:
        held, nodes = made
        where = (f"though the object's slot holds {held!r}" if held else
                 f"a slot the object itself lacks (it has {len(obj.material_slots)})")
        return (f"{len(faces)} face(s) of object {obj_name!r} (faces {faces_text(faces)}) "
                f"render with no material in slot {slots}{past}, {where}: {nodes} makes them "
                f"without a material (Cycles renders them with its default surface, and the "
                f"bake writes nothing for them): add a Set Material node "
                f"{'(' + repr(held) + ') ' if held else ''}for them in its tree")
    return (f"{len(faces)} face(s) of object {obj_name!r} (faces {faces_text(faces)}) use "
            f"empty material slot {slots}{past}, so the bake writes nothing for them, a hole "
            f"in the map: give the slot a material, or assign those faces to a slot that has "
            f"one (Material Properties > Assign)")


def _made_without(obj, slots):
    """(the material the object's own slot holds or None, modifier words) where a Geometry
    Nodes modifier shown in renders makes the mesh and the rendered mesh's empty `slots` are
    not the object's own empty slots (one holds a material, or the object has no such slot:
    geometry the tree made and joined, a Curve to Mesh); else None."""
    if obj is None:
        return None
    own = [s.material for s in obj.material_slots]
    nodes = [m for m in obj.modifiers if m.type == "NODES" and m.show_render]
    if not nodes or all(s < len(own) and own[s] is None for s in slots):
        return None
    held = [own[s] for s in slots if s < len(own) and own[s] is not None]
    names = ", ".join(repr(m.name) for m in nodes)
    return (held[0].name if held else None), f"Geometry Nodes modifier {names}"
