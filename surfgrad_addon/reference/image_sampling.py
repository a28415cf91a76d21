"""Image lookups that give the same numbers as Blender's Image Texture node in Cycles.

Images are arrays of shape (height, width) or (height, width, channels) in Blender's pixel
order: row 0 is the BOTTOM row (v = 0), as in `Image.pixels`. A texel (i, j) covers
[i/width, (i+1)/width) x [j/height, (j+1)/height) and its centre sits at half-integers.

Interpolation (Cycles `kernel/device/*/image.h`):
- 'Closest': texel floor(u * width), floor(v * height).
- 'Linear':  bilinear between floor(u * width - 0.5) and the next texel, weights
  frac(u * width - 0.5) (so a texel centre returns that texel exactly).
Extension: 'REPEAT' wraps periodically; 'EXTEND' clamps to the edge texel.
"""

import numpy as np

INTERPOLATIONS = ("Closest", "Linear")
EXTENSIONS = ("REPEAT", "EXTEND")


def wrap_texel_index(i, size, extension):
    if extension == "REPEAT":
        return np.mod(i, size)
    if extension == "EXTEND":
        return np.clip(i, 0, size - 1)
    raise ValueError(f"unsupported extension {extension!r}; use one of {EXTENSIONS}")


def sample_image(image, st, interpolation="Linear", extension="REPEAT"):
    """Sample `image` at texture coordinates st (..., 2). Returns (...,) for a one-channel
    image, (..., C) otherwise, in the image's float type (float64 for integer images)."""
    image = np.asarray(image)
    if image.dtype != np.float32:
        image = image.astype(np.float64)
    if image.ndim not in (2, 3):
        raise ValueError(f"image must have shape (height, width) or (height, width, C), "
                         f"got {image.shape}")
    height, width = image.shape[:2]
    st = np.asarray(st, dtype=image.dtype)
    # Cycles computes this in float32; in the image's type it is exact at the texel centres of
    # power-of-two images and within rounding elsewhere.
    u = st[..., 0] * width
    v = st[..., 1] * height
    if interpolation == "Closest":
        ix = wrap_texel_index(np.floor(u).astype(np.int64), width, extension)
        iy = wrap_texel_index(np.floor(v).astype(np.int64), height, extension)
        return image[iy, ix]
    if interpolation != "Linear":
        raise ValueError(f"unsupported interpolation {interpolation!r}; "
                         f"use one of {INTERPOLATIONS}")
    u = u - 0.5
    v = v - 0.5
    fu = np.floor(u)
    fv = np.floor(v)
    tx = u - fu
    ty = v - fv
    x0 = fu.astype(np.int64)
    y0 = fv.astype(np.int64)
    x1 = wrap_texel_index(x0 + 1, width, extension)
    y1 = wrap_texel_index(y0 + 1, height, extension)
    x0 = wrap_texel_index(x0, width, extension)
    y0 = wrap_texel_index(y0, height, extension)
    if image.ndim == 3:
        tx = tx[..., None]
        ty = ty[..., None]
    return ((1 - ty) * ((1 - tx) * image[y0, x0] + tx * image[y0, x1])
            + ty * ((1 - tx) * image[y1, x0] + tx * image[y1, x1]))


def texel_centres(width, height, dtype=np.float64):
    """Texture coordinates of every texel centre, shape (height, width, 2), row 0 at v ~ 0."""
    s = (np.arange(width, dtype=dtype) + 0.5) / width
    t = (np.arange(height, dtype=dtype) + 0.5) / height
    ss, tt = np.meshgrid(s, t)
    return np.stack([ss, tt], axis=-1)
