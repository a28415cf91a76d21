"""Materials linked from a library, baked through temporary local copies.

Cycles bakes into an Image Texture node the bake adds to each material (normal_bake.py), and
cancels the bake for a material linked from a library ("No active and selected image texture
node found"): linked data takes no lasting edit. So for the bake each slot holding such a
material gets a local copy of it (ID.copy of linked data is local; its node groups and images
stay the library's), baked exactly as a local material is, and afterwards every slot gets its
material back and every copy is removed, whatever happens (an exception, a KeyboardInterrupt
in a live session). A command stopped by a signal ends the process without saving anything,
so the .blend on disk is never touched.

A missing library is refused before (material_inputs.missing_library_problem); a library override is
local data and bakes as it is. A slot of a linked object or mesh cannot be reassigned: the
bake refuses those objects first (bake_target.bake_target_problem names the fix).
"""

from contextlib import contextmanager


def is_linked(mat):
    """A material whose data comes from a library file that holds it (not an override, which
    is local; not the placeholder of a missing one, which the checks refuse)."""
    return mat is not None and mat.library is not None and not getattr(mat, "is_missing", False)


@contextmanager
def local_copies(obj):
    """For the duration, each of obj's slots holding a linked material holds a local copy of
    it (one copy per material, shared by its slots, as the bake adds one node per material).
    Yields {linked material: copy}. Nothing is done for an object or mesh that is itself
    linked (its slots cannot be reassigned; the bake's checks refuse it)."""
    import bpy
    if obj is None or obj.type != "MESH" or obj.library is not None or \
            obj.data.library is not None:
        yield {}
        return
    copies, swapped = {}, []
    try:
        for index, slot in enumerate(obj.material_slots):
            mat = slot.material
            if not is_linked(mat):
                continue
            if mat not in copies:
                copies[mat] = mat.copy()
            swapped.append((index, mat))
            slot.material = copies[mat]
        yield copies
    finally:
        for index, mat in reversed(swapped):
            obj.material_slots[index].material = mat      # written where the slot links
        for copy in copies.values():
            bpy.data.materials.remove(copy)
