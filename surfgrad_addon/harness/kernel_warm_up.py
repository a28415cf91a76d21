"""compare's compiled kernels, loaded before its timed passes (harness/compare.py).

numba loads a kernel from its disk cache at the kernel's first call, and its typing tables
at the first of all; `raster.load_compiled` loads every method's kernels, where a comparison
runs a dozen. Comparing a small rasterisation of two of the mesh's own triangles against a
blank bake calls exactly the kernels, with the argument types, of the real pass: the real
rasterisation and comparison then load nothing (tests/test_compare_process.py), and the
seconds compare reports for them are the work alone.
"""

import dataclasses
import time

import numpy as np

from .. import reference as R
from .texel_report import compare_tile

# The warm-up's image size (load_kernels): texels enough to reach every kernel, and cheap.
WARM_UP = 32
# Two triangles covering the UV square: the warm-up's UVs on every map.
_UV_SQUARE = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                       [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])


def warm_up_mesh(mesh):
    """The mesh's first two triangles (one for a one-triangle mesh), every UV map laid over
    the UV square: the arrays and types of the real mesh, at a size that costs nothing
    whatever the mesh's (a million triangles took 0.95 s to rasterise and prepare at 32^2)."""
    k = min(len(mesh.triangles), 2)
    first = {name: np.asarray(a)[:k] for name, a in (
        ("triangles", mesh.triangles), ("corner_normals", mesh.corner_normals))}
    return dataclasses.replace(
        mesh, **first,
        uv_maps={n: _UV_SQUARE[:k].astype(np.asarray(uv).dtype) for n, uv in mesh.uv_maps.items()},
        tangents={n: np.asarray(t)[:k] for n, t in mesh.tangents.items()},
        tangent_signs={n: np.asarray(t)[:k] for n, t in mesh.tangent_signs.items()},
        triangle_faces=None if mesh.triangle_faces is None else mesh.triangle_faces[:k])


def load_kernels(mesh, uv_map, reference, facts):
    """Load the compiled kernels this comparison runs, before its timed passes; the seconds
    it took (0 with kernels off). numba loads a kernel at its first call: comparing a
    WARM_UP^2 rasterisation of the mesh's warm_up_mesh with a blank bake calls the kernels,
    and argument types, of the real pass, where raster.load_compiled loads every method's
    (the normal map runs 12 of them, not 25). The values are thrown away: nothing the
    warm-up meets (a degenerate triangle's NaN, an error) is the comparison's, which meets
    the same in the real pass if it is there."""
    if not R.compiled.enabled():
        return 0.0
    t0 = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            td = R.rasterize(warm_up_mesh(mesh), uv_map, WARM_UP, WARM_UP, facts=facts,
                             as_baked=True)
            blank = np.zeros((WARM_UP, WARM_UP, 4), dtype=np.float32)
            compare_tile(td, reference, blank, td.covered.copy())
    except Exception:       # noqa: BLE001 - a warm-up only: the real pass reports it
        pass
    return time.perf_counter() - t0
