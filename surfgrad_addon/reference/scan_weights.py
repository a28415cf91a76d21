"""The barycentric weights Blender's bake gives Cycles for a texel, in its own float32
arithmetic (render/intern/zbuf.cc, zspan_scanconvert, as RE_bake_pixels_populate calls it).

The scan converter evaluates each weight as a plane equation whose constant is rounded to
float32 at the size of (texel coordinate / the triangle's height in texels): on a sliver, a
bevel strip unwrapped 0.08 texel thin and 13 texels long, the weights are off by ~3e-5, which
moves the shaded point ~0.2 mm along a 2 m strip. Methods that read the position (triplanar,
noise, decals) turn that into degrees where the texture is fine (a correct SG Triplanar on
a 20 m truck was called 7 degrees wrong). Exact weights, as the raster computes them, are
right everywhere else to float32's last bit, so these replace them; where Blender's weights
fall outside the triangle (Cycles then moves the sample: bake_jitter_barycentric) the exact,
clamped ones stay (those texels lie on an edge, left out of the comparison anyway).

Equations only: the weight of corner k is affine in the texel (x, y); the float32 steps are
those of the scan (each product, sum and quotient rounded to float32 where Blender's
variables are float, in float64 where it converts to double).
"""

import numpy as np

from . import compiled, raster_kernels

F32 = np.float32
F64 = np.float64


def _plane(x0, y0, z0, v1x, v1y, my2, plus_one):
    """(xd, yd, y0 term) of one weight's plane: Blender's uxd, uyd, uy0 (or v's)."""
    xx1 = F32(x0 * v1x) + F32(y0 * v1y)
    xx1 = (xx1 / z0).astype(F32)
    if plus_one:
        xx1 = xx1 + F32(1.0)
    xd = (-x0.astype(F64) / z0.astype(F64)).astype(F32)
    yd = (-y0.astype(F64) / z0.astype(F64)).astype(F32)
    row0 = (my2.astype(F64) * yd.astype(F64) + xx1.astype(F64)).astype(F32)
    return xd, yd, row0


def triangle_planes(uv, width, height, uv_offset, sample_offset):
    """Per triangle of uv (T, 3, 2), Blender's float32 plane terms of the weights of corners
    0 and 1: (uxd, uyd, uy0, vxd, vyd, vy0) float32 (T,) each, my2 (T,) its top row, and ok
    (T,) False where Blender's z0 is 0 (it scans nothing there). Computed once per bake."""
    # vec[a] = (uv - tile corner) * size - (0.5 + nudge), each step in float32
    size = np.array([width, height], dtype=F32)
    off = np.asarray(uv_offset, dtype=F64).astype(F32)
    nudge = np.asarray(sample_offset, dtype=F64).astype(F32)
    v = (((np.asarray(uv).astype(F32) - off) * size) - nudge).astype(F32)     # (T, 3, 2)
    v1x, v1y = v[:, 0, 0], v[:, 0, 1]
    x1 = v[:, 0, 0] - v[:, 1, 0]
    x2 = v[:, 1, 0] - v[:, 2, 0]
    y1 = v[:, 0, 1] - v[:, 1, 1]
    y2 = v[:, 1, 1] - v[:, 2, 1]
    z0 = F32(x1 * y2) - F32(y1 * x2)
    ok = z0 != 0
    z0 = np.where(ok, z0, F32(1.0))
    with np.errstate(invalid="ignore", over="ignore"):
        my2 = np.minimum(np.floor(v[:, :, 1].max(axis=1)), height - 1)
        my2 = np.nan_to_num(my2, nan=0.0, posinf=height - 1, neginf=0.0).astype(np.int64)
        # u (corner 0): z1 = 1, z2 = 0; v (corner 1): z1 = -1, z2 = 1.
        u = _plane(-y2, x2, z0, v1x, v1y, my2, True)
        w = _plane(F32(y1 + y2), F32(-x2 - x1), z0, v1x, v1y, my2, False)
    return (*u, *w, my2, ok)


def weights_from_planes(planes, tri, pixel, exact):
    """(N, 3) weights of texels pixel (N, 2) in triangles tri (N,) from triangle_planes;
    `exact` (N, 3) where Blender's fall outside the triangle."""
    out = np.array(exact, dtype=F64, copy=True)
    if len(tri) == 0:
        return out
    if compiled.enabled():
        raster_kernels.scan_weights_in(np.ascontiguousarray(tri, dtype=np.int64),
                                       np.ascontiguousarray(pixel, dtype=np.int64),
                                       *planes, out)
        return out
    t = np.asarray(tri, dtype=np.int64)
    uxd, uyd, uy0, vxd, vyd, vy0, my2, ok = (a[t] for a in planes)
    x = pixel[:, 0].astype(F64)
    i = (my2 - pixel[:, 1]).astype(F32)

    def weight(xd, yd, row0):
        # Blender steps from the span's first texel; x * xd in float64 differs from that
        # by float32's last bit of the weight only.
        return ((x * xd.astype(F64) + row0.astype(F64)) - (i * yd).astype(F64)).astype(F32)

    with np.errstate(invalid="ignore", over="ignore"):
        u = weight(uxd, uyd, uy0)
        w = weight(vxd, vyd, vy0)
        rest = F32(F32(1.0) - u) - w
    scan = np.stack([u, w, rest], axis=1).astype(F64)
    use = ok & (scan >= 0).all(axis=1)
    # Summed to 1 in float64, as the exact ones: float32's u + v + (1 - u - v) is 1 only to
    # ~6e-8, which Cycles applies to object-space corners, the reference to world-space ones
    # (10 km out: 0.6 mm, degrees of a triplanar texture).
    scan = scan[use]
    out[use] = scan / ((scan[:, 0] + scan[:, 1]) + scan[:, 2])[:, None]
    return out


def blender_weights(uv, tri, pixel, width, height, uv_offset, sample_offset, exact):
    """(N, 3) weights of corners 0, 1, 2 of triangle tri[i] at texel pixel[i] as Blender's
    bake computes them; `exact` (N, 3), the exact clamped weights, where those fall outside
    the triangle. uv: (T, 3, 2) the UV map per loop triangle; sample_offset: the bake's
    nudge of each texel's sample ((0.501, 0.502) on every line)."""
    planes = triangle_planes(uv, width, height, uv_offset, sample_offset)
    return weights_from_planes(planes, tri, pixel, exact)
