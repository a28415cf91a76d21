"""Meshes into texels: rasterise a mesh's triangles into the W x H texture of one UV map.

Conventions follow Blender's bake: texel (i, j) is shaded at its centre nudged by Blender's
bake offset, ((i + 0.501) / W, (j + 0.502) / H) (image_sampling.BAKE_TEXEL_OFFSET), row j = 0
at v = 0 (bottom, as in Image.pixels). With as_baked, a texel's barycentrics are the ones
Blender's float32 scan conversion hands Cycles (scan_weights.py; on a UV sliver they move the
shaded point along the face), else exact. Texels no triangle covers are marked (triangle index
-1), never filled in.

Contested texels follow Blender's bake (render/intern/bake.cc, RE_bake_pixels_populate):
triangles are scan-converted in loop-triangle order and each writes every texel it covers
(store_bake_pixel), so a texel several triangles claim goes to the LAST of them, the highest
triangle index (pinned on every line: tests/test_raster_rules.py). Texels are clipped to the
image: UVs outside 0..1 bake nothing (no wrap); a UDIM tile is the image of its own UV square
(uv_offset, see tiles.py). TexelData flags texels claimed by two triangles' interiors
(`contested`: overlapping UV islands) and texels within float32 rounding of an edge
(`on_edge`): there Blender's float32 scan conversion decides the side, and on an island border
Cycles' bake finds the sample outside its triangle and moves it by a hashed jitter
(integrator_init_from_bake, bake_jitter_barycentric).

Everything is vectorised over candidate texels: each triangle is cut into one span of texels
per row, and spans are expanded band by band of rows; only a loop over bands remains.

The mesh comes in as MeshArrays (mesh_arrays.py); the texels go out as TexelData (texels.py).
"""

import numbers
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import compiled, raster_kernels, scan_weights
# The kernel modules, imported for their compiled.LOADERS (load_compiled runs them).
from . import (height_map_kernels, listing_kernels, normal_map_kernels,  # noqa: F401
               parallax_kernels, sampling_kernels)
from .blender_lines import MAIN_LINE
from .mesh_arrays import MeshArrays
# BLOCK_TEXELS also from here: harness/bench_reference.py reads raster.BLOCK_TEXELS.
from .texels import BLOCK_TEXELS, TexelData  # noqa: F401
from .threads import reference_threads

# Texels per band of rows in rasterize (its working memory is about 150 bytes x this);
# 16K measured 1.1-2x faster than 64K (cache).
_BAND_TEXELS = 1 << 14
# The compiled rasteriser splits an image of this many texels or more into bands of rows that
# threads scan at once (a 4096^2 sphere: 0.63 s on one thread); BANDS_PER_THREAD bands each.
PARALLEL_RASTER_TEXELS = 1 << 18
BANDS_PER_THREAD = 4
# Float32 rounding of Blender's scan conversion, in texels at 256^2 (scaled with the size),
# for UVs on the UDIM grid (|u|, |v| up to _GRID_REACH); beyond it, scaled with a
# triangle's farthest UV (float32 rounds a UV to its magnitude's step).
_EDGE_TEXELS = 1e-4
_GRID_REACH = 10.0
# Texel bounds are cut to this before they become integers (a UV of 1e30 from a file).
_BOUND_TEXELS = float(1 << 40)


