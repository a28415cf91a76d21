"""Compiled loops of raster.py and texels.py (see compiled.py): rasterize's scan conversion
and the corner interpolation of TexelData. Each computes what their numpy code computes, in the
same order of operations, so both give identical arrays (tests/test_compiled_kernels.py).

Blocks of texels already run on several threads (methods.evaluated_blocks), so these loops are
serial and release the GIL (nogil) rather than start threads of their own.
"""

import numpy as np

from .compiled import kernel
from .compiled import nan_maximum as _maximum
from .compiled import nan_minimum as _minimum


@kernel()
def _clamp_low(a):
    """np.maximum(a, 0.0): a where a >= 0 or NaN, else 0."""
    return a if (a >= 0.0 or a != a) else 0.0


@kernel()
def scan_triangles(cx, cy, cc, tol, span_tol, lo, hi, counts, width, triangle, other, near,
                   strict, y_lo, y_hi):
    """Visit every candidate texel of every triangle, triangles in index order as Blender's
    bake scan-converts them (the last triangle containing a texel wins:
    RE_bake_pixels_populate). A texel's claimants come in ascending triangle order, as in
    rasterize's row-ordered spans, so the outcome is the same. Each row of a triangle is the
    span _row_spans computes (the same bounds, in the same float steps). Fills, per texel of
    the flat image: triangle (the winner, -1 if none), other (the claimant before it), near
    and strict (how many triangles come within / lie beyond the edge tolerance, up to 2).
    Only rows y_lo..y_hi-1: bands of rows touch distinct texels, so they may run at once."""
    for t in range(cx.shape[1]):
        if counts[t] == 0 or hi[t, 1] < y_lo or lo[t, 1] >= y_hi:
            continue
        tl = tol[t]
        for y in range(max(lo[t, 1], y_lo), min(hi[t, 1] + 1, y_hi)):
            x0 = float(lo[t, 0])
            x1 = float(hi[t, 0])
            for k in range(3):
                a = cx[k, t]
                if a > 0 or a < 0:
                    bound = (-span_tol[t] - (cy[k, t] * y + cc[k, t])) / a
                    if a > 0:
                        x0 = _maximum(x0, np.floor(bound) - 1)
                    else:
                        x1 = _minimum(x1, np.ceil(bound) + 1)
            x0 = _maximum(x0, float(lo[t, 0]))
            x1 = _minimum(x1, float(hi[t, 0]))
            if not x1 >= x0:
                continue
            # Barycentric k = (cx x + cy y) + cc, in that order (rasterize's numpy bands).
            r0, r1, r2 = cy[0, t] * y, cy[1, t] * y, cy[2, t] * y
            for x in range(int(x0), int(x1) + 1):
                b0 = (cx[0, t] * x + r0) + cc[0, t]
                b1 = (cx[1, t] * x + r1) + cc[1, t]
                b2 = (cx[2, t] * x + r2) + cc[2, t]
                score = _minimum(_minimum(b0, b1), b2)
                if not score >= -tl:
                    continue
                f = y * width + x
                if near[f] < 2:
                    near[f] += 1
                if score > tl and strict[f] < 2:
                    strict[f] += 1
                if score >= -1e-12:
                    other[f] = triangle[f]
                    triangle[f] = t


@kernel()
def texel_flags(triangle, near, strict, cx, cy, cc, tol, width, row_count, contested,
                on_edge, y_lo, y_hi):
    """Per texel: claimed by two interiors (contested), within rounding of an edge (on_edge:
    claimed within tolerance by two triangles, or its winner's lowest barycentric within the
    winner's tolerance); per row: how many texels are covered. Rows y_lo..y_hi-1."""
    for y in range(y_lo, y_hi):
        row = y * width
        for x in range(width):
            f = row + x
            contested[f] = strict[f] >= 2
            t = triangle[f]
            if t < 0:
                continue
            b0 = (cx[0, t] * x + cy[0, t] * y) + cc[0, t]
            b1 = (cx[1, t] * x + cy[1, t] * y) + cc[1, t]
            b2 = (cx[2, t] * x + cy[2, t] * y) + cc[2, t]
            lowest = _minimum(_minimum(b0, b1), b2)
            on_edge[f] = (near[f] >= 2 and strict[f] < 2) or lowest <= tol[t]
            row_count[y] += 1


