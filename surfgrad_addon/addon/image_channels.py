"""The channels an image's files hold (image_headers.py reads the headers), and the one case
where what Blender loads from them is not defined: an EXR with two of R, G and B. Blender
loads the two into R and G; 4.2 fills B with 0, 4.5 and later leave it uninitialised, so the
pixels Cycles bakes from differ from load to load (measured: B between -6e37 and NaN, a
different map, or a refusal for non-finite pixels, on each run). The same holds for R, G and B
of an EXR with alpha and no colour channel (`A` alone, `Z` and `A`): measured as NaN, 3e34,
or the previous load's pixels."""

import io
from pathlib import Path

from ..reference import tiles as T
from ..reference.blender_lines import facts_for
from .image_headers import exr_layered, file_channels


def running_facts():
    """The running Blender's line facts (bpy imported here, when a check runs: the command
    line imports this module without Blender)."""
    import bpy
    return facts_for(bpy.app.version)


def file_openers(image):
    """(what, a function opening it) for the files an image reads: its packed data, its file,
    or each UDIM tile's; nothing for sequences, movies and generated images."""
    import bpy
    packed = getattr(image, "packed_file", None)
    if packed is not None:
        data = packed.data
        return [("packed", lambda: io.BytesIO(data))]
    if image.source not in ("FILE", "TILED") or not image.filepath:
        return []
    path = bpy.path.abspath(image.filepath, library=image.library)
    if image.source == "TILED":
        paths = [T.tile_path(path, t.number) for t in image.tiles]
    else:
        paths = [Path(path)]
    return [(Path(p).name, lambda p=p: open(p, "rb")) for p in paths]


def read_channels(image):
    """[(what, FileChannels)] for each of the image's files whose header says its channels."""
    out = []
    for what, opened in file_openers(image):
        try:
            with opened() as f:
                found = file_channels(f)
        except OSError:
            continue                    # unreadable: image_checks refuses what matters
        if found is not None:
            out.append((what, found))
    return out


def undefined_channel_problem(image, facts):
    """None, or why the image cannot be baked from on this line: a file with two of R, G and
    B, whose loaded B Blender leaves uninitialised (not LineFacts.exr_two_colours_fill_zero)."""
    if facts.exr_two_colours_fill_zero:
        return None
    for what, found in read_channels(image):
        if found.two_colours:
            return (f"image {image.name!r} holds two colour channels in its file ({what}: "
                    f"{found.kind} {found.format}): Blender {facts.line} loads them into R and "
                    f"G and leaves B uninitialised, so what Cycles bakes from it changes from "
                    f"run to run; save it with R, G and B (for a two-channel normal map, "
                    f"rebuild B = sqrt(1 - R^2 - G^2) first), or with one channel for a grey "
                    f"map")
        if found.unfilled:
            return (f"image {image.name!r} holds no colour channel Blender reads in its file "
                    f"({what}: {found.kind} {found.format}): Blender {facts.line} loads its "
                    f"alpha only and leaves R, G and B uninitialised, so what Cycles bakes from "
                    f"it changes from run to run; save it with R, G and B, or with one channel "
                    f"(R or Y) for a grey map")
    return None


def layered_file(image):
    """What names the first of the image's files that is a layered (multilayer) OpenEXR by its
    header, or None: such a file is refused before Blender loads it (image_checks)."""
    for what, opened in file_openers(image):
        try:
            with opened() as f:
                if exr_layered(f):
                    return what
        except OSError:
            continue
    return None
