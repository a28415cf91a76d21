"""Compiled twin of parallax.parallax_occlusion_march on an image's Linear lookups (see
compiled.py): the same steps, the same lookups (sampling_kernels.linear_at) and the same
refinement, texel by texel, so the offsets are identical (tests/test_compiled_kernels.py).
A texel stops marching once its ray is under the height field: later steps cannot change it.
"""

import numpy as np

from . import compiled
from .compiled import kernel
from .sampling_kernels import linear_at, wrap_mode


@kernel()
def march_linear(texels, width, height, mode_x, mode_y, st, v_tex, levels, out):
    """out[:, i] = parallax_occlusion_march's offset for texel i, sampling channel 0 of
    texels (H * W, C) bilinearly at st + level * v_tex."""
    for i in range(st.shape[0]):
        s0, s1 = st[i, 0], st[i, 1]
        v0, v1 = v_tex[i, 0], v_tex[i, 1]
        prev_level = 1.0
        prev_gap = prev_level - linear_at(texels, width, height, s0 + v0, s1 + v1,
                                          mode_x, mode_y, 0)
        found = prev_gap <= 0
        hit_level = prev_level if found else 0.0
        for j in range(1, levels.shape[0]):
            if found:
                break
            level = levels[j]
            h = linear_at(texels, width, height, s0 + level * v0, s1 + level * v1,
                          mode_x, mode_y, 0)
            gap = level - h
            if gap <= 0:
                # Linear refinement between the last two samples.
                t = prev_gap / (prev_gap - gap)
                hit_level = prev_level + (level - prev_level) * t
                found = True
            prev_level = level
            prev_gap = gap
        out[0, i] = hit_level * v0
        out[1, i] = hit_level * v1


def march(image, st, v_tex, steps):
    """parallax_occlusion_march(lambda q: sample_image(image, q, 'Linear', 'REPEAT'), st,
    v_tex, steps) for a float64 (H, W) image and (N, 2) float64 st, v_tex."""
    height, width = image.shape[:2]
    texels = np.ascontiguousarray(image).reshape(height * width, -1)
    levels = np.linspace(1.0, 0.0, steps + 1)
    out = np.empty((2, len(st)))
    march_linear(texels, width, height, wrap_mode(width, "REPEAT"), wrap_mode(height, "REPEAT"),
                 np.ascontiguousarray(st), np.ascontiguousarray(v_tex), levels, out)
    return out.T


def _load():
    """Load the kernel for the types the reference uses (raster.load_compiled)."""
    march(np.zeros((2, 2)), np.zeros((1, 2)), np.zeros((1, 2)), 2)


compiled.LOADERS.append(_load)
