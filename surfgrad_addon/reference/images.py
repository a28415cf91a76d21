"""The project's own procedural test images, each with a closed form for its ground truth.

Images are (height, width[, C]) with row 0 at v = 0 (Blender's pixel order). Normal maps are
returned as colours in [0, 1] (m = 2 c - 1), as an artist's file would hold them.
"""

import numpy as np

from .image_sampling import texel_centres


def hemisphere_tile_normal(st, tiles=4, radius=0.85):
    """Tangent-space normal of a tile of hemispheres (the paper's Figure 5 map), in [-1, 1]^3:
    in each of tiles x tiles cells a hemisphere of `radius` (in half-cell units) bulges out;
    flat (0, 0, 1) between them."""
    st = np.asarray(st, dtype=np.float64)
    local = (np.mod(st * tiles, 1.0) - 0.5) * 2.0           # [-1, 1) per cell
    rho2 = np.sum(local * local, axis=-1)
    inside = rho2 < radius * radius
    z = np.sqrt(np.maximum(radius * radius - rho2, 0.0))
    m = np.concatenate([local, z[..., None]], axis=-1) / radius
    return np.where(inside[..., None], m, [0.0, 0.0, 1.0])


def hemisphere_tile_image(size=256, tiles=4, radius=0.85):
    """hemisphere_tile_normal at the texel centres, encoded as colour (size, size, 3)."""
    return 0.5 * hemisphere_tile_normal(texel_centres(size, size), tiles, radius) + 0.5


def wave_height(st, freq=(3.0, 2.0)):
    """A smooth periodic height in [0, 1] with its exact derivative d/d(s, t):
    with a = 2 pi f_s s and b = 2 pi f_t t, H = 0.5 + 0.25 sin(a) + 0.25 cos(b) sin(a + b).
    Integer frequencies keep it periodic on the unit square (it tiles with REPEAT)."""
    st = np.asarray(st, dtype=np.float64)
    a = 2 * np.pi * freq[0] * st[..., 0]
    b = 2 * np.pi * freq[1] * st[..., 1]
    h = 0.5 + 0.25 * np.sin(a) + 0.25 * np.cos(b) * np.sin(a + b)
    dh_da = 0.25 * np.cos(a) + 0.25 * np.cos(b) * np.cos(a + b)
    dh_db = -0.25 * np.sin(b) * np.sin(a + b) + 0.25 * np.cos(b) * np.cos(a + b)
    deriv = np.stack([dh_da * 2 * np.pi * freq[0], dh_db * 2 * np.pi * freq[1]], axis=-1)
    return h, deriv


def wave_height_image(size=256, freq=(3.0, 2.0)):
    """wave_height at the texel centres: (size, size)."""
    return wave_height(texel_centres(size, size), freq)[0]


def hemisphere_tile_height_image(size=256, tiles=4, radius=0.85):
    """The height field whose normal is hemisphere_tile_normal: sqrt(r^2 - rho^2) / r in each
    cell (1 at a dome's top, 0 between domes), at the texel centres."""
    st = texel_centres(size, size)
    local = (np.mod(st * tiles, 1.0) - 0.5) * 2.0
    rho2 = np.sum(local * local, axis=-1)
    return np.sqrt(np.maximum(radius * radius - rho2, 0.0)) / radius
