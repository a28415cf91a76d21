"""Small vector helpers over arrays of shape (..., 3) and (..., 2).

Every function keeps the floating type of its array inputs: float32 in gives float32 out,
anything else (float64, integers, Python lists) gives float64. Scalar parameters never
widen the result.
"""

import numpy as np

# HLSL's FLT_EPSILON, used by Listings 5 and 10.
FLT_EPSILON = 1.192092896e-07
# The paper's tiny determinant guard in Listings 6, 11 and 12.
DET_EPSILON = 1.192093e-15
# A denominator floor that keeps 0/0 finite where the numerator is then 0 too (the node
# groups' max(x, DIVIDE_FLOOR); float32 nodes, so far above float32's denormals).
DIVIDE_FLOOR = 1e-30


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
    """Dot product over the last axis, keeping it (shape (..., 1)) so results broadcast."""
    return np.sum(a * b, axis=-1, keepdims=True)


def cross(a, b):
    """Cross product over the last axis (written out: np.cross is slow on small axes)."""
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape, dtype=np.result_type(a, b))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


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
