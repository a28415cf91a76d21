"""Compiled twin of Listing 16's plain branch (Listing 7's three taps) on Linear lookups
(see compiled.py): height_map.deriv_from_height_map without hq, texel by texel, the same
lookups (sampling_kernels.linear_at) and differences, so the same numbers
(tests/test_compiled_kernels.py). height_map.py stays the definition.
"""

import numpy as np

from . import compiled
from .compiled import kernel
from .sampling_kernels import linear_at, wrap_mode


@kernel()
def three_tap_derivative(texels, width, height, mode_x, mode_y, st, step_u, step_v, eoffs,
                         out):
    """out[:, i] = ((H(st + (step_u, 0)) - H(st)) / eoffs, (H(st + (0, step_v)) - H(st)) /
    eoffs) with H the bilinear lookup of channel 0."""
    for i in range(st.shape[0]):
        s, t = st[i, 0], st[i, 1]
        h_c = linear_at(texels, width, height, s, t, mode_x, mode_y, 0)
        h_r = linear_at(texels, width, height, s + step_u, t + 0.0, mode_x, mode_y, 0)
        h_u = linear_at(texels, width, height, s + 0.0, t + step_v, mode_x, mode_y, 0)
        out[0, i] = (h_r - h_c) / eoffs
        out[1, i] = (h_u - h_c) / eoffs


def derivative(height, st, lod, extension):
    """deriv_from_height_map(height, st, hq=False, lod, 'Linear', extension) for a float64
    (H, W) image and (N, 2) float64 st: (N, 2), each component contiguous."""
    h, w = height.shape
    eoffs = 2.0 ** lod
    out = np.empty((2, len(st)))
    three_tap_derivative(np.ascontiguousarray(height).reshape(h * w, 1), w, h,
                         wrap_mode(w, extension), wrap_mode(h, extension),
                         np.ascontiguousarray(st), eoffs / w, eoffs / h, eoffs, out)
    return out.T


def _load():
    """Load the kernel for the types the reference uses (raster.load_compiled)."""
    derivative(np.zeros((2, 2)), np.zeros((1, 2)), 0.0, "REPEAT")


compiled.LOADERS.append(_load)
