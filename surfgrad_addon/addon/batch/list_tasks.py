"""An asset list baked one entry a task (`--asset-index`: the OpenJD template's tasks, each its
own run with its own manifest): a run sees only its entry, so the batch's check of two assets
on one output file never met the other entries. Two entries on one file (the same asset listed
twice, or two files' objects of one name under a pattern without a folder per file) were two
tasks writing one map: without --overwrite the one that ended second failed, told to pass
--overwrite; with it each replaced the other's map, exit 0, the first entry's manifest
recording a map that then held the other asset's normals.

This finds the other entries whose output is known without opening their file: those naming
their object (with {uv} in the pattern, only where the settings give its UV map), and those
naming this entry's own file alone (they bake its objects too). An entry naming another file
alone is not opened (a farm task reads one file): its clashes stay unseen (docs/farm.md)."""

import os
import unicodedata
from pathlib import Path

from . import plan as P
from .output_names import output_key


def entries(others):
    """The other entries ([(index, entry)]) as clash takes them, read once a run:
    [(index, entry, its .blend as an absolute path, its object or None, the file's identity)]."""
    out = []
    for index, entry in others:
        blend, obj = P.split_entry(entry)
        blend = os.path.abspath(blend)
        out.append((index, entry, blend, obj, _identity(blend)))
    return out


def clash(others, listing, output, base, overrides, blend, obj, uv, seen_as):
    """The problem (text) when an entry of `others` (entries()) of the asset list `listing`
    would write the file this task writes for `obj` of `blend` (its output's output_key
    `seen_as`), or None."""
    name_key, identity = _name_key(seen_as), _identity(blend)
    for index, entry, other_blend, other_obj, other_identity in others:
        same_file = other_identity == identity
        if other_obj is None:
            if not same_file:
                continue                 # its objects are known only by opening it
            other_obj, other_uv = obj, uv
        elif same_file and other_obj == obj:
            other_uv = uv
        else:
            other_uv = P.asset_settings(base, overrides, Path(other_blend).name,
                                        other_obj)["uv_map"] or ""
            if "{uv}" in str(output) and not other_uv:
                continue                 # its UV map is known only by opening it
        other_out = P.expand(output, Path(other_blend).name, other_obj, other_uv)
        # (the file name first: resolving every entry's path costs a lookup a folder, and a
        # farm's list may have thousands of entries)
        if _name_key(other_out) != name_key or output_key(Path(other_out).resolve()) != seen_as:
            continue
        name = f"{Path(blend).name}:{obj}"
        task = (f"each entry of the list is its own task (--asset-index), so two tasks would "
                f"write it at once: the one ending second fails ('exists') or, with "
                f"--overwrite, replaces the other's map")
        if same_file and other_obj == obj:
            return (f"{name} is also baked by entry {index} of the asset list {listing} "
                    f"({entry!r}), into the same file {other_out}: {task}; list it once")
        return (f"{name} and entry {index} of the asset list {listing} ({entry!r}) would both "
                f"write {other_out}: {task}; make the output pattern tell them apart "
                f"({', '.join(P.TOKENS)}), or rename one")
    return None


def _identity(path):
    try:
        st = os.stat(path)
        return st.st_dev, st.st_ino
    except OSError:                  # (a missing entry fails in its own task)
        return os.path.abspath(path)


def _name_key(path):
    """A file name as any file system that ignores case or Unicode's forms may take it."""
    return unicodedata.normalize("NFC", os.path.basename(str(path))).casefold()
