"""compare's error heat map: the per-texel error as a picture (PNG), excluded texels in their
reason's colour.

The picture is a palette (indexed) PNG: a texel's index is its error's level, LEVELS steps
even in sqrt(error / top) (fine near zero, where the bars are), or the slot of its reason's
colour. The colour of a level is the ramp (v, 0.8 sqrt(v), v^2) at the level's v. An indexed
PNG is written without PNG's per-row filters: a 4096^2 map takes 0.03 s to encode against
0.5 s as RGB (measured, compress level 1), and its index reads back as the level exactly
(report/heat.py).

`heat_map_indices_numpy` is the definition; `heat_map_indices` runs its compiled twin (one
pass over the image instead of a dozen whole-image temporaries) when the reference's kernels
run (reference/compiled.py), with the same float operations in the same order, so the bytes are
the same either way (tests/test_compare_kernels.py)."""

import numpy as np

from ..reference import compiled
from ..reference.compiled import kernel
from .pictures import write_png

HEAT_COLOURS = {0: (0.05, 0.05, 0.2), 1: (0.9, 0.1, 0.8), 2: (1.0, 0.55, 0.0),
                3: (0.0, 0.8, 0.8), 4: (0.2, 0.9, 0.2)}
# Reasons drawn in another's colour (the palette's 256 slots are taken): grazing (6, the
# shading normal nearly in its face) as backfacing (4, beyond it).
HEAT_ALIASES = {6: 4}
# Error levels 0..LEVELS - 1 (v = (level / (LEVELS - 1))^2); a reason code c (a key of
# HEAT_COLOURS) has palette slot LEVELS + c: 256 entries in all.
LEVELS = 251
PNG_COMPRESS_LEVEL = 1


def write_heat_map(path, heat, overwrite):
    """Error in degrees as a picture: black 0, white at the max (or 0.5 deg, whichever is
    larger), uncovered texels dark blue; contested texels magenta (their error is in the
    report), excluded ones in their reason's colour (edge orange, outside cyan: HEAT_COLOURS)."""
    # Rows already top-down: the picture is written without another copy.
    return write_png(path, heat_map_indices(heat, top_down=True), bottom_up=False,
                     overwrite=overwrite, compress_level=PNG_COMPRESS_LEVEL,
                     palette=heat_palette())


def _byte(value):
    """A [0, 1] colour channel as the PNG's byte: round half up, as write_png rounds floats."""
    return np.minimum(np.asarray(value) * 255.0 + 0.5, 255.0).astype(np.uint8)


def level_value(level):
    """v (error over the map's top) of an error level."""
    return np.square(np.asarray(level, dtype=np.float64) / (LEVELS - 1))


def heat_palette():
    """(256, 3) uint8: the ramp at each level's v, then the reasons' colours."""
    v = level_value(np.arange(LEVELS))
    table = np.zeros((256, 3), dtype=np.uint8)
    table[:LEVELS, 0] = _byte(v)
    table[:LEVELS, 1] = _byte(np.sqrt(v) * 0.8)
    table[:LEVELS, 2] = _byte(np.square(v))
    for code, colour in HEAT_COLOURS.items():
        table[LEVELS + code] = _byte(colour)
    return table


def _reason_slots():
    """(256,) uint8 palette slot of a reason code (index code & 255), 0 where none."""
    slots = np.zeros(256, dtype=np.uint8)
    for code in HEAT_COLOURS:
        slots[code & 255] = LEVELS + code
    for code, shown in HEAT_ALIASES.items():
        slots[code & 255] = LEVELS + shown
    return slots


def _codes(heat):
    codes = getattr(heat, "reasons", None)
    return (np.zeros(np.shape(heat), dtype=np.uint8) if codes is None
            else np.asarray(codes, dtype=np.int8).view(np.uint8))


def heat_map_indices(heat, top_down=False):
    """write_heat_map's picture as palette indices (H, W) uint8, row 0 at the bottom
    (Blender's order) or, top_down, at the top."""
    if not compiled.enabled():
        index = heat_map_indices_numpy(heat)
        return index[::-1] if top_down else index
    values = np.ascontiguousarray(heat, dtype=np.float64)
    index = np.empty(values.shape, dtype=np.uint8)
    heat_kernel(values, np.ascontiguousarray(_codes(heat)), _reason_slots(), LEVELS, top_down,
                index)
    return index


def heat_map_rgb(heat, top_down=False):
    """The picture's colours, (H, W, 3) uint8 (heat_palette at heat_map_indices)."""
    return heat_palette()[heat_map_indices(heat, top_down)]


def heat_map_indices_numpy(heat):
    """The definition of heat_map_indices: the level of min(max(e / top, 0), 1) rounded half up
    in sqrt space; a known reason's slot wins; any other texel without an error is
    HEAT_COLOURS[0]'s slot."""
    index = _codes(heat)
    heat = np.asarray(heat, dtype=np.float64)
    finite = np.isfinite(heat)
    top = max(0.5, float(np.nanmax(heat)) if finite.any() else 0.5)
    v = np.clip(np.nan_to_num(heat, nan=0.0) / top, 0, 1)
    out = np.floor(np.sqrt(v) * (LEVELS - 1) + 0.5).astype(np.uint8)
    slots = _reason_slots()
    reason = (slots[index] != 0) & (index != 0)
    out[reason] = slots[index[reason]]
    out[~reason & ~finite] = LEVELS                   # HEAT_COLOURS[0]: no error
    return out


@kernel()
def heat_kernel(heat, codes, slots, levels, top_down, index):
    """Compiled twin of heat_map_indices_numpy, rows flipped when top_down."""
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
            if slots[c] != 0 and c != 0:
                index[row, x] = slots[c]
            elif not np.isfinite(e):
                index[row, x] = slots[0]
            else:
                v = min(max(e / top, 0.0), 1.0)    # np.clip(heat / top, 0, 1)
                index[row, x] = np.uint8(np.floor(np.sqrt(v) * (levels - 1) + 0.5))


def _load():
    """Load the kernel for the types compare uses (raster.load_compiled)."""
    index = np.empty((1, 1), dtype=np.uint8)
    heat_kernel(np.zeros((1, 1)), np.zeros((1, 1), dtype=np.uint8), _reason_slots(), LEVELS,
                True, index)


compiled.LOADERS.append(_load)
