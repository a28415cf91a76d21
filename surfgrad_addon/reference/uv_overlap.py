"""Texels that more than one UV triangle claims (overlapping UV islands, e.g. mirrored halves
stacked on each other): a bake writes only one face's normal there (the last in mesh order,
reference/raster.py), so a bake warns with their count before it starts.

Only the UV layout is needed (no positions or normals), so the check runs before any bake at
a bounded size: a texel is sampled at its centre, and a centre on an edge (within EDGE_EPS
texels, scaled by the edge's farthest corner) belongs to exactly one of the two faces sharing
it (the rasterizers' top-left rule: Cycles fills such a texel from one of them), so
neighbouring faces of one island never count as overlapping, and stacked islands do along
their inner edges too. (Before red team 50a such a centre belonged to neither side: a mirrored
grid stacked on itself, whose quad diagonals run through texel centres, was warned as 50%
overlapping at 32^2 where all of it is.)
"""

import numpy as np

EDGE_EPS = 1e-6          # relative to twice the triangle's area: float32 UVs on a shared edge
_CHUNK = 1 << 20         # candidate texels per pass: bounded memory at any size


def contested_texels(uv_triangles, size, uv_offset=(0.0, 0.0)):
    """How many texel centres of a size x size image of the unit square at uv_offset (a UDIM
    tile's corner) lie strictly inside two or more UV triangles (T, 3, 2) with area."""
    return int(np.count_nonzero(claimed_texels(uv_triangles, size, uv_offset,
                                                one_side=True) >= 2))


def claimed_texels(uv_triangles, size, uv_offset=(0.0, 0.0), edges=False, one_side=False):
    """Per texel (size * size, row-major) of the unit square at uv_offset, how many UV
    triangles (T, 3, 2) with area hold its centre strictly inside (edges=True: or on an
    edge, within EDGE_EPS, so an island's texels on its inner edges count as covered;
    one_side=True: a centre on an edge counts for one of the two faces sharing it)."""
    claims = np.zeros(size * size, dtype=np.int32)
    for _tri, texel in _claims(uv_triangles, size, uv_offset, edges, one_side):
        np.add.at(claims, texel, 1)
    return claims


def claimants(uv_triangles, size, texels, uv_offset=(0.0, 0.0)):
    """Every (texel, triangle) claim, as claimed_texels(one_side=True) counts them, at the
    texels (flat indices of the size x size square) asked for: all the triangles stacked on a
    texel, not only the last two a rasteriser keeps (a box whose six sides share the square
    has six faces on each texel)."""
    wanted = np.zeros(size * size, dtype=bool)
    wanted[np.asarray(texels, dtype=np.int64)] = True
    found_texel, found_tri = [], []
    for tri, texel in _claims(uv_triangles, size, uv_offset, False, True, wanted):
        keep = wanted[texel]
        found_texel.append(texel[keep])
        found_tri.append(tri[keep])
    if not found_texel:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return np.concatenate(found_texel), np.concatenate(found_tri)


def _claims(uv_triangles, size, uv_offset, edges, one_side, wanted=None):
    """The claims of claimed_texels, a group of triangles at a time: (triangle, texel) arrays
    of every texel centre a triangle holds (with `wanted`, a mask of texels: only triangles
    whose bounds hold one of them are scanned, so a few stacked faces cost a few faces)."""
    uv = np.asarray(uv_triangles, dtype=np.float64).reshape(-1, 3, 2)
    q = (uv - np.asarray(uv_offset, dtype=np.float64)) * size - 0.5   # centre of texel i is i
    a, b, c = q[:, 0], q[:, 1], q[:, 2]
    with np.errstate(invalid="ignore", over="ignore"):     # NaN / Inf: left out below
        area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    # Bounds clipped before the cast (a UV of 1e30 from a file overflows an integer); a
    # triangle with a NaN or Inf UV claims nothing.
    finite = np.isfinite(q).all(axis=(1, 2))
    bounds = np.where(finite[:, None, None], q, 0.0)
    lo = np.clip(np.ceil(bounds.min(axis=1)), 0, size).astype(np.int64)
    hi = np.clip(np.floor(bounds.max(axis=1)), -1, size - 1).astype(np.int64)
    span = np.maximum(hi - lo + 1, 0)
    count = span[:, 0] * span[:, 1]
    count[(area == 0) | ~finite] = 0
    if wanted is not None:
        # Wanted texels inside each triangle's bounds, by a summed-area table.
        table = np.zeros((size + 1, size + 1), dtype=np.int64)
        np.cumsum(np.cumsum(wanted.reshape(size, size), axis=0), axis=1, out=table[1:, 1:])
        x0, y0 = np.minimum(lo[:, 0], size), np.minimum(lo[:, 1], size)
        x1, y1 = np.maximum(hi[:, 0] + 1, x0), np.maximum(hi[:, 1] + 1, y0)
        held = table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]
        count[held == 0] = 0
    keep = np.flatnonzero(count)
    if len(keep) == 0:
        return
    # Triangles in groups whose candidate texels fit one pass.
    bounds = np.searchsorted(np.cumsum(count[keep]), np.arange(_CHUNK, count.sum(), _CHUNK))
    for group in np.split(keep, bounds):
        n = count[group]
        tri = np.repeat(group, n)
        k = np.arange(len(tri)) - np.repeat(np.cumsum(n) - n, n)
        x = lo[tri, 0] + k % span[tri, 0]
        y = lo[tri, 1] + k // span[tri, 0]
        inside = np.ones(len(tri), dtype=bool)
        s = np.sign(area[tri])
        for p0, p1 in ((a, b), (b, c), (c, a)):        # each edge's half-plane, inward side
            e = (p1[tri, 0] - p0[tri, 0]) * (y - p0[tri, 1]) - \
                (p1[tri, 1] - p0[tri, 1]) * (x - p0[tri, 0])
            if one_side:
                inside &= _one_side(s * e, s[:, None] * (p1[tri] - p0[tri]), p0[tri], p1[tri])
            else:
                inside &= s * e > (-1 if edges else 1) * EDGE_EPS * np.abs(area[tri])
        yield tri[inside], y[inside] * size + x[inside]


def _one_side(e, d, p0, p1):
    """Inside this edge's half-plane (e > 0 inward, d the edge's direction counter-clockwise):
    off the edge by more than the band, or on it where the edge runs up (or level, leftward).
    The face across a shared edge sees -d exactly and the same band, so it takes the centres
    this one leaves: each centre on an inner edge counts once."""
    band = EDGE_EPS * np.maximum(1.0, np.maximum(np.abs(p0).max(axis=1), np.abs(p1).max(axis=1)))
    band = band * np.hypot(d[:, 0], d[:, 1])          # e is the distance times the edge length
    up_or_left = (d[:, 1] > 0) | ((d[:, 1] == 0) & (d[:, 0] < 0))
    return (e > band) | ((np.abs(e) <= band) & up_or_left)