@kernel()
def texels_in_range(triangle, row_start, width, start, stop, cx, cy, cc, pixel, tri, bary):
    """Covered texels start..stop-1 (row-major order) of the triangle image: their (x, y),
    triangle, and the winner's barycentrics clamped to >= 0 and renormalised (summed in order
    0, 1, 2), as rasterize's numpy bands compute them. row_start[y]: covered texels before row
    y. A block's texels are made when it is evaluated, never the whole image's at once."""
    if stop <= start:
        return
    y = np.searchsorted(row_start, start, side="right") - 1
    i = row_start[y]
    height = row_start.shape[0] - 1
    while y < height:
        row = y * width
        for x in range(width):
            t = triangle[row + x]
            if t < 0:
                continue
            if i >= start:
                b0 = (cx[0, t] * x + cy[0, t] * y) + cc[0, t]
                b1 = (cx[1, t] * x + cy[1, t] * y) + cc[1, t]
                b2 = (cx[2, t] * x + cy[2, t] * y) + cc[2, t]
                b0 = _clamp_low(b0)
                b1 = _clamp_low(b1)
                b2 = _clamp_low(b2)
                total = (b0 + b1) + b2
                k = i - start
                bary[k, 0] = b0 / total
                bary[k, 1] = b1 / total
                bary[k, 2] = b2 / total
                pixel[k, 0] = x
                pixel[k, 1] = y
                tri[k] = t
            i += 1
            if i >= stop:
                return
        y += 1


@kernel()
def interpolate_corners(corners, tri, bary, out):
    """out[c, i] = corners[t, 0, c] b0 + corners[t, 1, c] b1 + corners[t, 2, c] b2 for texel i
    of triangle t = tri[i], summed in order 0, 1, 2 (TexelData._interpolate)."""
    channels = out.shape[0]
    for i in range(tri.shape[0]):
        t = tri[i]
        b0, b1, b2 = bary[i, 0], bary[i, 1], bary[i, 2]
        for c in range(channels):
            out[c, i] = (corners[t, c] * b0 + corners[t, channels + c] * b1) \
                + corners[t, 2 * channels + c] * b2


@kernel()
def gather_rows(table, tri, out):
    """out[c, i] = table[tri[i], c]: a per-triangle (T, C) array at every texel, component by
    component (vecmath's layout once transposed)."""
    for i in range(tri.shape[0]):
        t = tri[i]
        for c in range(out.shape[0]):
            out[c, i] = table[t, c]


@kernel()
def interpolate_corners_unit(corners, tri, bary, out):
    """interpolate_corners of (T, 3 * 3) corner vectors, each result divided by its length
    sqrt((x x + y y) + z z) (vecmath.normalize)."""
    for i in range(tri.shape[0]):
        t = tri[i]
        b0, b1, b2 = bary[i, 0], bary[i, 1], bary[i, 2]
        x = (corners[t, 0] * b0 + corners[t, 3] * b1) + corners[t, 6] * b2
        y = (corners[t, 1] * b0 + corners[t, 4] * b1) + corners[t, 7] * b2
        z = (corners[t, 2] * b0 + corners[t, 5] * b1) + corners[t, 8] * b2
        length = np.sqrt((x * x + y * y) + z * z)
        out[0, i] = x / length
        out[1, i] = y / length
        out[2, i] = z / length


@kernel()
def scan_weights_in(tri, pixel, uxd, uyd, uy0, vxd, vyd, vy0, my2, ok, out):
    """scan_weights.weights_from_planes's loop, the same float32 and float64 steps: out[k]
    (the exact weights on entry) becomes Blender's where those lie inside the triangle."""
    one = np.float32(1.0)
    for k in range(tri.shape[0]):
        t = tri[k]
        if not ok[t]:
            continue
        x = np.float64(pixel[k, 0])
        i = np.float32(my2[t] - pixel[k, 1])
        u = np.float32((x * np.float64(uxd[t]) + np.float64(uy0[t]))
                       - np.float64(i * uyd[t]))
        w = np.float32((x * np.float64(vxd[t]) + np.float64(vy0[t]))
                       - np.float64(i * vyd[t]))
        rest = (one - u) - w
        if u >= 0 and w >= 0 and rest >= 0:
            b0, b1, b2 = np.float64(u), np.float64(w), np.float64(rest)
            total = (b0 + b1) + b2
            out[k, 0] = b0 / total
            out[k, 1] = b1 / total
            out[k, 2] = b2 / total
