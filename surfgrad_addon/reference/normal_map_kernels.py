"""Compiled twins of the reference's tangent-space normal-map steps (see compiled.py):
Blender's Normal Map node frame at texels (methods.mikktspace_frame), a sampled colour to the
node's derivative (decode_normal_map, normal_map_strength, Eq. 15) and to Listing 2's
(tspace_normal_to_derivative). Each does the numpy code's arithmetic in its order, texel by
texel, so the arrays are identical (tests/test_compiled_kernels.py); the numpy code stays the
definition and runs whenever numba does not.
"""

import numpy as np

from . import compiled
from .compiled import kernel
from .compiled import nan_maximum as _maximum
from .vecmath import NODE_Z_FLOOR, TSPACE_Z_CLAMP

TINY = np.finfo(np.float64).tiny
FLT_EPSILON = 1.192092896e-07          # vecmath.FLT_EPSILON (Listings 5 and 10)


@kernel()
def _interp(corners, t, channels, c, b0, b1, b2):
    return (corners[t, c] * b0 + corners[t, channels + c] * b1) \
        + corners[t, 2 * channels + c] * b2


@kernel()
def mikktspace_frame(tangents, signs, normals, unit_normal, tri, bary, nm, identity,
                     out_n, out_t, out_b):
    """methods.mikktspace_frame per texel: tangent, sign and normal interpolated in object
    space (the normal normalised when unit_normal), b = sign * cross(n, t), all three by the
    normal matrix nm (v @ nm; skipped when identity) and scaled by 1 / |n| (Listing 9)."""
    for i in range(tri.shape[0]):
        t = tri[i]
        b0, b1, b2 = bary[i, 0], bary[i, 1], bary[i, 2]
        tx = _interp(tangents, t, 3, 0, b0, b1, b2)
        ty = _interp(tangents, t, 3, 1, b0, b1, b2)
        tz = _interp(tangents, t, 3, 2, b0, b1, b2)
        sign = _interp(signs, t, 1, 0, b0, b1, b2)
        nx = _interp(normals, t, 3, 0, b0, b1, b2)
        ny = _interp(normals, t, 3, 1, b0, b1, b2)
        nz = _interp(normals, t, 3, 2, b0, b1, b2)
        if unit_normal:
            length = np.sqrt((nx * nx + ny * ny) + nz * nz)
            nx, ny, nz = nx / length, ny / length, nz / length
        bx = sign * (ny * tz - nz * ty)
        by = sign * (nz * tx - nx * tz)
        bz = sign * (nx * ty - ny * tx)
        if not identity:
            nx, ny, nz = ((nx * nm[0, 0] + ny * nm[1, 0]) + nz * nm[2, 0],
                          (nx * nm[0, 1] + ny * nm[1, 1]) + nz * nm[2, 1],
                          (nx * nm[0, 2] + ny * nm[1, 2]) + nz * nm[2, 2])
            tx, ty, tz = ((tx * nm[0, 0] + ty * nm[1, 0]) + tz * nm[2, 0],
                          (tx * nm[0, 1] + ty * nm[1, 1]) + tz * nm[2, 1],
                          (tx * nm[0, 2] + ty * nm[1, 2]) + tz * nm[2, 2])
            bx, by, bz = ((bx * nm[0, 0] + by * nm[1, 0]) + bz * nm[2, 0],
                          (bx * nm[0, 1] + by * nm[1, 1]) + bz * nm[2, 1],
                          (bx * nm[0, 2] + by * nm[1, 2]) + bz * nm[2, 2])
        renorm = 1.0 / np.sqrt((nx * nx + ny * ny) + nz * nz)
        out_n[0, i], out_n[1, i], out_n[2, i] = nx * renorm, ny * renorm, nz * renorm
        out_t[0, i], out_t[1, i], out_t[2, i] = tx * renorm, ty * renorm, tz * renorm
        out_b[0, i], out_b[1, i], out_b[2, i] = bx * renorm, by * renorm, bz * renorm


