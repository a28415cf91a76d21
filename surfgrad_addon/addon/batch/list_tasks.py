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
alone is not opened (a farm task reads one file): its clashes stay unseen (docs/pipelines.md,
Known limits)."""

import os
from pathlib import Path

from . import plan as P
from .output_names import output_key


def clash(others, listing, output, base, overrides, blend, obj, uv, seen_as):
    """The problem (text) when an entry of `others` ([(index, entry)] of the asset list
    `listing`) would write the file this task writes for `obj` of `blend` (its output's
    output_key `seen_as`), or None."""
    for index, entry in others:
        other_blend, other_obj = P.split_entry(entry)
        other_blend = os.path.abspath(other_blend)
        same_file = _same_file(other_blend, blend)
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
        if output_key(Path(other_out).resolve()) != seen_as:
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


def _same_file(a, b):
    try:
        return os.path.samefile(a, b)
    except OSError:                  # (a missing entry fails in its own task)
        return os.path.abspath(a) == os.path.abspath(b)
