"""compare's error heat map: the per-texel error as a picture (PNG), excluded texels in their
reason's colour.

`heat_map_rgb_numpy` is the definition; `heat_map_rgb` runs its compiled twin (one pass over
the image instead of a dozen whole-image temporaries) when the reference's kernels run
(reference/compiled.py), with the same float operations in the same order, so the bytes are
the same either way (tests/test_compare_kernels.py)."""

import numpy as np

from ..reference import compiled
from ..reference.compiled import kernel
from .pictures import write_png

HEAT_COLOURS = {0: (0.05, 0.05, 0.2), 1: (0.9, 0.1, 0.8), 2: (1.0, 0.55, 0.0),
                3: (0.0, 0.8, 0.8), 4: (0.2, 0.9, 0.2)}
# zlib level of the heat maps: 1 encodes a 4096^2 map in a third of the default's (6) time
# for a file about 1.5 x larger; the pixels are the same.
PNG_COMPRESS_LEVEL = 1


def write_heat_map(path, heat, overwrite):
    """Error in degrees as a picture: black 0, white at the max (or 0.5 deg, whichever is
    larger), uncovered texels dark blue; contested texels magenta (their error is in the
    report), excluded ones in their reason's colour (edge orange, outside cyan: HEAT_COLOURS)."""
    # Rows already top-down: the picture is written without another copy.
    return write_png(path, heat_map_rgb(heat, top_down=True), bottom_up=False,
                     overwrite=overwrite, compress_level=PNG_COMPRESS_LEVEL)


def _byte(value):
    """A [0, 1] colour channel as the PNG's byte: round half up, as write_png rounds floats."""
    return np.minimum(np.asarray(value) * 255.0 + 0.5, 255.0).astype(np.uint8)


def _colour_table():
    """(table (256, 3) uint8, known (256,) bool): a reason code's colour (index code & 255)."""
    table = np.zeros((256, 3), dtype=np.uint8)
    known = np.zeros(256, dtype=bool)
    for code, colour in HEAT_COLOURS.items():
        table[code & 255], known[code & 255] = _byte(colour), True
    return table, known


def _codes(heat):
    codes = getattr(heat, "reasons", None)
    return (np.zeros(np.shape(heat), dtype=np.uint8) if codes is None
            else np.asarray(codes, dtype=np.int8).view(np.uint8))


def heat_map_rgb(heat, top_down=False):
    """write_heat_map's picture, (H, W, 3) uint8, row 0 at the bottom (Blender's order) or,
    top_down, at the top."""
    if not compiled.enabled():
        rgb = heat_map_rgb_numpy(heat)
        return rgb[::-1] if top_down else rgb
    table, known = _colour_table()
    values = np.ascontiguousarray(heat, dtype=np.float64)
    rgb = np.empty(values.shape + (3,), dtype=np.uint8)
    heat_kernel(values, np.ascontiguousarray(_codes(heat)), table, known, top_down, rgb)
    return rgb


def heat_map_rgb_numpy(heat):
    """The definition of heat_map_rgb: channel by channel into one byte image, the reason
    colours through a table (no float RGB image, no mask per colour)."""
    index = _codes(heat)
    heat = np.asarray(heat, dtype=np.float64)
    finite = np.isfinite(heat)
    top = max(0.5, float(np.nanmax(heat)) if finite.any() else 0.5)
    v = np.clip(np.nan_to_num(heat, nan=0.0) / top, 0, 1)
    rgb = np.empty(heat.shape + (3,), dtype=np.uint8)
    rgb[..., 0] = _byte(v)
    rgb[..., 1] = _byte(np.sqrt(v) * 0.8)
    rgb[..., 2] = _byte(np.square(v))
    table, known = _colour_table()
    # A reason's colour wins; any other texel without an error is HEAT_COLOURS[0].
    reason = known[index] & (index != 0)
    special = reason | ~finite
    rgb[special] = table[np.where(reason, index, 0)[special]]
    return rgb


@kernel(inline=True)
def _byte_of(v):
    return np.uint8(min(v * 255.0 + 0.5, 255.0))


@kernel()
def heat_kernel(heat, codes, table, known, top_down, rgb):
    """Compiled twin of heat_map_rgb_numpy, rows flipped when top_down."""
    h, w = heat.shape
    top = -np.inf
    any_finite = False
    for y in range(h):                          # np.nanmax over the image
        for x in range(w):
            e = heat[y, x]
            if e == e:
                top = max(top, e)
                any_finite = any_finite or np.isfinite(e)
    top = max(0.5, top) if any_finite else 0.5
    for y in range(h):
        row = h - 1 - y if top_down else y
        for x in range(w):
            c = codes[y, x]
            e = heat[y, x]
            if known[c] and c != 0:
                k = c
            elif not np.isfinite(e):
                k = 0
            else:
                v = min(max(e / top, 0.0), 1.0)    # np.clip(heat / top, 0, 1)
                rgb[row, x, 0] = _byte_of(v)
                rgb[row, x, 1] = _byte_of(np.sqrt(v) * 0.8)
                rgb[row, x, 2] = _byte_of(v * v)
                continue
            rgb[row, x, 0] = table[k, 0]
            rgb[row, x, 1] = table[k, 1]
            rgb[row, x, 2] = table[k, 2]


def _load():
    """Load the kernel for the types compare uses (raster.load_compiled)."""
    rgb = np.empty((1, 1, 3), dtype=np.uint8)
    table, known = _colour_table()
    heat_kernel(np.zeros((1, 1)), np.zeros((1, 1), dtype=np.uint8), table, known, True, rgb)


compiled.LOADERS.append(_load)
