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
package or in the user's cache directory), so a fresh process loads them in milliseconds. A
cache that cannot be written (a full disk, a file-size limit, a read-only checkout) costs only
that speed: one warning line, and the kernels run uncached with the same numbers
(_guard_cache).
"""

import os
import sys

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
        options = dict(nogil=True, error_model="numpy", inline="always" if inline else "never")
        try:
            dispatcher = numba.njit(cache=True, **options)(fn)
        except RuntimeError as error:       # numba found no folder it can write its cache in
            if "cannot cache" not in str(error):
                raise
            cache_unwritable(_in_tree_cache(), "no folder numba tried takes files")
            return numba.njit(**options)(fn)
        _guard_cache(dispatcher)
        return dispatcher
    return wrap


_CACHE_FAILED = []      # the folder whose write failed: warned once, no more writes tried


def _in_tree_cache():
    """Where numba keeps this package's kernels by default (its in-tree locator)."""
    return os.environ.get("NUMBA_CACHE_DIR") or os.path.join(os.path.dirname(__file__),
                                                             "__pycache__")


def cache_unwritable(folder, reason):
    """Warn once per process that kernels run uncached, naming the folder and the fix."""
    if _CACHE_FAILED:
        return
    _CACHE_FAILED.append(folder)
    print(f"surfgrad: warning: the reference's compiled kernels could not be cached in "
          f"{folder!r} ({reason}): each run compiles them again (a slower start, the same "
          f"numbers); free space there, make it writable, or set NUMBA_CACHE_DIR to a folder "
          f"that takes files", file=sys.stderr, flush=True)


def _guard_cache(dispatcher):
    """Make the dispatcher's disk cache fail soft: numba raises a failed cache write (ENOSPC,
    EFBIG under `ulimit -f`, EACCES) out of the call that compiled the kernel, often from deep
    in another kernel's type inference. The kernel is already compiled then, so the write's
    failure is only a warning; later writes are skipped, and an unreadable cache is a miss."""
    cache = getattr(dispatcher, "_cache", None)
    save, load = getattr(cache, "save_overload", None), getattr(cache, "load_overload", None)
    if save is None or load is None:
        return

    def save_overload(sig, data):
        if _CACHE_FAILED:
            return
        try:
            save(sig, data)
        except OSError as error:
            cache_unwritable(getattr(cache, "cache_path", _in_tree_cache()),
                             error.strerror or str(error))

    def load_overload(sig, target_context):
        try:
            return load(sig, target_context)
        except OSError:
            return None

    cache.save_overload, cache.load_overload = save_overload, load_overload



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
