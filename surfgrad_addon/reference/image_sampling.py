"""Image lookups that give the same numbers as Blender's Image Texture node in Cycles.

Images are arrays of shape (height, width) or (height, width, channels) in Blender's pixel
order: row 0 is the BOTTOM row (v = 0), as in `Image.pixels`. A texel (i, j) covers
[i/width, (i+1)/width) x [j/height, (j+1)/height) and its centre sits at half-integers.

Interpolation (Cycles `kernel/device/*/image.h`), with Cycles' integer part
i(x) = (int)x - (x < 0), which is floor(x) except at negative integers, where it is x - 1:
- 'Closest': texel i(u * width), i(v * height).
- 'Linear':  bilinear between i(u * width - 0.5) and the next texel, weights
  x - i(x) (so a texel centre returns that texel exactly).
Both rules are pinned against Cycles bakes in tests/test_blender_pins.py.
Pixels are floats as Blender holds them; uint8 / uint16 arrays (a PNG as imageio or PIL load it)
are read as Blender reads the file, value / 255 and value / 65535.
Extension: 'REPEAT' wraps periodically; 'EXTEND' clamps to the edge texel.

Cycles on a GPU (CUDA, OptiX) leaves 'Linear' to the texture unit, whose bilinear weights carry
8 fractional bits (CUDA C++ Programming Guide, texture fetching: 9-bit fixed point). Inside
gpu_texture_filter() lookups weight texels as an H100's texture unit did, measured lookup by
lookup (tools/texture_unit_probe): each axis' weight rounded to the nearest 1/256, ties up, and
the far corner's product rounded the same way, the other three corners' weights following from
it. Every one of 1M lookups of random texels at random coordinates agreed to float32 rounding.
"""

from contextlib import contextmanager

import numpy as np

from . import compiled, sampling_kernels
from .blender_lines import MAIN_LINE

INTERPOLATIONS = ("Closest", "Linear")
EXTENSIONS = ("REPEAT", "EXTEND")


def cycles_int_part(x):
    """Cycles' frac() integer part: (int)x - (x < 0 ? 1 : 0). Equals floor(x) except at
    negative integers (-2.0 -> -3), where Closest then picks the texel to the left."""
    return np.trunc(x).astype(np.int64) - (x < 0)


def wrap_texel_index(i, size, extension):
    if extension == "REPEAT":
        if size & (size - 1) == 0:
            return i & (size - 1)       # np.mod for a power of two, in two's complement
        return np.mod(i, size)
    if extension == "EXTEND":
        return np.clip(i, 0, size - 1)
    raise ValueError(f"unsupported extension {extension!r}; use one of {EXTENSIONS}")


# An image file's 8- and 16-bit channels (PNG, TIFF: uint8 / uint16 as imageio or PIL load
# them), which Blender reads as value / 255 and value / 65535.
FILE_CHANNEL_MAX = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}


def image_values(image):
    """The values Blender's Image Texture reads from an image array: float32 kept, uint8 and
    uint16 (a file's 8- and 16-bit channels) scaled to 0..1, anything else as float64."""
    image = np.asarray(image)
    if image.dtype in (np.float32, np.float64):
        return image
    held = _VALUES.get(id(image))
    if held is not None and held[0] is image:
        return held[1]
    scale = FILE_CHANNEL_MAX.get(image.dtype)
    # (as values 0..255 a normal map decoded far off the unit sphere: 35 degrees typical)
    values = image / scale if scale is not None else image.astype(np.float64)
    if _ROWS_ACTIVE[0]:                     # blocks of one evaluation convert it once
        if len(_VALUES) >= 8:
            _VALUES.pop(next(iter(_VALUES)))
        _VALUES[id(image)] = (image, values)
    return values


# The GPU texture unit's weight grid (gpu_texture_filter).
GPU_FILTER_WEIGHT_BITS = 8
_WEIGHT_STEPS = [None]                      # 2**bits inside gpu_texture_filter(); None: exact


@contextmanager
def gpu_texture_filter(bits=GPU_FILTER_WEIGHT_BITS):
    """Within this block 'Linear' lookups weight texels as a GPU's texture unit does: each
    weight on a grid of 1 / 2**bits (against exact weights a GPU bake of a normal map is off by
    tenths of a degree: docs/performance.md, "On a GPU")."""
    previous = _WEIGHT_STEPS[0]
    _WEIGHT_STEPS[0] = float(2 ** bits)
    try:
        yield
    finally:
        _WEIGHT_STEPS[0] = previous


