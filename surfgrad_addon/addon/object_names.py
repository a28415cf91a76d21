"""Why no object has the name a request gives, with the fix. A name longer than Blender keeps
(63 bytes up to 4.5, 255 from 5.0: an asset list written from another tool's names) was
cut where Blender cut it when the object was made, at a whole UTF-8 character; the lookup by
the full name finds nothing, and the refusal named no fix."""

from pathlib import Path

LISTED = 40                 # objects named in the refusal (a scene may hold thousands)


def missing_object_problem(name, where=True):
    """The refusal for `name`, which bpy.data.objects lacks (`where`: name the open file)."""
    import bpy
    limit = bpy.types.ID.bl_rna.properties["name"].length_max - 1
    raw = name.encode("utf-8", "surrogateescape")
    head = f"no object named {name!r}"
    if where and bpy.data.filepath:
        head += f" in {Path(bpy.data.filepath).name}"
    if len(raw) > limit:
        cut = raw[:limit].decode("utf-8", "ignore")
        line = ".".join(map(str, bpy.app.version[:2]))
        if bpy.data.objects.get(cut) is not None:
            return (f"{head}: the name is {len(raw)} bytes, and Blender {line} keeps {limit}, "
                    f"so the object is called {cut!r} in the file: give that name")
        return (f"{head}: the name is {len(raw)} bytes, longer than the {limit} Blender "
                f"{line} keeps; give the name the file has")
    names = sorted(o.name for o in bpy.data.objects)
    more = f" and {len(names) - LISTED} more" if len(names) > LISTED else ""
    return f"{head}; objects: {names[:LISTED]}{more}"