@kernel()
def normal_map_node_derivative(rgb, strength, k, flip, out):
    """Eq. 15 on the Normal Map node's colour (methods.normal_map_surfgrad): m = 2 rgb - 1,
    x and y times strength, z = max(1 + k (z' - 1), k z') with z' Listing 2's clamp (floored as
    in SG Normal Map's colour: NODE_Z_FLOOR) and k the saturated strength; out = -(x, y) / z,
    y negated for a DirectX map (flip)."""
    for i in range(rgb.shape[1]):
        mx = 2.0 * np.float64(rgb[0, i]) - 1.0
        my = 2.0 * np.float64(rgb[1, i]) - 1.0
        mz = 2.0 * np.float64(rgb[2, i]) - 1.0
        z = _maximum(abs(mz), _maximum(abs(mx), abs(my)) * TSPACE_Z_CLAMP + NODE_Z_FLOOR)
        mx *= strength
        my *= strength
        mz = _maximum(1.0 + k * (z - 1.0), k * z)
        out[0, i] = -mx / mz
        dy = -my / mz
        out[1, i] = dy * -1.0 if flip else dy


@kernel()
def colour_to_listing2_derivative(rgb, sign, out):
    """Listing 2 (listings.tspace_normal_to_derivative) on m = 2 rgb - 1: -(x, s y) / z' with
    z' = max(|z|, |x| / 128, |y| / 128, tiny); s = -1 flips the green channel."""
    scale = TSPACE_Z_CLAMP
    for i in range(rgb.shape[1]):
        mx = 2.0 * np.float64(rgb[0, i]) - 1.0
        my = 2.0 * np.float64(rgb[1, i]) - 1.0
        mz = 2.0 * np.float64(rgb[2, i]) - 1.0
        z = _maximum(abs(mz), scale * _maximum(abs(mx), abs(my)))
        z = _maximum(z, TINY)
        out[0, i] = -mx / z
        out[1, i] = -(sign * my) / z


@kernel()
def reach_normal(n_f, t, b, deriv, n, out):
    """normal_map_surfgrad's last steps per texel: v = normalize(n_f - (d.x t + d.y b))
    (Listing 3 on the node's frame), then the surface gradient that resolves to v against n:
    Listing 5, or n - v where v faces away from n (n.v < FLT_EPSILON). Rows (3, N)."""
    for i in range(n.shape[1]):
        d0, d1 = deriv[0, i], deriv[1, i]
        wx = n_f[0, i] - (d0 * t[0, i] + d1 * b[0, i])
        wy = n_f[1, i] - (d0 * t[1, i] + d1 * b[1, i])
        wz = n_f[2, i] - (d0 * t[2, i] + d1 * b[2, i])
        length = np.sqrt((wx * wx + wy * wy) + wz * wz)
        vx, vy, vz = wx / length, wy / length, wz / length
        nx, ny, nz = n[0, i], n[1, i], n[2, i]
        k = (nx * vx + ny * vy) + nz * vz
        if k < FLT_EPSILON:
            out[0, i], out[1, i], out[2, i] = nx - vx, ny - vy, nz - vz
        else:
            scale = _maximum(FLT_EPSILON, abs(k))
            out[0, i] = (k * nx - vx) / scale
            out[1, i] = (k * ny - vy) / scale
            out[2, i] = (k * nz - vz) / scale


def _load():
    """Load the kernels for the types the reference uses (raster.load_compiled)."""
    tables = np.zeros((1, 9)), np.ones((1, 3)), np.tile([0.0, 0.0, 1.0], 3)[None]
    tri, bary = np.zeros(1, dtype=np.int32), np.full((1, 3), 1.0 / 3.0)
    out = [np.empty((3, 1)) for _ in range(3)]
    for unit in (False, True):
        for identity in (False, True):
            mikktspace_frame(*tables, unit, tri, bary, np.eye(3), identity, *out)
    for dtype in (np.float64, np.float32):
        rows = np.full((3, 1), 0.5, dtype=dtype)
        for flip in (False, True):
            normal_map_node_derivative(rows, 1.0, 1.0, flip, np.empty((2, 1)))
        colour_to_listing2_derivative(rows, 1.0, np.empty((2, 1)))
    reach_normal(*(np.ones((3, 1)) for _ in range(3)), np.ones((2, 1)), np.ones((3, 1)),
                 np.empty((3, 1)))


compiled.LOADERS.append(_load)