def rasterize(mesh, uv_map, width, height, sample_offset=None, facts=MAIN_LINE,
              uv_offset=(0.0, 0.0), as_baked=False):
    """Rasterise `mesh` into a width x height texture of UV map `uv_map` (see module doc).
    sample_offset: where in its texel each texel is sampled (default: where the bake of
    `facts`' line shades; (0.5, 0.5) for exact centres). facts: the Blender line modelled.
    uv_offset: the UV corner of the image (a UDIM tile's, tiles.tile_uv_offset).
    as_baked: each texel's barycentrics as Blender's bake computes them in float32
    (scan_weights.py), for a comparison with a bake; else exact (clamped at an edge)."""
    if sample_offset is None:
        sample_offset = facts.bake_texel_offset
    mesh.validate()
    if any(isinstance(n, bool) or not isinstance(n, numbers.Integral) for n in (width, height)):
        # (a float size failed deep in numpy: "Cannot cast array data from dtype('float64')")
        raise ValueError(f"bake resolution must be whole numbers of texels, got {width!r} x "
                         f"{height!r}")
    width, height = int(width), int(height)
    if width < 1 or height < 1:
        raise ValueError(f"bake resolution must be positive, got {width} x {height}")
    uv = mesh.uv(uv_map)
    # Sample space: texel (i, j) is sampled at (i, j).
    q = ((uv - np.asarray(uv_offset, dtype=np.float64)) * np.array([width, height], dtype=np.float64)
         - np.asarray(sample_offset))
    a, b, c = q[:, 0], q[:, 1], q[:, 2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    bounds = np.clip(q, -_BOUND_TEXELS, _BOUND_TEXELS)
    lo = np.ceil(bounds.min(axis=1) - 1e-9).astype(np.int64)
    hi = np.floor(bounds.max(axis=1) + 1e-9).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [width - 1, height - 1])
    span = np.maximum(hi - lo + 1, 0)
    counts = span[:, 0] * span[:, 1]
    counts[area == 0] = 0  # zero-area UV triangles cover nothing
    coef = _barycentric_coefficients(a, b, c, area)
    # Near an edge (within float32 rounding of Blender's scan conversion, in barycentric units
    # of each triangle) a texel's side is not decided by exact arithmetic.
    edge_len = np.stack([np.hypot(*(b - c).T), np.hypot(*(c - a).T), np.hypot(*(a - b).T)], 1)
    altitude = np.abs(area) / np.maximum(edge_len.max(axis=1), 1e-300)
    # A triangle reaching u = 1e5 (a corner dragged off in a file) has its edges decided by
    # Blender to a fifth of a texel at 32^2.
    reach = np.clip(np.abs(uv).max(axis=(1, 2)) / _GRID_REACH, 1.0, 1e12)
    tol = _EDGE_TEXELS * max(width, height) / 256 * reach / np.maximum(altitude, 1e-300)
    # Each triangle's texels, row by row: a row of a triangle is one span of x (the three
    # edge half-planes cut the row into an interval), widened by a texel each side so that
    # the per-texel test below, not the span's rounding, decides every texel. Spans are taken
    # in row order (triangle order within a row) and expanded band by band of rows, so the
    # working memory is a band's, not the image's.
    # as_baked: the weights Blender's float32 scan gives Cycles (scan_weights.py).
    scan = scan_weights.triangle_planes(uv, width, height, uv_offset, sample_offset) \
        if as_baked else None
    if compiled.enabled():
        return _rasterize_compiled(mesh, uv_map, width, height, facts, uv_offset, coef, tol,
                                   lo, hi, counts, scan)
    span_t, span_y, span_x0, span_x1 = _row_spans(coef, lo, hi, counts, np.maximum(tol, 1e-12))
    npx = width * height
    triangle = np.full(npx, -1, dtype=np.int32)
    other_tri = np.full(npx, -1, dtype=np.int32)
    contested = np.zeros(npx, dtype=bool)
    on_edge = np.zeros(npx, dtype=bool)
    # Texels are at most the candidates; filled band by band in row-major order.
    n_max = min(npx, int(np.sum(span_x1 - span_x0 + 1)))
    pixel = np.empty((n_max, 2), dtype=np.int64)
    bary_out = np.empty((n_max, 3))
    n_out = 0
    band_rows = max(1, _BAND_TEXELS // width)
    row_start = np.searchsorted(span_y, np.arange(0, height + band_rows, band_rows))
    # Barycentric k is affine in the texel position: (coef[t, k, 0] x + coef[t, k, 1] y) +
    # coef[t, k, 2], evaluated in exactly that order everywhere (bit-identical results).
    cx = [np.ascontiguousarray(coef[:, k, 0]) for k in range(3)]
    cy = [np.ascontiguousarray(coef[:, k, 1]) for k in range(3)]
    cc = [np.ascontiguousarray(coef[:, k, 2]) for k in range(3)]
    for b, y0 in enumerate(range(0, height, band_rows)):
        s0, s1 = row_start[b], row_start[b + 1]
        if s1 <= s0:
            continue
        y1 = min(height, y0 + band_rows)
        st, sy = span_t[s0:s1], span_y[s0:s1]
        n = span_x1[s0:s1] - span_x0[s0:s1] + 1
        t = np.repeat(st, n)
        px = np.repeat(span_x0[s0:s1] - np.cumsum(n) + n, n) + np.arange(n.sum())
        bary = []
        for k in range(3):      # per span: the row's term; per texel: the rest
            bk = np.repeat(cx[k][st], n) * px
            bk += np.repeat(cy[k][st] * sy, n)
            bk += np.repeat(cc[k][st], n)
            bary.append(bk)
        score = np.minimum(np.minimum(bary[0], bary[1]), bary[2])
        tol_t = np.repeat(tol[st], n)
        cand = np.nonzero(score >= -tol_t)[0]       # near an edge or inside
        flat = (np.repeat(sy - y0, n) * width + px)[cand]
        score, t, tol_t = score[cand], t[cand], tol_t[cand]
        band_px = (y1 - y0) * width
        near_claims = np.bincount(flat, minlength=band_px)
        strict_claims = np.bincount(flat[score > tol_t], minlength=band_px)
        # The bake's rule: the last triangle (highest index) containing the sample point wins.
        # A texel's candidates come in ascending triangle order (spans are), so the last one
        # is the winner and the one before it the other claimant; only texels claimed more
        # than once need sorting.
        inside = score >= -1e-12
        fi, ti, ci = flat[inside], t[inside], cand[inside]
        best = np.full(band_px, -1, dtype=np.int32)
        other = np.full(band_px, -1, dtype=np.int32)
        winner = np.zeros(band_px, dtype=np.int64)     # the winning candidate of a texel
        claims = np.bincount(fi, minlength=band_px)
        multi = claims[fi] > 1
        one = ~multi
        best[fi[one]] = ti[one]
        winner[fi[one]] = ci[one]
        if multi.any():
            m = np.nonzero(multi)[0]
            m = m[np.argsort(fi[m], kind="stable")]
            fm, tm = fi[m], ti[m]
            last = np.ones(len(m), dtype=bool)
            last[:-1] = fm[1:] != fm[:-1]
            prev = np.nonzero(last[1:] & ~last[:-1])[0]
            other[fm[prev + 1]] = tm[prev]
            best[fm[last]] = tm[last]
            winner[fm[last]] = ci[m[last]]
        cov = np.nonzero(best >= 0)[0]
        k = len(cov)
        x, y = cov % width, cov // width + y0
        tc = best[cov]
        # The winner's barycentrics, clamped and renormalised (summed in order 0, 1, 2).
        wc = winner[cov]
        bb = bary_out[n_out:n_out + k]
        cols = [b[wc] for b in bary]
        lowest = np.minimum(np.minimum(cols[0], cols[1]), cols[2])
        for j in range(3):
            np.maximum(cols[j], 0.0, out=bb[:, j])
        bb /= ((bb[:, 0] + bb[:, 1]) + bb[:, 2])[:, None]
        pixel[n_out:n_out + k, 0] = x
        pixel[n_out:n_out + k, 1] = y
        n_out += k
        sl = slice(y0 * width, y1 * width)
        triangle[sl] = best
        other_tri[sl] = other
        contested[sl] = strict_claims >= 2
        # Within rounding of an edge: another triangle may take the texel, or (an island
        # border) Cycles finds the sample outside its triangle and moves it
        # (bake_jitter_barycentric).
        edge = (near_claims >= 2) & (strict_claims < 2) & (best >= 0)
        edge[cov] |= lowest <= tol[tc]
        on_edge[sl] = edge
    tri_out = triangle[pixel[:n_out, 1] * width + pixel[:n_out, 0]]
    bary = bary_out[:n_out] if scan is None else scan_weights.weights_from_planes(
        scan, tri_out, pixel[:n_out], bary_out[:n_out])
    return TexelData(mesh=mesh, uv_map=uv_map, width=width, height=height,
                     triangle=triangle.reshape(height, width), pixel=pixel[:n_out],
                     barycentric=bary,
                     facts=facts, uv_offset=tuple(float(o) for o in uv_offset),
                     contested=contested.reshape(height, width),
                     other_triangle=other_tri.reshape(height, width),
                     on_edge=on_edge.reshape(height, width))


_LOADED = []


def load_compiled():
    """Load (or, once per machine, compile) the compiled kernels before any timing, the way a
    process imports its libraries: a tiny rasterisation and interpolation of every type the
    real ones use. Returns the seconds it took (0 when kernels are off or already loaded)."""
    if not compiled.enabled() or _LOADED:
        return 0.0
    import time
    t0 = time.perf_counter()
    tri = MeshArrays(positions=np.eye(3), triangles=np.array([[0, 1, 2]]),
                     corner_normals=np.tile([0.0, 0.0, 1.0], (1, 3, 1)),
                     uv_maps={"UV": np.array([[[0.1, 0.1], [0.9, 0.1], [0.1, 0.9]]])})
    td = rasterize(tri, "UV", 4, 4, as_baked=True)
    block = td.block(0, td.texel_count)
    block.position
    block.shading_normal
    td.pixel
    td.uv()
    for hook in compiled.LOADERS:
        hook()
    _LOADED.append(True)
    return time.perf_counter() - t0


def _rasterize_compiled(mesh, uv_map, width, height, facts, uv_offset, coef, tol, lo, hi,
                        counts, scan=None):
    """rasterize's spans and band loop as two compiled passes (raster_kernels): the scan of
    every triangle's rows, then the flags and the covered texels per row. The texels' (x, y)
    and barycentrics are left to the blocks (TexelData.row_start): identical values, and
    memory of the triangle image, not of every texel's attributes."""
    npx = width * height
    triangle = np.full(npx, -1, dtype=np.int32)
    other_tri = np.full(npx, -1, dtype=np.int32)
    near = np.zeros(npx, dtype=np.uint8)
    strict = np.zeros(npx, dtype=np.uint8)
    cx, cy, cc = (np.ascontiguousarray(coef[:, :, j].T) for j in range(3))
    tol = np.ascontiguousarray(tol, dtype=np.float64)
    span_tol = np.maximum(tol, 1e-12)
    lo, hi = np.ascontiguousarray(lo), np.ascontiguousarray(hi)
    on_edge = np.zeros(npx, dtype=bool)
    row_count = np.zeros(height, dtype=np.int64)
    contested = np.empty(npx, dtype=bool)

    def band(rows):
        """Scan and flag the rows [y_lo, y_hi): the same texels and values as one pass."""
        y_lo, y_hi = rows
        raster_kernels.scan_triangles(cx, cy, cc, tol, span_tol, lo, hi, counts, width,
                                      triangle, other_tri, near, strict, y_lo, y_hi)
        raster_kernels.texel_flags(triangle, near, strict, cx, cy, cc, tol, width, row_count,
                                   contested, on_edge, y_lo, y_hi)
    bands = _row_bands(height, npx)
    if len(bands) == 1:
        band(bands[0])
    else:
        # The kernels release the GIL; bands hold distinct rows, so no texel is shared.
        with ThreadPoolExecutor(min(len(bands), reference_threads())) as pool:
            list(pool.map(band, bands))
    row_start = np.zeros(height + 1, dtype=np.int64)
    np.cumsum(row_count, out=row_start[1:])
    return TexelData(mesh=mesh, uv_map=uv_map, width=width, height=height,
                     triangle=triangle.reshape(height, width), facts=facts,
                     uv_offset=tuple(float(o) for o in uv_offset),
                     contested=contested.reshape(height, width),
                     other_triangle=other_tri.reshape(height, width),
                     on_edge=on_edge.reshape(height, width), row_start=row_start,
                     _shared={"raster_coefficients": (cx, cy, cc), "scan": scan})


def _row_bands(height, texels):
    """Row ranges the compiled rasteriser scans at once: one for a small image (threads would
    cost more than they save), else BANDS_PER_THREAD per thread, so a thread that finishes a
    sparse band takes the next."""
    threads = reference_threads()
    if threads == 1 or texels < PARALLEL_RASTER_TEXELS:
        return [(0, height)]
    edges = np.linspace(0, height, min(height, BANDS_PER_THREAD * threads) + 1).astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def _row_spans(coef, lo, hi, counts, tol):
    """Per (triangle, row) the x range [x0, x1] (inclusive, within the triangle's texel bounds)
    that holds every texel with all three barycentrics >= -tol, plus one texel each side.
    Returns (t, y, x0, x1) sorted by row, triangles ascending within a row; empty spans
    dropped."""
    tris = np.nonzero(counts)[0]
    rows = hi[tris, 1] - lo[tris, 1] + 1
    t = np.repeat(tris, rows)
    y = np.repeat(lo[tris, 1] - np.cumsum(rows) + rows, rows) + np.arange(rows.sum())
    x0 = lo[t, 0].astype(np.float64)
    x1 = hi[t, 0].astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for k in range(3):
            a = coef[t, k, 0]
            # a x + c >= -tol  <=>  x >= (-tol - c) / a for a > 0, x <= it for a < 0.
            bound = (-tol[t] - (coef[t, k, 1] * y + coef[t, k, 2])) / a
            x0 = np.where(a > 0, np.maximum(x0, np.floor(bound) - 1), x0)
            x1 = np.where(a < 0, np.minimum(x1, np.ceil(bound) + 1), x1)
    x0 = np.maximum(x0, lo[t, 0])
    x1 = np.minimum(x1, hi[t, 0])
    keep = x1 >= x0         # compared as floats: a sliver's huge bound must not wrap as int64
    x0, x1 = x0.astype(np.int64), x1.astype(np.int64)
    t, y, x0, x1 = t[keep], y[keep], x0[keep], x1[keep]
    order = np.argsort(y, kind="stable")
    return t[order], y[order], x0[order], x1[order]


def _barycentric_coefficients(a, b, c, area):
    """(T, 3, 3): barycentric k of texel (x, y) is coef[:, k, 0] x + coef[:, k, 1] y +
    coef[:, k, 2]. Signed sub-triangle areas over the signed area, so the inside test holds for
    clockwise and counter-clockwise (mirrored) UVs alike."""
    safe = np.where(area == 0, 1.0, area)
    rows = []
    for p0, p1 in ((b, c), (c, a), (a, b)):     # the edge opposite each corner
        ex, ey = p1[:, 0] - p0[:, 0], p1[:, 1] - p0[:, 1]
        rows.append(np.stack([-ey, ex, ey * p0[:, 0] - ex * p0[:, 1]], axis=1) / safe[:, None])
    return np.stack(rows, axis=1)
