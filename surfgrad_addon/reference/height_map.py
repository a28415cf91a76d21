"""Derivatives of a height image on the fly: Listing 7 (three taps) and Listing 16.

Images follow image_sampling's conventions (row 0 at v = 0, Blender's Image Texture lookups).
Cycles has no MIP maps, so every sample is taken from level 0; `lod` only sets the step size
and the HQ fade of Listing 16, as CalculateLevelOfDetail() would.
"""

import numpy as np

from . import compiled, height_map_kernels
from .image_sampling import (exact_weights, height_image, image_values, sample_image,
                             wrap_texel_index)
from .vecmath import as_float, saturate, stack_last


def deriv_three_tap(height, st, dst_dx, dst_dy, interpolation="Linear", extension="REPEAT"):
    """Listing 7: screen-space (dH/dx, dH/dy) by forward differences along ddx(st), ddy(st).

    Feed the result to surfgrad_scale_dependent(..., is_deriv_screen_space=True).
    """
    st, dst_dx, dst_dy = as_float(st, dst_dx, dst_dy)
    height = height_image(height)
    h_ll = sample_image(height, st, interpolation, extension)
    h_lr = sample_image(height, st + dst_dx, interpolation, extension)
    h_ul = sample_image(height, st + dst_dy, interpolation, extension)
    return stack_last([h_lr - h_ll, h_ul - h_ll])


def _hq_derivative(height, st, extension):
    """Eq. 20 and 21: Sobel-style derivatives at the four surrounding texel centres, bilinearly
    interpolated (the 4x4 block that Listing 16 gathers), in pixel units."""
    h, w = height.shape[:2]
    f = st * np.asarray([w, h], dtype=st.dtype) - 0.5
    fl = np.floor(f)
    t = saturate(f - fl)
    ax, ay = 1 - t[..., 0], t[..., 0]
    bx, by = 1 - t[..., 1], t[..., 1]
    # Row weights (v direction) and column weights (u direction), four each.
    smooth_u = [0.25 * ax, 0.25 * (2 * ax + ay), 0.25 * (ax + 2 * ay), 0.25 * ay]
    diff_u = [-0.5 * ax, -0.5 * ay, 0.5 * ax, 0.5 * ay]
    smooth_v = [0.25 * bx, 0.25 * (2 * bx + by), 0.25 * (bx + 2 * by), 0.25 * by]
    diff_v = [-0.5 * bx, -0.5 * by, 0.5 * bx, 0.5 * by]
    x0 = fl[..., 0].astype(np.int64) - 1
    y0 = fl[..., 1].astype(np.int64) - 1
    du = np.zeros(st.shape[:-1], dtype=st.dtype)
    dv = np.zeros(st.shape[:-1], dtype=st.dtype)
    flat = height.ravel()
    cols = [wrap_texel_index(x0 + j, w, extension) for j in range(4)]
    for i in range(4):  # rows of the 4x4 block (a fixed 16-tap loop, vectorised over pixels)
        rows = wrap_texel_index(y0 + i, h, extension) * w
        for j in range(4):
            q = np.take(flat, rows + cols[j])
            du += smooth_v[i] * diff_u[j] * q
            dv += diff_v[i] * smooth_u[j] * q
    return stack_last([du, dv])


_CONVERTED = {}


def _converted(image, dtype):
    """image.astype(dtype), the same array for the same image while images_unchanged() is
    active (blocks of one evaluation sample it again and again)."""
    from .image_sampling import _ROWS_ACTIVE
    if not _ROWS_ACTIVE[0]:
        _CONVERTED.clear()
        return image.astype(dtype)
    held = _CONVERTED.get((id(image), dtype))
    if held is None or held[0] is not image:
        if len(_CONVERTED) >= 8:
            _CONVERTED.pop(next(iter(_CONVERTED)))
        held = _CONVERTED[id(image), dtype] = (image, image.astype(dtype))
    return held[1]


def deriv_from_height_map(height, st, hq=False, lod=0.0, interpolation="Linear",
                          extension="REPEAT"):
    """Listing 16: (dH/du, dH/dv) in pixel units of level 0.

    The plain branch is Listing 7's three taps with a step of 2**lod texels (one texel at
    level 0). With hq, under magnification (lod below 0.5, fully from 0.05 down) the result
    fades to the bilinearly interpolated 4x4 Sobel derivative of Eq. 20/21.
    """
    height = image_values(height_image(height))
    (st,) = as_float(st)
    if height.dtype != st.dtype:
        height = _converted(height, st.dtype)
    h, w = height.shape
    mix = min(max((lod - 0.5) / (0.05 - 0.5), 0.0), 1.0)
    if compiled.enabled() and exact_weights() and height.dtype == st.dtype == np.float64 and \
            st.ndim == 2 and interpolation == "Linear" and extension in ("REPEAT", "EXTEND") and \
            not (hq and mix > 0.0):
        return height_map_kernels.derivative(height, st, lod, extension)
    eoffs = 2.0 ** lod
    offs_u = np.asarray([eoffs / w, 0.0], dtype=st.dtype)
    offs_v = np.asarray([0.0, eoffs / h], dtype=st.dtype)
    h_c = sample_image(height, st, interpolation, extension)
    h_r = sample_image(height, st + offs_u, interpolation, extension)
    h_u = sample_image(height, st + offs_v, interpolation, extension)
    deriv = stack_last([h_r - h_c, h_u - h_c]) / eoffs
    if hq and mix > 0.0:
        deriv = deriv + (_hq_derivative(height, st, extension) - deriv) * mix
    return deriv
