"""Compiled image lookups: image_sampling.sample_image's Closest and Linear in one pass per
lookup over all channels (numba, through compiled.py).

image_sampling.py stays the definition: these loops do its arithmetic in its order and in the
image's float type, so they give its numbers bit for bit (tests/test_compiled_sampling.py).
A lookup reads its texels straight from the (H * W, C) image, where a texel's channels sit
side by side (one cache line), instead of the numpy path's channel rows.
"""

import numpy as np

from . import compiled
from .compiled import prange

# How an index is brought into [0, size): image_sampling.wrap_texel_index's three cases.
REPEAT_POW2 = 0     # i & (size - 1)
REPEAT_MOD = 1      # np.mod(i, size), non-negative
EXTEND = 2          # np.clip(i, 0, size - 1)

INT64_MIN = np.int64(-2**63)
INT64_MAX = np.int64(2**63 - 1)
_INT64_RANGE = 9.223372036854775808e18      # 2**63


def wrap_mode(size, extension):
    """The wrap case of image_sampling.wrap_texel_index for one axis."""
    if extension == "REPEAT":
        return REPEAT_POW2 if size & (size - 1) == 0 else REPEAT_MOD
    return EXTEND


@compiled.kernel()
def _int_part(x):
    """cycles_int_part of one value: trunc(x) - (x < 0) as int64."""
    if abs(x) < _INT64_RANGE:
        i = np.int64(x)
        return i - 1 if x < 0 else i
    # NaN, +-inf and |x| >= 2**63: numpy's astype(int64) gives INT64_MIN on x86 (the CPU's
    # "integer indefinite"), and subtracting (x < 0) wraps it to INT64_MAX for negatives.
    # Spelled out here because the compiled cast of these values is undefined.
    return INT64_MAX if x < 0 else INT64_MIN


@compiled.kernel()
def _next(i):
    """i + 1 with numpy's int64 wrap-around."""
    return INT64_MIN if i == INT64_MAX else i + 1


@compiled.kernel()
def _wrap(i, size, mode):
    """image_sampling.wrap_texel_index; every case lands in [0, size)."""
    if mode == REPEAT_POW2:
        return i & (size - 1)
    if mode == REPEAT_MOD:
        return i % size             # numba keeps Python's sign rule: non-negative
    return min(max(i, 0), size - 1)


@compiled.kernel()
def _closest(texels, width, height, wf, hf, s, t, mode_x, mode_y, out, k):
    """out[:, k] = texel (i(s[k] W), i(t[k] H)) of texels (H * W, C), wrapped."""
    ix = _wrap(_int_part(s[k] * wf), width, mode_x)
    iy = _wrap(_int_part(t[k] * hf), height, mode_y)
    j = iy * width + ix
    for c in range(texels.shape[1]):
        out[c, k] = texels[j, c]


@compiled.kernel()
def _linear(texels, width, height, wf, hf, s, t, mode_x, mode_y, out, k):
    """out[:, k] = bilinear lookup at (s[k] W - 0.5, t[k] H - 0.5), in image_sampling's order:
    ((c00 sx + c01 tx) (1 - ty)) + ((c10 sx + c11 tx) ty) with sx = 1 - tx."""
    ftype = texels.dtype.type
    u = s[k] * wf
    u -= ftype(0.5)
    v = t[k] * hf
    v -= ftype(0.5)
    i0 = _int_part(u)
    j0 = _int_part(v)
    tx = u - ftype(i0)
    ty = v - ftype(j0)
    x1 = _wrap(_next(i0), width, mode_x)
    y1 = _wrap(_next(j0), height, mode_y) * width
    x0 = _wrap(i0, width, mode_x)
    y0 = _wrap(j0, height, mode_y) * width
    sx = ftype(1) - tx
    sy = ftype(1) - ty
    for c in range(texels.shape[1]):
        row0 = texels[y0 + x0, c] * sx
        row0 += texels[y0 + x1, c] * tx
        row1 = texels[y1 + x0, c] * sx
        row1 += texels[y1 + x1, c] * tx
        out[c, k] = row0 * sy + row1 * ty


# One loop per rule, serial and parallel: a short call is done before threads would start
# (and on a busy machine a parallel loop waits for its slowest thread).

@compiled.kernel()
def closest_serial(texels, width, height, s, t, mode_x, mode_y, out):
    wf, hf = texels.dtype.type(width), texels.dtype.type(height)
    for k in range(s.shape[0]):
        _closest(texels, width, height, wf, hf, s, t, mode_x, mode_y, out, k)


@compiled.kernel(parallel=True)
def closest_parallel(texels, width, height, s, t, mode_x, mode_y, out):
    wf, hf = texels.dtype.type(width), texels.dtype.type(height)
    for k in prange(s.shape[0]):
        _closest(texels, width, height, wf, hf, s, t, mode_x, mode_y, out, k)


@compiled.kernel()
def linear_serial(texels, width, height, s, t, mode_x, mode_y, out):
    wf, hf = texels.dtype.type(width), texels.dtype.type(height)
    for k in range(s.shape[0]):
        _linear(texels, width, height, wf, hf, s, t, mode_x, mode_y, out, k)


@compiled.kernel(parallel=True)
def linear_parallel(texels, width, height, s, t, mode_x, mode_y, out):
    wf, hf = texels.dtype.type(width), texels.dtype.type(height)
    for k in prange(s.shape[0]):
        _linear(texels, width, height, wf, hf, s, t, mode_x, mode_y, out, k)


# From this many lookups the parallel loop runs (measured: /work/notes/issue13-sampling.md).
PARALLEL_MIN_LOOKUPS = 1024

KERNELS = {("Closest", False): closest_serial, ("Closest", True): closest_parallel,
           ("Linear", False): linear_serial, ("Linear", True): linear_parallel}


def sample(image, st, interpolation, extension):
    """image_sampling.sample_image for a float32/float64 image of shape (H, W) or (H, W, C)
    and st (..., 2) of the image's type, interpolation and extension already checked."""
    height, width = image.shape[:2]
    channels = image.shape[2] if image.ndim == 3 else 1
    texels = np.ascontiguousarray(image).reshape(height * width, channels)
    lead = st.shape[:-1]
    s = st[..., 0].reshape(-1)
    t = st[..., 1].reshape(-1)
    out = np.empty((channels, s.shape[0]), dtype=image.dtype)
    run = KERNELS[interpolation, s.shape[0] >= PARALLEL_MIN_LOOKUPS]
    run(texels, width, height, s, t, wrap_mode(width, extension), wrap_mode(height, extension), out)
    if image.ndim == 2:
        return out[0].reshape(lead)
    # Channels last as a view: each channel contiguous, as the numpy path returns them.
    return np.moveaxis(out.reshape((channels,) + lead), 0, -1)