def exact_weights():
    """False inside gpu_texture_filter(): lookups must then go through sample_image (the
    compiled kernels' own lookups weight texels exactly)."""
    return _WEIGHT_STEPS[0] is None


def _on_weight_grid(t):
    """t on the texture unit's grid: the nearest step, a tie rounded up (np.round's ties to
    even disagreed with the H100 at 0.1-0.5% of lookups, every one a tie)."""
    steps = _WEIGHT_STEPS[0]
    return np.floor(t * steps + 0.5) / steps


def sample_image(image, st, interpolation="Linear", extension="REPEAT"):
    """Sample `image` at texture coordinates st (..., 2). Returns (...,) for a one-channel
    image, (..., C) otherwise, in the image's float type (float64 for other types; uint8 and
    uint16 pixels read as Blender reads them, image_values)."""
    image = image_values(image)
    if image.ndim not in (2, 3):
        raise ValueError(f"image must have shape (height, width) or (height, width, C), "
                         f"got {image.shape}")
    height, width = image.shape[:2]
    st = np.asarray(st, dtype=image.dtype)
    # The compiled loop (same numbers) whenever numba is there: faster from one lookup up
    # (a call costs ~4 us against numpy's ~25 us; tools/bench_sampling.py for large ones). A
    # single point (st of shape (2,)) stays on numpy: numpy 1.x computes 0-d float32 in float64.
    if (compiled.enabled() and _WEIGHT_STEPS[0] is None and st.ndim > 1 and st.shape[-1] == 2 and image.size
            and interpolation in INTERPOLATIONS and extension in EXTENSIONS):
        return sampling_kernels.sample(image, st, interpolation, extension)
    # Texels by flat index (y * width + x), channels as rows: each lookup gathers one
    # contiguous row per channel (np.take; fancy indexing of (N, 3) rows is several times
    # slower), and results come out in vecmath's component layout.
    rows = _channel_rows(image)
    u = st[..., 0] * width
    v = st[..., 1] * height
    if interpolation == "Closest":
        ix = wrap_texel_index(cycles_int_part(u), width, extension)
        iy = wrap_texel_index(cycles_int_part(v), height, extension)
        return _last_axis(np.take(rows, iy * width + ix, axis=-1), image)
    if interpolation != "Linear":
        raise ValueError(f"unsupported interpolation {interpolation!r}; "
                         f"use one of {INTERPOLATIONS}")
    # Cycles computes this in float32; in the image's type it is exact at the texel centres of
    # power-of-two images and within rounding elsewhere.
    u -= 0.5
    v -= 0.5
    x0 = cycles_int_part(u)
    y0 = cycles_int_part(v)
    tx = u - x0.astype(u.dtype)
    ty = v - y0.astype(v.dtype)
    x1 = wrap_texel_index(x0 + 1, width, extension)
    y1 = wrap_texel_index(y0 + 1, height, extension)
    x0 = wrap_texel_index(x0, width, extension)
    y0 = wrap_texel_index(y0, height, extension)
    y0 *= width
    y1 *= width
    if _WEIGHT_STEPS[0] is not None:
        return _last_axis(_texture_unit_bilinear(rows, x0, x1, y0, y1, tx, ty), image)
    sx = 1 - tx
    # ((1 - ty) ((1 - tx) c00 + tx c01) + ty ((1 - tx) c10 + tx c11)), in this order.
    row0 = np.take(rows, y0 + x0, axis=-1) * sx
    row0 += np.take(rows, y0 + x1, axis=-1) * tx
    row1 = np.take(rows, y1 + x0, axis=-1) * sx
    row1 += np.take(rows, y1 + x1, axis=-1) * tx
    row0 *= 1 - ty
    row1 *= ty
    row0 += row1
    return _last_axis(row0, image)


def _texture_unit_bilinear(rows, x0, x1, y0, y1, tx, ty):
    """A GPU texture unit's bilinear lookup (rows by flat texel index; y0, y1 already times
    the width). Its corner weights are not products of the rounded axis weights: w11 is
    rounded to the grid again, and w01 = tx - w11, w10 = ty - w11, w00 = 1 - tx - ty + w11
    (so each axis still sums to its weight). With exact products the H100's lookups of random
    texels differed by up to 3.7e-3 (p99 1.8e-3); with this, by float32 rounding."""
    tx, ty = _on_weight_grid(tx), _on_weight_grid(ty)
    w11 = _on_weight_grid(tx * ty)
    out = np.take(rows, y0 + x0, axis=-1) * (1.0 - tx - ty + w11)
    out += np.take(rows, y0 + x1, axis=-1) * (tx - w11)
    out += np.take(rows, y1 + x0, axis=-1) * (ty - w11)
    out += np.take(rows, y1 + x1, axis=-1) * w11
    return out


