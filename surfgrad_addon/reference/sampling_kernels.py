"""Compiled image lookups: image_sampling.sample_image's Closest and Linear in one pass per
lookup over all channels (numba, through compiled.py).

image_sampling.py stays the definition: these loops do its arithmetic in its order and in the
image's float type, so they give its numbers bit for bit (tests/test_compiled_sampling.py).
A lookup reads its texels straight from the (H * W, C) image, where a texel's channels sit
side by side (one cache line), instead of the numpy path's channel rows.
"""

import numpy as np

from . import compiled

# How an index is brought into [0, size): image_sampling.wrap_texel_index's three cases.
REPEAT_POW2 = 0     # i & (size - 1)
REPEAT_MOD = 1      # np.mod(i, size), non-negative
EXTEND = 2          # np.clip(i, 0, size - 1)

INT64_MIN = np.int64(-2**63)
INT64_MAX = np.int64(2**63 - 1)
INT64_RANGE = 9.223372036854775808e18       # 2**63


def wrap_mode(size, extension):
    """The wrap case of image_sampling.wrap_texel_index for one axis."""
    if extension == "REPEAT":
        return REPEAT_POW2 if size & (size - 1) == 0 else REPEAT_MOD
    return EXTEND


# Per axis, image_sampling's cycles_int_part and wrap_texel_index: i = trunc(x) - (x < 0);
# for NaN, +-inf and |x| >= 2**63 numpy's astype(int64) gives INT64_MIN on x86 (the CPU's
# "integer indefinite") and subtracting (x < 0) wraps that to INT64_MAX for negatives, so those
# are written out too (the compiled cast of them is undefined). Every wrap case lands in
# [0, size). Serial loops: blocks of texels already run on all cores
# (methods.evaluated_blocks), and a parallel loop called from those threads would
# oversubscribe the cores (or, under numba's workqueue threading layer, abort on concurrent
# use).

@compiled.kernel(inline=True)
def _int_part(x):
    """cycles_int_part of one value, with numpy's int64 results for the values it cannot cast."""
    if abs(x) < INT64_RANGE:
        i = np.int64(x)
        return i - 1 if x < 0 else i
    return INT64_MAX if x < 0 else INT64_MIN


@compiled.kernel(inline=True)
def _wrap(i, size, mode):
    """wrap_texel_index of one index: REPEAT on a power of two, REPEAT, EXTEND."""
    if mode == REPEAT_POW2:
        return i & (size - 1)
    if mode == REPEAT_MOD:
        return i % size             # numba keeps Python's sign rule: non-negative
    return min(max(i, 0), size - 1)


@compiled.kernel(inline=True)
def _linear_taps(width, height, s, t, mode_x, mode_y, ftype):
    """A Linear lookup's four texels (flat indices) and weights sx, tx, sy, ty at (s W - 0.5,
    t H - 0.5), in the image's float type, as image_sampling computes them."""
    u = s * ftype(width)
    u -= ftype(0.5)
    v = t * ftype(height)
    v -= ftype(0.5)
    x0 = _int_part(u)
    y0 = _int_part(v)
    tx = u - ftype(x0)
    ty = v - ftype(y0)
    x1 = _wrap(INT64_MIN if x0 == INT64_MAX else x0 + 1, width, mode_x)  # numpy's int64 wrap
    y1 = _wrap(INT64_MIN if y0 == INT64_MAX else y0 + 1, height, mode_y) * width
    x0 = _wrap(x0, width, mode_x)
    y0 = _wrap(y0, height, mode_y) * width
    return y0 + x0, y0 + x1, y1 + x0, y1 + x1, ftype(1) - tx, tx, ftype(1) - ty, ty


@compiled.kernel()
def sample_closest(texels, width, height, s, t, mode_x, mode_y, out):
    """out[c, k] = texel (i(s[k] W), i(t[k] H)) of texels (H * W, C), wrapped."""
    ftype = texels.dtype.type
    wf = ftype(width)
    hf = ftype(height)
    for k in range(s.shape[0]):
        j = _wrap(_int_part(t[k] * hf), height, mode_y) * width + \
            _wrap(_int_part(s[k] * wf), width, mode_x)
        for c in range(texels.shape[1]):
            out[c, k] = texels[j, c]


@compiled.kernel()
def sample_linear(texels, width, height, s, t, mode_x, mode_y, out):
    """out[c, k] = bilinear lookup at (s[k] W - 0.5, t[k] H - 0.5), in image_sampling's order:
    ((c00 sx + c01 tx) (1 - ty)) + ((c10 sx + c11 tx) ty) with sx = 1 - tx."""
    ftype = texels.dtype.type
    for k in range(s.shape[0]):
        j00, j01, j10, j11, sx, tx, sy, ty = _linear_taps(width, height, s[k], t[k], mode_x,
                                                          mode_y, ftype)
        for c in range(texels.shape[1]):
            row0 = texels[j00, c] * sx
            row0 += texels[j01, c] * tx
            row1 = texels[j10, c] * sx
            row1 += texels[j11, c] * tx
            out[c, k] = row0 * sy + row1 * ty


@compiled.kernel(inline=True)
def linear_at(texels, width, height, s, t, mode_x, mode_y, c):
    """One channel of one Linear lookup (sample_linear for a single point, for loops that
    sample as they go, such as the parallax march)."""
    j00, j01, j10, j11, sx, tx, sy, ty = _linear_taps(width, height, s, t, mode_x, mode_y,
                                                      texels.dtype.type)
    row0 = texels[j00, c] * sx
    row0 += texels[j01, c] * tx
    row1 = texels[j10, c] * sx
    row1 += texels[j11, c] * tx
    return row0 * sy + row1 * ty


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
    run = sample_closest if interpolation == "Closest" else sample_linear
    run(texels, width, height, s, t, wrap_mode(width, extension), wrap_mode(height, extension), out)
    if image.ndim == 2:
        return out[0].reshape(lead)
    # Channels last as a view: each channel contiguous, as the numpy path returns them.
    return np.moveaxis(out.reshape((channels,) + lead), 0, -1)


def _load():
    """Load the kernels for the types the reference uses (raster.load_compiled)."""
    for dtype in (np.float64, np.float32):
        for shape in ((2, 2), (2, 2, 3)):
            image = np.zeros(shape, dtype=dtype)
            for interpolation in ("Closest", "Linear"):
                for order in "CF":          # st's columns strided or contiguous
                    st = np.zeros((2, 2), dtype=dtype, order=order)
                    sample(image, st, interpolation, "REPEAT")


compiled.LOADERS.append(_load)
