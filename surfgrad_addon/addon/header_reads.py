"""What the checks want to know of an image file's header, read in one opening of it.

Layers, channels, cut short and pixel size were each read by opening the file again: for a
packed image every opening is a copy of its data (packed_file.data), 0.29 s for a 50 MB PNG
(5.2.3), and a bake's checks made five. Inside one_header_read() (bake_request.check; each
image check opens its own) each file, packed data or path, is opened once."""

import io
from pathlib import Path
from typing import NamedTuple

from ..reference import tiles as T
from .image_headers import cut_short, exr_layered, file_channels, pixel_size
from .read_once import ReadOnce

_headers = ReadOnce()           # {("image", pointer) or ("path", path): facts}


class HeaderFacts(NamedTuple):
    layered: bool       # a layered (multilayer) OpenEXR: image_headers.exr_layered
    channels: object    # FileChannels, or None where the header does not say
    cut: object         # the format of a file cut short (image_headers.cut_short), or None
    size: object        # PixelSize, or None where the header does not say


def one_header_read():
    """Within this block each file's header is read once. Nothing may change an image's file
    within it."""
    return _headers.scope()


def image_headers(image):
    """[(what, HeaderFacts or None where it cannot be opened)] for each file the image reads:
    its packed data ("packed"; "packed tile 1002" for each of a packed UDIM image's, in the
    order of image.packed_files), its file, or each UDIM tile's (named by file, in tile order);
    nothing for sequences, movies and generated images (their frame file: path_headers)."""
    return _headers.get(("image", image.as_pointer()), lambda: _read_image(image))


def path_headers(path):
    """HeaderFacts of the image file `path` (a UDIM tile's, a sequence frame's, a file named on
    the command line), or None where it cannot be opened."""
    return _headers.get(("path", str(path)), lambda: _read(lambda: open(path, "rb")))


def _read_image(image):
    import bpy
    tiles = list(getattr(image, "packed_files", ()))
    if image.source == "TILED" and len(tiles) > 1:        # a packed UDIM image: each tile
        return [(f"packed tile {t.tile_number}",
                 _read(lambda t=t: io.BytesIO(t.packed_file.data))) for t in tiles]
    packed = getattr(image, "packed_file", None)
    if packed is not None:
        return [("packed", _read(lambda: io.BytesIO(packed.data)))]
    if image.source not in ("FILE", "TILED") or not image.filepath:
        return []
    path = bpy.path.abspath(image.filepath, library=image.library)
    if image.source == "TILED":
        paths = [T.tile_path(path, t.number) for t in image.tiles]
    else:
        paths = [Path(path)]
    return [(Path(p).name, path_headers(p)) for p in paths]     # (shared with path_headers)


def _read(opened):
    try:
        with opened() as f:
            facts = []
            for read in (exr_layered, file_channels, cut_short, pixel_size):
                f.seek(0)
                facts.append(read(f))
    except OSError:
        return None                     # unreadable: image_checks refuses what matters
    return HeaderFacts(*facts)