def sample_colour(image, st, interpolation="Linear", extension="REPEAT"):
    """The Image Texture's Color output at st: (..., C) for an RGB(A) image, and (g, g, g)
    for a grey one, (H, W), (H, W, 1) or grey and alpha (H, W, 2), as Blender loads a grey
    file. (A grey image's (N,) samples read as one colour of their first three texels gave
    every texel one normal; a grey and alpha one raised an IndexError.)"""
    image = np.asarray(image)
    values = sample_image(image, st, interpolation, extension)
    if image.ndim == 3 and image.shape[2] >= 3:
        return values
    grey = values if image.ndim == 2 else values[..., 0]
    return np.stack([grey, grey, grey], axis=-1)


def height_image(image):
    """A height image as (H, W), from (H, W) or (H, W, 1) (a value per texel, which Listings 7
    and 16 difference); ValueError for colour images, naming the fix. (Sampled as (N, 1), an
    (H, W, 1) one broadcast the forward variant's (N, 2) derivatives to (N, N, 3).)"""
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[..., 0]
    if image.ndim != 2:
        raise ValueError(f"height must be a one-channel image of shape (height, width), got "
                         f"{image.shape}: give one channel (e.g. pixels[..., 0] of an RGBA "
                         f"Image.pixels)")
    return image


_ROWS = {}      # id(image) -> (image, its channel rows), while images_unchanged() is active
_ROWS_ACTIVE = [0]
_VALUES = {}    # id(image) -> (image, image_values(image)), likewise


@contextmanager
def images_unchanged():
    """Within this block the caller promises not to modify sampled images in place: each
    image is laid out for sampling once and reused by every block (evaluate_in_blocks)."""
    _ROWS_ACTIVE[0] += 1
    try:
        yield
    finally:
        _ROWS_ACTIVE[0] -= 1
        if not _ROWS_ACTIVE[0]:
            _ROWS.clear()
            _VALUES.clear()


def _channel_rows(image):
    """(C, H * W) for an (H, W, C) image, (H * W,) for (H, W)."""
    held = _ROWS.get(id(image))
    if held is not None and held[0] is image:
        return held[1]
    h, w = image.shape[:2]
    rows = np.ascontiguousarray(np.moveaxis(image.reshape((h * w,) + image.shape[2:]), 0, -1))
    if _ROWS_ACTIVE[0]:
        if len(_ROWS) >= 16:               # converted copies each call: keep a few only
            _ROWS.pop(next(iter(_ROWS)))
        _ROWS[id(image)] = (image, rows)
    return rows


def _last_axis(values, image):
    """Channels from the first axis to the last (a view) for multi-channel images."""
    return np.moveaxis(values, 0, -1) if image.ndim == 3 else values


# Blender's bake rasteriser shades texel (i, j) at ((i + 0.5 + 0.001) / W, (j + 0.5 + 0.002) / H)
# (render/intern/bake.cc subtracts 0.5 + 0.001 and 0.5 + 0.002) on every line; pinned by a bake
# test (tests/test_blender_pins.py) that runs on each.
BAKE_TEXEL_OFFSET = MAIN_LINE.bake_texel_offset


def bake_sample_points(width, height, dtype=np.float64):
    """Where a width x height bake shades each texel, shape (height, width, 2)."""
    s = (np.arange(width, dtype=dtype) + BAKE_TEXEL_OFFSET[0]) / width
    t = (np.arange(height, dtype=dtype) + BAKE_TEXEL_OFFSET[1]) / height
    ss, tt = np.meshgrid(s, t)
    return np.stack([ss, tt], axis=-1)


def texel_centres(width, height, dtype=np.float64):
    """Texture coordinates of every texel centre, shape (height, width, 2), row 0 at v ~ 0."""
    s = (np.arange(width, dtype=dtype) + 0.5) / width
    t = (np.arange(height, dtype=dtype) + 0.5) / height
    ss, tt = np.meshgrid(s, t)
    return np.stack([ss, tt], axis=-1)
