"""Small vector helpers over arrays of shape (..., 3) and (..., 2).

Every function keeps the floating type of its array inputs: float32 in gives float32 out,
anything else (float64, integers, Python lists) gives float64. Scalar parameters never
widen the result.

Layout: per-texel vectors are (N, 3) arrays stored component by component (Fortran order,
each component contiguous), as `stack_last` and TexelData make them. numpy then runs an
(N, 1) * (N, 3) product over N at a time instead of 3 at a time (3-5x faster); values are the
same in any layout.
"""

import numpy as np

# HLSL's FLT_EPSILON, used by Listings 5 and 10.
FLT_EPSILON = 1.192092896e-07
# The paper's tiny determinant guard in Listings 6, 11 and 12.
DET_EPSILON = 1.192093e-15
# A denominator floor that keeps 0/0 finite where the numerator is then 0 too (the node
# groups' max(x, DIVIDE_FLOOR); float32 nodes, so far above float32's denormals).
DIVIDE_FLOOR = 1e-30
# Listing 2's clamp: z = max(|z|, max(|x|, |y|) / 128) bounds a tangent-space normal's
# derivative to [-128, 128] (89.55 degrees).
TSPACE_Z_CLAMP = 1.0 / 128.0
# SG Normal Map's floor under Listing 2's clamp, z >= max(|x|, |y|) / 128 + 2^-22: its colour's
# blue stays above 0.5 (0.5 + 2^-23 in float32), so the Normal Map node never decodes a zero
# vector, which 4.2 and 4.5 turn into no normal at all (a mid-grey texel then dropped every
# layer added to it). 2^-22 moves only texels the clamp decides, by under 0.004 degrees.
NODE_Z_FLOOR = 2.0 ** -22


def float_type(*arrays):
    """The dtype the listings compute in: float32 only when every array input is float32."""
    kinds = [np.asarray(a).dtype for a in arrays]
    if kinds and all(k == np.float32 for k in kinds):
        return np.dtype(np.float32)
    return np.dtype(np.float64)


def as_float(*arrays):
    """Convert the inputs to one shared floating dtype (see float_type)."""
    dtype = float_type(*arrays)
    return tuple(np.asarray(a, dtype=dtype) for a in arrays)


def dot(a, b):
    """Dot product over the last axis, keeping it (shape (..., 1)) so results broadcast.
    Three components are summed in order, written out (a reduction over a short axis is
    several times slower, and sums in the same order)."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape[-1:] == b.shape[-1:] == (3,):
        out = a[..., 0:1] * b[..., 0:1]
        out += a[..., 1:2] * b[..., 1:2]
        out += a[..., 2:3] * b[..., 2:3]
        return out
    return np.sum(a * b, axis=-1, keepdims=True)


def dot3(a, b):
    """dot() without the kept axis: shape (...,)."""
    return dot(a, b)[..., 0]


def stack_last(arrays):
    """np.stack(arrays, axis=-1), each input a contiguous component of the result."""
    return np.moveaxis(np.stack(arrays), 0, -1)


_IDENTITY3 = np.eye(3)


def transform(v, m):
    """v @ m for vectors v (..., 3) and a 3 x 3 matrix m, component by component (keeps the
    layout; sums in order 0, 1, 2)."""
    m = np.asarray(m)
    if m.shape == (3, 3) and np.array_equal(m, _IDENTITY3):
        return np.array(v, order="K")    # x 1 + y 0 + z 0 is x (up to the sign of a zero)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return stack_last([x * m[0, j] + y * m[1, j] + z * m[2, j] for j in range(3)])


def cross(a, b):
    """Cross product over the last axis (written out: np.cross is slow on small axes)."""
    a, b = np.broadcast_arrays(a, b)
    return stack_last([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                       a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                       a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]])


def length(v):
    return np.sqrt(dot(v, v))


def normalize(v):
    """HLSL normalize(): v/|v|. A zero vector gives NaN, exactly as on a GPU."""
    return v / length(v)


def safe_normalize(v, fallback):
    """normalize(v), but fallback where |v| is zero or not finite (keeps outputs unit)."""
    n = length(v)
    good = np.isfinite(n) & (n > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = v / np.where(good, n, 1)
    return np.where(good, unit, fallback)


def sign_nonneg(x):
    """The listings' `x < 0 ? -1 : 1`: zero counts as positive."""
    return np.where(x < 0, -1, 1).astype(np.asarray(x).dtype)


def saturate(x):
    return np.clip(x, 0, 1)


def lerp(a, b, t):
    return a + (b - a) * t
