"""Optional compiled loops for the reference's hottest steps (numba, when it is installed).

The numpy code beside each kernel stays the definition: every kernel computes the same
numbers in the same order of operations (no fast-math, no contraction), and
tests/test_compiled_kernels.py holds each one to its numpy twin bit for bit. Without numba, or
with SURFGRAD_REFERENCE_COMPILED=0, the reference runs its numpy code only; it never needs
numba to import or to give an answer.

Why compiled loops: a numpy expression is one pass over memory per operation; the
rasteriser's scan conversion, the corner-attribute gathers and the image lookups are
gathers and scatters whose temporaries cost more than their arithmetic (README,
Performance). A kernel does each in one pass; kernels are serial and release the GIL, and
the blocks they run on spread over the cores (methods.evaluated_blocks), as Cycles' bake
spreads its own.

Kernels are compiled once per machine and cached on disk (numba's cache=True, next to this
package or in the user's cache directory), so a fresh process loads them in milliseconds.
"""

import os

import numpy as np

ENV = "SURFGRAD_REFERENCE_COMPILED"

try:
    import numba
except ImportError:             # the reference's numpy code runs instead
    numba = None

AVAILABLE = numba is not None


# More warm-up hooks (callables) of kernel modules: raster.load_compiled runs them.
LOADERS = []


def enabled():
    """True when kernels run: numba imported and SURFGRAD_REFERENCE_COMPILED is not 0
    (read at each call, so a test can compare both paths in one process)."""
    return AVAILABLE and os.environ.get(ENV, "1").strip() != "0"


def kernel(inline=False):
    """Decorator: numba.njit with the numpy error model (0/0 gives NaN as numpy does, not an
    exception) and the disk cache; without numba the plain function, never called. inline:
    a small helper compiled into each caller (numba's inline="always")."""
    def wrap(fn):
        if numba is None:
            return fn
        return numba.njit(cache=True, nogil=True, error_model="numpy",
                          inline="always" if inline else "never")(fn)
    return wrap



# Scalar twins of numpy's NaN-propagating minimum and maximum, for the kernels.

@kernel()
def nan_minimum(a, b):
    """np.minimum of two scalars: NaN if either is NaN."""
    if a != a or b != b:
        return np.nan
    return a if a <= b else b


@kernel()
def nan_maximum(a, b):
    """np.maximum of two scalars: NaN if either is NaN."""
    if a != a or b != b:
        return np.nan
    return a if a >= b else b
