"""Which image a texel of a UV layout lands in: UDIM tiles and the 0..1 square (no bpy).

Blender's bake (render/intern/bake.cc, RE_bake_pixels_populate) rasterises every triangle into
every image of its material, each at the image's UV offset: a plain image is the UV square
0..1 and what lies outside bakes nothing (no wrap: pinned in tests/test_raster_rules.py); a
UDIM tile numbered 1001 + u + 10 v is the square [u, u + 1) x [v, v + 1). Shared by the
reference (rasterize(uv_offset=...)) and the bake side: the one module for tile maths
(numbers, offsets, which tiles a layout touches, tile lists as typed, file names per tile).
"""

from pathlib import Path

import numpy as np

UDIM_FIRST = 1001
UDIM_COLUMNS = 10
UDIM_LAST = 2000          # Blender's highest tile number
UDIM_TOKEN = "<UDIM>"     # in an output name: one file per tile, the number in its place


def tile_uv_offset(number):
    """The UV corner (u, v) of UDIM tile `number` (1001 -> (0, 0), 1012 -> (1, 1))."""
    number = int(number)
    if not UDIM_FIRST <= number <= UDIM_LAST:
        raise ValueError(f"UDIM tile {number} is out of range; tiles are numbered "
                         f"{UDIM_FIRST} to {UDIM_LAST}")
    k = number - UDIM_FIRST
    return float(k % UDIM_COLUMNS), float(k // UDIM_COLUMNS)


def tile_number(u, v):
    """The UDIM tile holding UV (u, v) (arrays allowed), or -1 outside the tile grid (u < 0,
    u >= 10, v < 0, or beyond tile 2000)."""
    iu, iv = np.floor(np.asarray(u, float)).astype(np.int64), \
        np.floor(np.asarray(v, float)).astype(np.int64)
    n = UDIM_FIRST + iu + UDIM_COLUMNS * iv
    ok = (iu >= 0) & (iu < UDIM_COLUMNS) & (iv >= 0) & (n <= UDIM_LAST)
    return np.where(ok, n, -1)


def tiles_touched(uv_triangles):
    """Sorted UDIM tile numbers that some UV triangle (T, 3, 2) overlaps, by the bounding box
    of each triangle (a tile its box touches but the triangle misses bakes nothing, which
    rasterising that tile reports)."""
    uv = np.asarray(uv_triangles, dtype=np.float64).reshape(-1, 3, 2)
    if len(uv) == 0:
        return []
    lo = np.floor(uv.min(axis=1)).astype(np.int64)
    hi = np.ceil(uv.max(axis=1)).astype(np.int64) - 1
    hi = np.maximum(hi, lo)
    lo = np.clip(lo, 0, [UDIM_COLUMNS - 1, 99])
    hi = np.clip(hi, -1, [UDIM_COLUMNS - 1, 99])
    found = set()
    for (u0, v0), (u1, v1) in {(tuple(a), tuple(b)) for a, b in zip(lo, hi)}:
        for iv in range(v0, v1 + 1):
            for iu in range(u0, u1 + 1):
                n = UDIM_FIRST + iu + UDIM_COLUMNS * iv
                if n <= UDIM_LAST:
                    found.add(n)
    return sorted(found)


def fraction_inside_unit_square(uv_triangles):
    """Share of UV triangle corners inside 0..1: near 0 means a plain image bakes nothing."""
    uv = np.asarray(uv_triangles, dtype=np.float64).reshape(-1, 2)
    if len(uv) == 0:
        return 0.0
    return float(np.mean(np.all((uv >= 0) & (uv <= 1), axis=1)))


def face_tiles(uv, loop_starts, eps=1e-6):
    """(sorted UDIM tiles, faces outside the tile grid) of a UV layout given per loop (L, 2)
    with each face's first loop. A face counts in every tile its UV bounding box reaches into
    (a face ending exactly on a tile border, within eps, does not reach the next tile); it
    lies outside when its box leaves u 0..10 or v >= 0 or passes tile 2000."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    starts = np.asarray(loop_starts, dtype=np.int64)
    if len(starts) == 0:
        return [], 0
    lo = np.minimum.reduceat(uv, starts, axis=0)
    hi = np.maximum.reduceat(uv, starts, axis=0)
    t_lo = np.floor(lo + eps).astype(np.int64)
    t_hi = np.floor(hi - eps).astype(np.int64)
    t_hi = np.maximum(t_hi, t_lo)               # degenerate faces on a border
    outside = (t_lo[:, 0] < 0) | (t_hi[:, 0] >= UDIM_COLUMNS) | (t_lo[:, 1] < 0) | \
        (UDIM_FIRST + t_hi[:, 1] * UDIM_COLUMNS > UDIM_LAST)
    tiles = set()
    span = t_hi - t_lo
    inside = ~outside
    if inside.any():
        simple = inside & (span[:, 0] == 0) & (span[:, 1] == 0)
        tiles.update((UDIM_FIRST + t_lo[simple, 0] + UDIM_COLUMNS * t_lo[simple, 1]).tolist())
        for i in np.flatnonzero(inside & ~simple):      # faces across tile borders (few)
            for v in range(t_lo[i, 1], t_hi[i, 1] + 1):
                for u in range(t_lo[i, 0], t_hi[i, 0] + 1):
                    tiles.add(UDIM_FIRST + u + UDIM_COLUMNS * v)
    return sorted(int(t) for t in tiles), int(outside.sum())


def parse_tiles(value):
    """'1001-1003,1005' / [1001, 1002] / None -> sorted tile numbers (None stays None).
    Raises ValueError naming the form to use."""
    if value in (None, "", []):
        return None
    if isinstance(value, (list, tuple)):
        try:
            return sorted({int(v) for v in value})
        except (TypeError, ValueError):
            raise ValueError(f"tiles {value!r}: give UDIM numbers like 1001,1002 or "
                             f"1001-1010") from None
    tiles = set()
    for part in str(value).replace(" ", "").split(","):
        if not part:
            continue
        try:
            if "-" in part:
                a, b = part.split("-", 1)
                tiles.update(range(int(a), int(b) + 1))
            else:
                tiles.add(int(part))
        except ValueError:
            raise ValueError(f"tiles {value!r}: give UDIM numbers like 1001,1002 or "
                             f"1001-1010") from None
    return sorted(tiles)


def tiles_text(tiles):
    """Tile numbers as a message shows them."""
    return ", ".join(map(str, tiles)) if tiles else "none"


def tile_path(output, tile):
    """The file of UDIM tile `tile` for an output name with <UDIM> (or the name itself)."""
    return Path(str(output).replace(UDIM_TOKEN, str(tile)))
