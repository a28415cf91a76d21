"""Materials linked from a library, baked through temporary local copies.

Cycles bakes into an Image Texture node the bake adds to each material (normal_bake.py), and
cancels the bake for a material linked from a library ("No active and selected image texture
node found"): linked data takes no lasting edit. So for the bake each slot holding such a
material gets a local copy of it (ID.copy of linked data is local; its node groups and images
stay the library's), baked exactly as a local material is, and afterwards every user gets its
material back and every copy is removed, whatever happens (an exception, a KeyboardInterrupt
in a live session). A command stopped by a signal ends the process without saving anything,
so the .blend on disk is never touched.

For the bake every local user of such a material (a slot, a Set Material node) uses the copy
(ID.user_remap). A linked material that only a Geometry Nodes Set Material gives the object (no
slot holds it) bakes through a local copy too, whose BSDFs then stand in as a slot's do
(bake_closures.py);
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
def local_copies(obj, given=()):
    """For the duration, every local user of each linked material of obj's slots, and of each
    of `given` (linked materials a Set Material gives obj), uses one local copy of it
    (ID.user_remap): the slots and the Set Material nodes of local node groups alike (a slot's
    copy alone left a Set Material of the same material giving a material no slot held, whose
    faces Blender's bake wrote into the last slot's map: Freeze refused it, round 48). Yields
    {linked material: copy}. Nothing is done for an object or mesh that is itself linked (its
    slots cannot be reassigned; the bake's checks refuse it)."""
    import bpy
    if obj is None or obj.type != "MESH" or obj.library is not None or \
            obj.data.library is not None:
        yield {}
        return
    slots = [s.material for s in obj.material_slots]
    copies = {}
    try:
        for mat in dict.fromkeys(slots + list(given)):
            if is_linked(mat):
                copies[mat] = mat.copy()
                mat.user_remap(copies[mat])
        yield copies
    finally:
        for mat, copy in reversed(copies.items()):
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
    BSDF to stand in) that a linked node group of its modifiers uses: local_copies cannot
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
