"""Compiled twin of Listing 1, which every method's texels end in (see compiled.py):
listings.resolve_normal_from_surface_gradient texel by texel, identical values
(tests/test_compiled_kernels.py). listings.py stays the definition.
"""

import numpy as np

from . import compiled
from .compiled import kernel


@kernel()
def resolve_normal_from_surface_gradient(n, sg, out):
    """out = normalize(n - sg), or n where n - sg has no finite, non-zero length (Listing 1
    with vecmath.safe_normalize's fallback). n, sg: (3, N) rows."""
    for i in range(n.shape[1]):
        x = n[0, i] - sg[0, i]
        y = n[1, i] - sg[1, i]
        z = n[2, i] - sg[2, i]
        length = np.sqrt((x * x + y * y) + z * z)
        if np.isfinite(length) and length > 0:
            out[0, i], out[1, i], out[2, i] = x / length, y / length, z / length
        else:
            out[0, i], out[1, i], out[2, i] = n[0, i], n[1, i], n[2, i]


def resolve(n, sg):
    """Listing 1 on (N, 3) float64 arrays: the result (N, 3), each component contiguous."""
    out = np.empty((3, len(n)))
    resolve_normal_from_surface_gradient(np.ascontiguousarray(n.T), np.ascontiguousarray(sg.T),
                                         out)
    return out.T


def _load():
    """Load the kernel for the types the reference uses (raster.load_compiled)."""
    resolve(np.zeros((1, 3)), np.zeros((1, 3)))


compiled.LOADERS.append(_load)
