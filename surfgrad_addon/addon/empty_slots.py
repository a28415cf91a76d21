"""Faces in an empty material slot (an importer's leftover slot, a material unlinked from the
object, a material index past the slots). Blender's bake writes each face into its material's
image node; a face whose slot is empty has none, so the bake writes nothing there: a hole in
the map, which the margin fills from the neighbouring faces, with exit 0 (5.2 and 4.2 alike;
Cycles renders such a face with its default surface). A material index past the last slot
counts as the last, as Cycles clamps it (tests/test_faults_unseen_meshes35.py)."""

import numpy as np

from ..reference.input_checks import faces_text


def empty_slot_problem(obj_name, face_materials, filled_slots):
    """None, or the refusal naming the faces whose slot is empty. face_materials: (F,) each
    face's material index; filled_slots: per slot of the rendered object, whether it holds a
    material (no slots at all: the request's "no material" says it)."""
    if not filled_slots or all(filled_slots):
        return None
    index = np.asarray(face_materials, dtype=np.int64)
    slot = np.clip(index, 0, len(filled_slots) - 1)
    empty = ~np.asarray(filled_slots, dtype=bool)[slot]
    if not empty.any():
        return None
    faces = np.flatnonzero(empty)
    slots = ", ".join(str(s + 1) for s in np.unique(slot[empty]))
    past = " (a material index past the last slot counts as the last)" \
        if (index[empty] != slot[empty]).any() else ""
    return (f"{len(faces)} face(s) of object {obj_name!r} (faces {faces_text(faces)}) use "
            f"empty material slot {slots}{past}, so the bake writes nothing for them, a hole "
            f"in the map: give the slot a material, or assign those faces to a slot that has "
            f"one (Material Properties > Assign)")
