"""Mesh caches a bake cannot read (an Alembic or USD import's Mesh Sequence Cache modifier)
whose file moved, is gone or is damaged: Blender only logs a warning and renders the mesh the
import stored, another shape than the cache's at the current frame, so the bake wrote a map of
a stale mesh with exit 0. (A Transform Cache constraint moves the object only, which changes
no texel of a tangent- or object-space map.)

A cache Blender could read lists the file's object paths (CacheFile.object_paths, filled when
the file is opened, not saved with the .blend); one it could not read lists none."""

from pathlib import Path


def _users(obj):
    """(what, cache file, object path) of each render-enabled mesh cache reader on obj."""
    for mod in obj.modifiers:
        if mod.type == "MESH_SEQUENCE_CACHE" and mod.show_render and mod.cache_file:
            yield f"modifier {mod.name!r}", mod.cache_file, mod.object_path


def unread_cache_problems(obj):
    """One problem per cache reader on obj whose file Blender could not read, or which holds
    no object at the reader's object path; [] when all read."""
    import bpy
    out = []
    for what, cache, object_path in _users(obj):
        paths = {p.path for p in cache.object_paths}
        where = f"{what} of object {obj.name!r} reads cache file {cache.filepath!r}"
        if paths and (not object_path or object_path in paths):
            continue
        if paths:
            out.append(f"{where}, which holds no object {object_path!r}, so Blender renders "
                       f"the mesh the import stored: pick one of {sorted(paths)[:8]} as its "
                       f"Object Path")
            continue
        path = bpy.path.abspath(cache.filepath, library=cache.library)
        why = "which is missing" if not cache.is_sequence and not Path(path).is_file() else \
            "which Blender could not read (damaged, or not Alembic / USD?)"
        out.append(f"{where} ({path}), {why}, so Blender renders the mesh the import stored, "
                   f"not the cache's: put the file there or point the cache at it (Cache File "
                   f"> File Path; File > External Data > Find Missing Files)")
    return out
