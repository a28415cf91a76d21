"""Red team 48c: which flat-triangle normal MikkTSpace sees in Cycles, per line.

MikkTSpace welds two corners only where their position, normal and UV are bitwise equal, so
on a flat face UV'd irregularly (its triangles' own tangents differ) whether the two triangles
weld across the diagonal turns the tangents by up to ~30 degrees. Cycles hands MikkTSpace each
flat triangle's own normal, cross(v1 - v0, v2 - v0) scaled to unit length: 5.2 divides by the
length, up to 5.0 Cycles' float3 division multiplies by the reciprocal (one rounding more),
and the two differ from each other and from Blender's face normal in the last bit on many
triangles. Round 47c matched 5.2; up to 5.0 the reference's temporary mesh still took Blender's
face normal, and compare called a correct SG Normal Map wrong on the chopper's blade quad
mirrored at z = 0 (p99 26.8 / max 29.9 deg) and on the faces below (p99 37.9 / max 71.2 deg
on 5.0 and 4.5), exit 0. Now 5.0 and 4.5 take the reciprocal form
(mesh_data.cycles_triangle_normals, blender_lines.triangle_normal_divides): p99 0.0006 / max
0.0014. 4.2 has no float corner normals, so the temporary mesh's flat triangles keep Blender's
face normal there: still off, an expected failure (docs/pipelines.md, Known limits). There an
all-flat mesh now reaches weld_fans.fan_mesh (before, the float attribute "matched" only
because it held Blender's own face normals), which ended in a raw IndexError with no smooth
corner to join (weld_fans._bridges); the chopper quad in test_faults_imports47.py pins it.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import compare  # noqa: E402
from surfgrad_addon.harness.mesh_data import cycles_triangle_normals  # noqa: E402
from test_faults_unseen_meshes31 import _object, _within_bar  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _flat_polygons(seed=0, count=9):
    """Irregular convex flat quads, a 5-gon and a 6-gon, each in an axis plane at a random
    height, either winding, each UV'd to a square (a regular polygon) in its own UV cell."""
    rng = np.random.default_rng(seed)
    verts, faces, uvs = [], [], []
    for k in range(count):
        n = (4, 4, 4, 5, 6, 4, 4, 4, 4)[k]
        angle = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
        radius = rng.uniform(0.5, 1.0, n)
        flat = np.c_[np.cos(angle) * radius, np.sin(angle) * radius] * 0.3 + [k * 0.7, 0.0]
        points = np.insert(flat, k % 3, rng.uniform(-1.0, 1.0), axis=1)
        order = list(range(n)) if rng.random() < 0.5 else list(range(n))[::-1]
        faces.append([len(verts) + i for i in order])
        verts.extend(points.tolist())
        step = np.arange(n) * 2.0 * np.pi / n
        shape = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=np.float64) if n == 4 else \
            np.c_[np.cos(step), np.sin(step)] * 0.5 + 0.5
        uvs.extend((np.array([k % 3, k // 3]) / 3.0 + 0.02 + shape[order] * 0.29).tolist())
    return verts, faces, uvs


@pytest.mark.xfail(bpy.app.version < (4, 5, 0), strict=True,
                   reason="4.2: the temporary mesh's flat triangles carry Blender's face normal, "
                          "not Cycles' (no float normals; docs/pipelines.md, Known limits)")
def test_flat_polygons_weld_as_this_lines_cycles_does(fresh):
    """Compare within the bar on every face; the faces are ones where the lines' rules differ
    (so the test tells the rules apart): some triangle pair of one face has bitwise equal
    normals under one rule and not under the other."""
    verts, faces, uvs = _flat_polygons()
    obj = _object("Flat", verts, faces, uvs, smooth=False)
    obj.data.materials.append(bpy.data.materials.new("Flat"))
    tris = np.array([[obj.data.loops[c].vertex_index for c in t.loops]
                     for t in obj.data.loop_triangles])
    face = np.array([t.polygon_index for t in obj.data.loop_triangles])
    positions = np.array([v.co[:] for v in obj.data.vertices], dtype=np.float32)

    def groups(divides):
        bits = cycles_triangle_normals(positions, tris, divides=divides).view(np.uint32)
        return [len({b.tobytes() for b in bits[face == f]}) for f in range(len(faces))]

    assert groups(True) != groups(False)
    _within_bar(compare.compare(obj, "normal-map", 48), 1000)
