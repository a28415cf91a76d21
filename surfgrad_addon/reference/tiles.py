"""Which image a texel of a UV layout lands in: UDIM tiles and the 0..1 square (no bpy).

Blender's bake (render/intern/bake.cc, RE_bake_pixels_populate) rasterises every triangle into
every image of its material, each at the image's UV offset: a plain image is the UV square
0..1 and what lies outside bakes nothing (no wrap: pinned in tests/test_raster_rules.py); a
UDIM tile numbered 1001 + u + 10 v is the square [u, u + 1) x [v, v + 1). Shared by the
reference (rasterize(uv_offset=...)) and the bake side: the one module for tile maths
(numbers, offsets, which tiles a layout touches, tile lists as typed, file names per tile).
"""

import numbers
from pathlib import Path

import numpy as np

UDIM_FIRST = 1001
UDIM_COLUMNS = 10
UDIM_LAST = 2000          # Blender's highest tile number
UDIM_ROWS = (UDIM_LAST - UDIM_FIRST + 1) // UDIM_COLUMNS
# The tiles' UV square in words, for messages: v >= 100 lies beyond tile 2000, outside too.
UDIM_SPAN = f"u 0..{UDIM_COLUMNS}, v 0..{UDIM_ROWS}"
UDIM_TOKEN = "<UDIM>"     # in an output name: one file per tile, the number in its place
UVTILE_TOKEN = "<UVTILE>"    # Blender's other tile token (read in textures, not written)


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


def parse_tiles(value):
    """'1001-1003,1005' / [1001, 1002] / None -> sorted tile numbers (None stays None).
    Raises ValueError naming the form to use."""
    if value is None or isinstance(value, str) and not value:
        return None
    if not isinstance(value, (str, numbers.Integral)):
        # A list, a tuple, a numpy array (which `in (None, [])` could not even compare).
        try:
            given = [_whole(v) for v in value]
        except (TypeError, ValueError):
            raise ValueError(f"tiles {value!r}: give UDIM numbers like 1001,1002 or "
                             f"1001-1010") from None
        return sorted(set(given)) or None
    tiles = set()
    for part in str(value).replace(" ", "").split(","):
        if not part:
            continue
        try:
            if "-" in part:
                a, b = (int(x) for x in part.split("-", 1))
            else:
                a = b = int(part)
        except ValueError:
            raise ValueError(f"tiles {value!r}: give UDIM numbers like 1001,1002 or "
                             f"1001-1010") from None
        if b < a:
            raise ValueError(f"tiles {value!r}: the range {part!r} runs backwards (no "
                             f"tiles); write it low to high, like {b}-{a}")
        outside = next((t for t in (a, b) if not UDIM_FIRST <= t <= UDIM_LAST), None)
        if outside is not None:
            # before the range is made: 1001-1000000000 built a billion-tile set (14 s, GBs)
            raise ValueError(f"tile {outside}: UDIM tiles are numbered {UDIM_FIRST} to "
                             f"{UDIM_LAST}")
        tiles.update(range(a, b + 1))
    if not tiles:                     # ',' alone: no tile at all, not "every tile"
        raise ValueError(f"tiles {value!r}: no tile given; give UDIM numbers like 1001,1002 "
                         f"or 1001-1010")
    return sorted(tiles)


def _whole(v):
    """A tile number given as a number or its text; ValueError for any other (1001.5 was cut to
    1001, True taken as tile 1)."""
    if isinstance(v, bool) or not isinstance(v, (str, numbers.Integral)) and \
            not (isinstance(v, numbers.Real) and float(v).is_integer()):
        raise ValueError(v)
    return int(v)


def tiles_text(tiles):
    """Tile numbers as a message shows them."""
    return ", ".join(map(str, tiles)) if tiles else "none"


def tile_path(output, tile):
    """The file of UDIM tile `tile` for a name with <UDIM>, or with Blender's other tile token
    <UVTILE> (u<column>_v<row>, from 1: Mari's and Mudbox's texture names), or the name
    itself."""
    u, v = (tile - UDIM_FIRST) % UDIM_COLUMNS + 1, (tile - UDIM_FIRST) // UDIM_COLUMNS + 1
    return Path(str(output).replace(UDIM_TOKEN, str(tile)).replace(UVTILE_TOKEN, f"u{u}_v{v}"))


# Exact tile maths: which tiles a triangle really covers (area, not its bounding box) -------------

