"""Materials linked from a library, baked through temporary local copies.

Cycles bakes into an Image Texture node the bake adds to each material (normal_bake.py), and
cancels the bake for a material linked from a library ("No active and selected image texture
node found"): linked data takes no lasting edit. So for the bake each slot holding such a
material gets a local copy of it (ID.copy of linked data is local; its node groups and images
stay the library's), baked exactly as a local material is, and afterwards every slot gets its
material back and every copy is removed, whatever happens (an exception, a KeyboardInterrupt
in a live session). A command stopped by a signal ends the process without saving anything,
so the .blend on disk is never touched.

A linked material that only a Geometry Nodes Set Material gives the object (no slot holds it)
bakes through a local copy too: for the bake every local user of it (the Set Material node)
uses the copy (ID.user_remap), whose BSDFs then stand in as a slot's do (bake_closures.py);
before, it baked as it was, a Principled BSDF's map 8.3 degrees flat with exit 0
(tests/test_faults_bake_closures47.py). Every user gets it back after. Linked data keeps what
it uses, so where a linked node group of the object's modifiers gives such a material with a
BSDF, the bake is refused, naming the group and the fix (make it local).

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


@contextmanager
def remapped_copies(materials):
    """For the duration, every local user of each linked material in `materials` uses a local
    copy of it instead (linked data that uses it keeps it). Yields the copies."""
    import bpy
    swapped = []
    try:
        for mat in materials:
            copy = mat.copy()
            swapped.append((mat, copy))
            mat.user_remap(copy)
        yield [copy for _, copy in swapped]
    finally:
        for mat, copy in reversed(swapped):
            copy.user_remap(mat)
            bpy.data.materials.remove(copy)


def _modifier_groups(obj):
    """The node groups obj's Geometry Nodes modifiers use, at any depth."""
    groups, todo = [], [m.node_group for m in obj.modifiers if m.type == "NODES"]
    while todo:
        group = todo.pop()
        if group is None or group in groups:
            continue
        groups.append(group)
        todo += [getattr(n, "node_tree", None) for n in group.nodes]
    return groups


def linked_user_problem(obj, materials):
    """None, or the refusal of the linked `materials` a Set Material gives obj (each with a
    BSDF to stand in) that a linked node group of its modifiers uses: remapped_copies cannot
    reach them there, and they would bake as they are (a Principled BSDF 8.3 degrees flat)."""
    import bpy
    groups = [g for g in _modifier_groups(obj) if g.library is not None]
    if not groups or not materials:
        return None
    users = bpy.data.user_map(subset=set(materials))
    for mat in materials:
        group = next((g for g in groups if g in users[mat]), None)
        if group is not None:
            return (f"object {obj.name!r} renders material {mat.name!r} from library "
                    f"{mat.library.filepath!r}, which node group {group.name!r}, linked from "
                    f"{group.library.filepath!r}, gives it (a Set Material): the bake stands "
                    f"its BSDFs in as white Diffuse BSDFs (Cycles' own normal bake bends "
                    f"them) through a local copy, which linked data cannot be pointed at; "
                    f"make the node group local (Object > Relations > Make Local > All, or "
                    f"the link button by the group's name in the modifier) and bake again")
    return None
