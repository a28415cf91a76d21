"""Red team 50b: `compare` and `bake-normal-map` on public meshes the project had not seen
(mikedh/trimesh's models: OBJ, PLY, STL and glTF files with odd UVs, degenerate faces, huge
and tiny sizes); each finding is built here by code.

1. Faces that are slivers in UV (a bevel strip unwrapped 13 texels long and 0.08 texel thin:
   the Cesium Milk Truck glTF's trim, 34 faces of it). Blender's bake hands Cycles each
   texel's barycentrics from its scan converter (zbuf.cc, zspan_scanconvert), whose plane
   constants are float32 at the size of (texel coordinate / the face's height in texels):
   on such a sliver the weights are off by ~3e-5, the shaded point ~0.2 mm along a 2 m
   strip. The reference took exact weights, and a method reading the position (triplanar,
   noise, decals) turned that offset into degrees. Before, at 64^2 on 5.2: a correct SG
   Triplanar on the truck scored p99 0.019 / max 0.60 deg, and p99 0.27 / max 7.2 deg with
   the truck scaled 4x (19.5 m, no far-out warning); SG Normal Map max 0.113. Now compare
   models Blender's float32 weights (reference/scan_weights.py, raster.rasterize(as_baked=
   True)): triplanar max 0.0024 (0.0086 at 4x), normal-map max 0.0006. Built here: 32 strips
   of a 20 m plane, each two triangles unwrapped as a sliver over one row of texel centres
   (32^2, SG Triplanar: before p99 0.94 / max 4.2 deg on 5.2, now 0.0096 / 0.027).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import compare  # noqa: E402
from surfgrad_addon.reference import scan_weights  # noqa: E402
from test_faults_unseen_meshes31 import _object, _within_bar, empty_file  # noqa: E402,F401

pytestmark = pytest.mark.tier("bake")

RES = 32


def _sliver_strips(length=20.0, width=0.006, rows=RES, thin=0.08):
    """A length x (rows * width) plane cut into `rows` strips along x, each two triangles
    whose first two corners lie across the strip at one end (as the truck's trim); strip j
    is unwrapped onto u 0.03..0.97 and a band `thin` texels high on row j's texel centres."""
    verts, faces, uvs = [], [], []
    for j in range(rows):
        y0, y1 = j * width, (j + 1) * width
        v0 = (j + 0.502 - thin / 2) / rows
        v1 = (j + 0.502 + thin / 2) / rows
        a, b, c, d = len(verts), len(verts) + 1, len(verts) + 2, len(verts) + 3
        verts += [(0.0, y0, 0.0), (length, y0, 0.0), (length, y1, 0.0), (0.0, y1, 0.0)]
        corner_uv = {a: (0.03, v0), b: (0.97, v0), c: (0.97, v1), d: (0.03, v1)}
        for face in ((b, c, a), (d, a, c)):
            faces.append(face)
            uvs += [corner_uv[k] for k in face]
    return verts, faces, uvs


def test_uv_slivers_compare_within_the_bar(empty_file):
    """Finding 1: within the bar on every line (before: p99 0.94 deg on 5.2). Pinned: the
    strips are slivers (texels inside, none on an edge), and Blender's float32 weights
    there stand 1e-6 or more from the exact ones (what the reference had used)."""
    verts, faces, uvs = _sliver_strips()
    obj = _object("Trim", verts, faces, uvs)
    obj.rotation_euler = (0.6, 0.4, 0.3)        # all three projections blend
    bpy.context.view_layer.update()
    report = compare.compare(obj, "triplanar", RES)
    assert report["excluded"]["edge"] == 0, report
    _within_bar(report, RES * 20)
    # The weights themselves, for the top strip's texels (its two triangles), where the
    # texel coordinate is largest against the sliver's height.
    j = RES - 1
    uv = np.array(uvs[6 * j:6 * j + 6], dtype=np.float32).astype(float).reshape(2, 3, 2)
    xs = np.arange(2, RES - 2)
    pixel = np.stack([xs, np.full(len(xs), j)], 1)
    centre = np.stack([xs + 0.501, np.full(len(xs), j + 0.502)], 1) / RES
    exact = [[_exact(uv[t], c) for t in (0, 1)] for c in centre]
    tri = np.array([0 if e[0].min() >= 0 else 1 for e in exact])
    exact = np.array([e[t] for e, t in zip(exact, tri)])
    scan = scan_weights.blender_weights(uv, tri, pixel, RES, RES, (0.0, 0.0),
                                        (0.501, 0.502), exact)
    assert (exact > 0).all()
    off = np.abs(scan - exact).max()
    assert 1e-6 < off < 1e-3, off


def _exact(tri, p):
    """Exact barycentric weights of point p in the UV triangle tri (3, 2)."""
    a, b, c = tri
    m = np.array([b - a, c - a]).T
    s, t = np.linalg.solve(m, p - a)
    return np.array([1.0 - s - t, s, t])