_GRID = (UDIM_COLUMNS, (UDIM_LAST - UDIM_FIRST) // UDIM_COLUMNS + 1)   # 10 x 100 tile squares
# Overlap thinner than this (UV units) is none: float32 UVs a rounding past a border (1e-7)
# reach no texel centre at any image size Blender makes.
BORDER_EPS = 1e-6


def _overlaps_square(uv, lo):
    """(P,) True where triangle uv (P, 3, 2) and the unit square at corner lo (P, 2) share
    area. Separating axes of two convex shapes: the square's two and the triangle's three
    edge normals; touching (a shared edge or corner) is no overlap. A zero-area triangle
    overlaps nothing."""
    hi = lo + 1.0
    e = BORDER_EPS
    sep = (uv[..., 0].max(1) <= lo[:, 0] + e) | (uv[..., 0].min(1) >= hi[:, 0] - e) | \
        (uv[..., 1].max(1) <= lo[:, 1] + e) | (uv[..., 1].min(1) >= hi[:, 1] - e)
    corners = np.stack([lo, [1, 0] * hi + [0, 1] * lo, hi, [0, 1] * hi + [1, 0] * lo], 1)
    for k in range(3):
        a, b = uv[:, k], uv[:, (k + 1) % 3]
        axis = np.stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]], -1)     # the edge's normal
        t = np.einsum("pi,pki->pk", axis, uv)
        s = np.einsum("pi,pki->pk", axis, corners)
        e = BORDER_EPS * np.linalg.norm(axis, axis=-1)
        sep |= (t.max(1) <= s.min(1) + e) | (s.max(1) <= t.min(1) + e)
    return ~sep


def triangle_tiles(uv_triangles):
    """(triangle index (P,), tile number (P,)) for every UV triangle (T, 3, 2) and UDIM tile
    that share area: what a bake into that tile can write (no bounding-box guesses). Tiles
    outside the UDIM grid (u < 0, u >= 10, v < 0, beyond 2000) are not listed."""
    uv = np.asarray(uv_triangles, dtype=np.float64).reshape(-1, 3, 2)
    if len(uv) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    # A triangle with a NaN or Inf UV (refused by the checks, which read the tiles first)
    # covers no tile; its bounds are taken at 0 so that no NaN is cast to an integer.
    finite = np.isfinite(uv).all(axis=(1, 2))
    bounds = np.where(finite[:, None, None], uv, 0.0)
    lo = np.clip(np.floor(bounds.min(1)), -1, _GRID).astype(np.int64)
    hi = np.clip(np.ceil(bounds.max(1)) - 1, -1, _GRID).astype(np.int64)
    lo, hi = np.maximum(lo, 0), np.minimum(hi, np.array(_GRID) - 1)
    n = np.maximum(hi - lo + 1, 0)
    count = n[:, 0] * n[:, 1] * finite
    tri = np.repeat(np.arange(len(uv)), count)
    k = np.arange(len(tri)) - np.repeat(np.cumsum(count) - count, count)
    iu = lo[tri, 0] + k % np.maximum(n[tri, 0], 1)
    iv = lo[tri, 1] + k // np.maximum(n[tri, 0], 1)
    ok = _overlaps_square(uv[tri], np.stack([iu, iv], -1).astype(np.float64))
    number = UDIM_FIRST + iu + UDIM_COLUMNS * iv
    ok &= number <= UDIM_LAST
    return tri[ok], number[ok]


def tiles_with_uvs(uv_triangles):
    """Sorted UDIM tiles some UV triangle (T, 3, 2) covers with area (triangle_tiles)."""
    return sorted(int(t) for t in np.unique(triangle_tiles(uv_triangles)[1]))


def triangles_outside(uv_triangles, tiles=None):
    """(T,) True where a UV triangle has area outside the given tiles (None: outside the
    UDIM grid): the part a bake into those tiles does not write. A triangle is inside when
    it lies in the tiles' squares' union: inside the UDIM grid (tiles 1001 to 2000: u 0..10,
    v 0..100) and every tile it covers is one of them (within BORDER_EPS). Zero-area
    triangles are never outside (they bake nothing anywhere)."""
    uv = np.asarray(uv_triangles, dtype=np.float64).reshape(-1, 3, 2)
    with np.errstate(invalid="ignore", over="ignore"):     # NaN / Inf UVs: no area here
        area2 = np.abs((uv[:, 1, 0] - uv[:, 0, 0]) * (uv[:, 2, 1] - uv[:, 0, 1])
                       - (uv[:, 2, 0] - uv[:, 0, 0]) * (uv[:, 1, 1] - uv[:, 0, 1]))
    e = BORDER_EPS
    in_grid = np.all((uv >= -e) & (uv <= np.array(_GRID, dtype=np.float64) + e), axis=(1, 2))
    outside = ~in_grid
    if tiles is not None:
        tri, number = triangle_tiles(uv)
        wanted = np.isin(number, np.asarray(sorted(int(t) for t in tiles), dtype=np.int64))
        outside[tri[~wanted]] = True
    return outside & (area2 > 0)
