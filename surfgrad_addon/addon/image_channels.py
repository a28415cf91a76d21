"""The channels an image's files hold (image_headers.py reads the headers), and the files
whose pixels Blender does not load as they are meant, refused from the header before a load:
- an EXR with two of R, G and B: Blender shows them in R and G, and B as 0 on 4.2 but
  uninitialised on 4.5 and later (measured: between -6e37 and NaN, so the NaN check's answer
  was luck); Cycles renders neither, but a grey of the first (with alpha: the alpha as B), on
  every line. The same for R, G and B of an EXR with no channel Blender loads as colour (`A`
  alone, `Z` and `A`, `Z` or a lower case `y` alone): shown as 0 or uninitialised (5.2: as
  rendered, but for `y` and `a`), rendered as a grey of one of them;
- a luminance-chroma EXR (Y with RY and / or BY): no line loads it as RGB."""

from pathlib import Path

from ..reference.blender_lines import facts_for
from .header_reads import image_headers, path_headers


def running_facts():
    """The running Blender's line facts (bpy imported here, when a check runs: the command
    line imports this module without Blender)."""
    import bpy
    return facts_for(bpy.app.version)


def read_channels(image):
    """[(what, FileChannels)] for each of the image's files whose header says its channels."""
    return [(what, found.channels) for what, found in image_headers(image)
            if found is not None and found.channels is not None]


def undefined_channel_problem(image, facts):
    """None, or why the image cannot be baked from on this line (channel_problem) for the
    first of its files whose header says so."""
    for what, found in read_channels(image):
        problem = channel_problem(f"image {image.name!r}", what, found, facts)
        if problem:
            return problem
    return None


def path_channel_problem(subject, path, facts):
    """channel_problem for the image file `path` (a UDIM tile's, a sequence frame's, a file
    given on the command line), from its header; None where it cannot be read."""
    found = path_channels(path)
    return found and channel_problem(subject, Path(path).name, found, facts)


def path_channels(path):
    """FileChannels of the image file `path` from its header, or None where it does not say
    or cannot be read."""
    found = path_headers(path)
    return found and found.channels


def channel_problem(subject, what, found, facts):
    """None, or why a file whose header says `found` (its name `what`) cannot be baked from:
    on every line, a luminance-chroma EXR, and an EXR with two of R, G and B or with alpha and
    no colour, whose pixels as Cycles renders them are not those Blender shows (cycles_view)."""
    held = f"({what}: {found.kind} {found.format})"
    if found.luma_chroma:
        return (f"{subject} is a luminance-chroma OpenEXR {held}: Blender {facts.line} does not "
                f"load its luminance and chroma as RGB (Cycles renders a grey of its Y, its "
                f"magenta 'missing' colour or values far from the file's colours, by line and "
                f"channels); save it as an RGB OpenEXR (R, G and B channels)")
    if not found.unfilled:
        return None
    shown = "0" if facts.exr_two_colours_fill_zero else "uninitialised"
    if found.two_colours:
        return (f"{subject} holds two colour channels in its file {held}: Blender "
                f"{facts.line} shows them in R and G with B {shown}, but {cycles_view(found)}, "
                f"so no check sees what the bake takes; save it with R, G and B (for a "
                f"two-channel normal map, rebuild B = sqrt(1 - R^2 - G^2) first), or with one "
                f"channel for a grey map")
    return (f"{subject} holds no colour channel Blender reads in its file {held}: "
            f"{cycles_view(found)}, but what Blender shows the checks differs by line (0 on "
            f"4.2, uninitialised memory on later lines), so no check sees what the bake takes; "
            f"save it with R, G and B, or with one channel (R or Y) for a grey map")


def cycles_view(found):
    """What Cycles renders from an EXR lacking colour channels (found.unfilled), the same on
    every line (tests/test_faults_images34.py): the file's channels as they lie, not spread
    as Blender shows them: two colour channels as a grey of the first, the alpha after two as
    B, an alpha alone or a channel of another name (Z, a lower case y) as a grey."""
    if not found.two_colours:
        return "Cycles renders one of its channels as a grey"
    if found.channels == 2:
        return "Cycles renders a grey of the first of them"
    return "Cycles renders its alpha as B"


def layered_file(image):
    """What names the first of the image's files that is a layered (multilayer) OpenEXR by its
    header, or None: such a file is refused before Blender loads it (image_checks)."""
    return next((what for what, found in image_headers(image) if found and found.layered), None)


def cut_short_file(image):
    """(what, format) of the first of the image's files that is cut short (its image data not
    all within it: image_headers.cut_short), or None: Blender loads the part missing filled in."""
    return next(((what, found.cut) for what, found in image_headers(image)
                 if found and found.cut), None)


def cut_short_problem(subject, what, found):
    """Why `what` (a `found` file cut short, read by `subject`; "packed" or "packed tile 1002":
    its packed data) cannot be baked from."""
    lacks = {"JPEG": "no end-of-image marker after its image data",
             "TIFF": "its image data runs past the end of the file",
             "SGI image": "its image data runs past the end of the file",
             "OpenEXR": "its image data runs past the end of the file",
             "WebP": "shorter than its header says"}[found]
    found = f"{'an' if found[0] in 'AEIOU' else 'a'} {found}"     # "an OpenEXR"
    if what.startswith("packed"):   # (packed from a file cut short: no whole copy in the .blend)
        tile = f" ({what[len('packed '):]})" if what != "packed" else ""    # "(tile 1002)"
        return (f"{subject}{tile} is packed from {found} cut short ({lacks}: a copy or download "
                f"interrupted): Blender loads it at full size with the part missing filled "
                f"in, which Cycles would bake; replace it with the whole file (Image Editor: "
                f"Image > Replace) and pack that")
    return (f"{subject} reads {what}, {found} cut short ({lacks}: a copy or download "
            f"interrupted): Blender loads it at full size with the part missing filled in, "
            f"which Cycles would bake; copy or export the file again, whole")
