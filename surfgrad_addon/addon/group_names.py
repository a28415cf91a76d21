"""What names and stamps say about surface-gradient node groups in a file: the stamps our
groups carry, the name a group gets where Blender would cut it, and the copies of a group that
an append brought in ("SG Decal.001")."""

import hashlib

import bpy

VERSION_KEY = "surfgrad_version"
# The Blender line a group was built for: a few interiors differ by line (the interface never
# does), so a file saved on one line gets its groups rebuilt when used on another.
LINE_KEY = "surfgrad_line"
# A digest of the group's inside as built (node_builder.inside_digest): an artist's edit of it
# is told apart from our build when a rebuild would replace it.
INSIDE_KEY = "surfgrad_inside"


def fitting_name(name):
    """`name` if Blender can name a data-block so (63 bytes up to 4.5, 255 from 5.0), else
    its longest start that fits with a tag of the whole name's hash: Blender cut the name of
    a group built for a long image or UV map name, so every use made another group."""
    limit = bpy.types.ID.bl_rna.properties["name"].length_max - 1
    raw = name.encode()
    if len(raw) <= limit:
        return name
    tag = "~" + hashlib.sha1(raw).hexdigest()[:8]
    return raw[:limit - len(tag)].decode(errors="ignore") + tag


def is_copy_name(candidate, name):
    """Whether `candidate` is Blender's name for a copy of a data-block named `name`:
    "<name>.001", or, where "<name>.001" does not fit (63 bytes on 4.2 and 4.5: a per-UV-map
    group of a UV map name of 44 bytes or more), `name` cut short, with or without ".001"
    (the first copy of a 60-byte name is its first 59 bytes; rt58a: such copies were named
    renamed and never rebuilt)."""
    prefix = name + "."
    if candidate.startswith(prefix) and candidate[len(prefix):].isdigit():
        return True
    limit = bpy.types.ID.bl_rna.properties["name"].length_max - 1
    base = candidate.rsplit(".", 1)[0] if candidate.rsplit(".", 1)[-1].isdigit() else candidate
    return (base != name and name.startswith(base) and len(name.encode()) + 4 > limit
            and len(base.encode()) >= limit - 8)


def stale_copies(name, version, line, tree_type):
    """Our editable groups named `name` plus Blender's ".NNN" suffix of an older version or of
    this one built on another line (a newer one is left alone; an image-bound group's copy
    names another image: never asked for)."""
    return [g for g in bpy.data.node_groups
            if is_copy_name(g.name, name) and g.bl_idname == tree_type and g.is_editable
            and VERSION_KEY in g
            and g.override_library is None                 # (its rebuild would not be saved)
            and (g[VERSION_KEY] == version and g.get(LINE_KEY) != line
                 or isinstance(g[VERSION_KEY], int) and g[VERSION_KEY] < version)]


def newer_group_problem(tree, name, version):
    """None, or why group `tree` (named `name`) is not rebuilt to `version`: a newer surfgrad
    made it (a colleague's file), and rebuilding would drop from every node using it what the
    newer version added (an input, its value and its links), silently."""
    made = tree.get(VERSION_KEY) if tree is not None else None
    if not isinstance(made, int) or made <= version:
        return None
    return (f"node group {name!r} was made by a newer surfgrad (group version {made}; this "
            f"extension makes {version}), and rebuilding it here would drop what that version "
            f"added from every node using it: update the surfgrad extension, or rename that "
            f"group to add this version beside it")


def override_text(tree, name):
    """Why group `tree` (named `name`), a library override of an older surfgrad's (or another
    line's) group, is not rebuilt: the file would not save the rebuild."""
    reference = tree.override_library.reference
    library = getattr(reference, "library", None) if reference is not None else None
    where = f" from {library.filepath!r}" if library is not None else ""
    return (f"node group {name!r} is a library override of a group{where} built by an older "
            f"surfgrad (or for another Blender line): a rebuild here would not be saved "
            f"(reopened, it and every node using it would be the library's again); update it "
            f"in that file (Update surfgrad Groups there, then save it), or make it local "
            f"first (Outliner: Library Override > Make Local)")
