"""Red team 32a: `compare` and the bake request on meshes the project had not seen, built here.

1. Free normals that are not unit length (a Set Mesh Normal node, Free, fed an unnormalised
   vector; Blender keeps the length): MikkTSpace reads what Cycles stores. Up to 5.0 that is
   the normal as Blender gave it, length and all (cycles/scene/mesh.cpp,
   MikkMeshWrapper::GetNormal), while the Normal Map node's frame takes each stored normal
   back to object space unit; 5.2 reads its octahedral-packed normals decoded, so corners of
   one direction weld whatever their lengths.
2. A separate face far out (a stray part of an import, a second island of faces): the test for
   faces without area measured each triangle against the extent of the mesh's faces, so a
   face 1000 km out made every face of a 2 m grid "without area" (compare and the bake
   request refused the mesh) and one 100 km out left a finer grid's texels out of compare.
   Now each triangle is measured against its own size (reference/input_checks.zero_area_mask).
3. Free normals set to zero (a Set Mesh Normal node fed a zero vector, a script normalising a
   zero attribute): 4.5 and 5.0 store them as they are; Cycles interpolates the zeros and
   shades with the geometric normal where the interpolation is zero (triangle_smooth_normal).
   The reference divided by their length: NaN, and a correct group was called 180 deg wrong.
   5.2's MikkTSpace reads its packed normals, decoded, never zero (finding 1's rule).
4. Faces snapped onto float32's grid (0.1 mm quads whose vertices lie 5 km from the object's
   origin: a georeferenced import): Cycles shades what float32 kept, flipped and collapsed
   triangles with vertex normals anywhere. 4.5 and later reproduce it exactly (5.2 since
   finding 1's rule: before, p99 41.9 / max 165 deg on a correct group); 4.2's MikkTSpace input
   passes through Blender's encoded normals and cannot (p99 40 / max 141), so 4.2 leaves such
   faces out (no_area.below_float32_step, LineFacts.free_normals) and refuses a mesh of
   nothing else. The mesh extent had excluded them beside a larger part by accident.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import bake_request  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from surfgrad_addon.addon.node_builder import running_line  # noqa: E402
from surfgrad_addon.reference import input_checks  # noqa: E402
from test_faults_unseen_meshes31 import RES, _within_bar, empty_file  # noqa: E402,F401

pytestmark = pytest.mark.tier("bake")


def _grid(n=8, size=2.0, offset=(0.0, 0.0, 0.0), uv_corner=(0.05, 0.05), uv_size=0.6):
    """An n x n bumped grid `size` wide about `offset`, filling a UV square of `uv_size` at
    `uv_corner`: (vertices, quads, per-vertex UVs)."""
    xs = np.linspace(-1.0, 1.0, n + 1)
    gx, gy = np.meshgrid(xs, xs)
    z = 0.3 * np.exp(-1.5 * (gx ** 2 + gy ** 2))
    verts = np.stack([gx, gy, z], -1).reshape(-1, 3) * (0.5 * size) + np.asarray(offset)
    faces = [[j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1,
              (j + 1) * (n + 1) + i] for j in range(n) for i in range(n)]
    uvs = (np.stack([gx, gy], -1).reshape(-1, 2) * 0.5 + 0.5) * uv_size + np.asarray(uv_corner)
    return verts, faces, uvs


def _object(name, parts):
    """A smooth mesh object of several _grid parts (UV map 'UVMap')."""
    verts, faces, uvs = [], [], []
    for v, f, uv in parts:
        base = sum(len(x) for x in verts)
        verts.append(v)
        uvs.append(uv)
        faces += [[base + i for i in q] for q in f]
    verts, uvs = np.vstack(verts), np.vstack(uvs)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts.tolist(), [], faces)
    mesh.uv_layers.new(name="UVMap").uv.foreach_set(
        "vector", uvs[[i for q in faces for i in q]].ravel())
    mesh.polygons.foreach_set("use_smooth", np.ones(len(faces), dtype=bool))
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _set_free_normals(mesh, normals, domain):
    """Store `normals` as the mesh's free normals on `domain` (a float 'custom_normal', as a
    Set Mesh Normal node writes it); Blender's corner normals (L, 3) then. Skips a line
    without free normals (4.2: the attribute is a plain one)."""
    mesh.attributes.new("custom_normal", "FLOAT_VECTOR", domain).data.foreach_set(
        "vector", np.asarray(normals, dtype=np.float64).ravel())
    mesh.update()
    if not mesh.has_custom_normals:
        pytest.skip(f"Blender {bpy.app.version_string} has no free normals: a "
                    f"'custom_normal' attribute is a plain one")
    corner = np.empty(len(mesh.loops) * 3)
    mesh.corner_normals.foreach_get("vector", corner)
    return corner.reshape(-1, 3)


@pytest.mark.parametrize("domain", ["POINT", "CORNER"])
def test_free_normals_of_any_length_give_mikktspace_what_cycles_reads(empty_file, domain):
    """1. Point normals (x 0.4, y -0.3, 1) of length 1 .. 1.12; corner normals of those
    directions, each corner's length drawn from 0.5 .. 2. Before, a correct SG Normal Map at
    64^2: point normals p99 1.61 / max 2.81 deg on 4.5 and 5.0 (MikkTSpace got unit normals,
    Cycles' the raw ones; 2.71 / 3.21 with the raw ones in the frame too), corner normals
    p99 8.9 / max 24.8 there; corner normals p99 0.35 / max 0.54 on 5.2 (each normalised on its own, corners of one vertex differed in
    the last bits and did not weld; Cycles' decoded packed normals do). Cycles' own tangent
    (its Tangent node, baked) was 0.54 deg from the reference's there; now within 1e-5."""
    from support.cycles_tangents import tangent_errors
    verts, faces, uvs = _grid(uv_size=0.9)
    obj = _object("LongNormals", [(verts, faces, uvs)])
    mesh = obj.data
    n = np.column_stack([0.4 * verts[:, 0], -0.3 * verts[:, 1], np.ones(len(verts))])
    if domain == "CORNER":
        n = n[[v for f in faces for v in f]] * np.random.default_rng(2).uniform(
            0.5, 2.0, (len(mesh.loops), 1))
    corner = _set_free_normals(mesh, n, domain)
    length = np.linalg.norm(corner, axis=1)
    assert length.max() > 1.1 and (domain == "POINT" or length.min() < 0.9)   # kept as set
    for method in ("normal-map", "object-normal"):
        _within_bar(compare.compare(obj, method, RES), 3000)
    err, used, _ = tangent_errors(obj, "UVMap", RES)
    assert used.sum() > 2000
    assert err.max() < 0.01, err.max()


@pytest.mark.parametrize("far,n", [(1.0e6, 8), (1.0e5, 16)], ids=["1000km", "100km"])
def test_a_separate_face_far_out_leaves_the_faces_elsewhere_their_area(empty_file, far, n):
    """2. A 2 m grid (n x n quads, UVs in 0.05 .. 0.65) and one small separate part (a 1 m
    quad, or a 2 m one of 4 quads, UVs in 0.75 .. 0.95) `far` metres out. Before: 1000 km,
    compare and the bake request refused it ("every face of mesh ... has zero area", exit 2);
    100 km, compare left the grid's 1521 texels out ("without area") and compared the far
    part's 169. Now every texel is compared, within the bar (measured 0.0007 deg on 5.2,
    0.017 on 4.2)."""
    grid = _grid(n)
    island = _grid(1 if far > 5e5 else 2, 1.0 if far > 5e5 else 2.0, (far, 0.0, 0.0),
                   (0.75, 0.75), 0.2)
    obj = _object("FarPart", [grid, island])
    warnings = []
    problems = bake_request.mesh_problems(obj, "UVMap", warnings)
    assert not any("zero area" in p for p in problems), problems
    report = compare.compare(obj, "normal-map", RES)
    _within_bar(report, 1600)
    assert report["excluded"]["outside"] == 0, report
    assert not any("without area" in w for w in report.get("warnings", [])), report
    # Independently: every triangle of both parts has area against its own size.
    verts = np.vstack([grid[0], island[0]])
    obj.data.calc_loop_triangles()
    tris = np.array([t.vertices[:] for t in obj.data.loop_triangles])
    areas = input_checks.triangle_areas(verts, tris)
    assert areas.min() > 1e-3 and not input_checks.zero_area_mask(verts, tris).any()
    # A triangle collapsed onto a line (float64 rounding of a rotation left in it) beside
    # them is still found, and a mesh collapsed everywhere still refused.
    rot = np.array([[0.6, -0.8, 0.0], [0.8, 0.6, 0.0], [0.0, 0.0, 1.0]])
    line = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [1.1, 0.0, 0.0]]) @ rot.T + (3.0, 1.0, 0.0)
    with_line = np.vstack([verts, line])
    tris_line = np.vstack([tris, [[len(verts), len(verts) + 1, len(verts) + 2]]])
    assert input_checks.zero_area_mask(with_line, tris_line).tolist() == \
        [False] * len(tris) + [True]
    flat = verts * (1.0, 0.0, 0.0)
    assert input_checks.collapsed_mesh_problem("the parts", flat, tris) is not None


@pytest.mark.parametrize("domain", ["POINT", "CORNER"])
def test_free_normals_set_to_zero_shade_as_cycles_shades_them(empty_file, domain):
    """3. Point normals (x 0.4, y -0.3, 1) with the nine about the centre zero (eight whole
    triangles zero) and one more alone, or those normals on the corners with every seventh
    corner zero. Before, at 64^2 on 4.5 and 5.0: p99 180 / max 180 deg on normal-map and
    object-normal alike (mean 39.7, POINT; 76.2, CORNER), and numpy's "invalid value
    encountered in divide" on stderr. 5.2 shaded right (its packed normals are never zero)
    but MikkTSpace got the zeros, where Cycles' gets its decoded packed normal: p99 2.38 /
    max 3.29 (POINT), 3.82 / 14.40 (CORNER) on normal-map.
    Also under a rotation and non-uniform scale, and shared by a second object (Cycles then
    keeps the mesh in object space)."""
    verts, faces, uvs = _grid(uv_size=0.9)
    obj = _object("ZeroNormals", [(verts, faces, uvs)])
    mesh = obj.data
    n = np.column_stack([0.4 * verts[:, 0], -0.3 * verts[:, 1], np.ones(len(verts))])
    if domain == "POINT":
        n[(np.abs(verts[:, 0]) < 0.3) & (np.abs(verts[:, 1]) < 0.3)] = 0.0
        n[10] = 0.0
    else:
        n = n[[v for f in faces for v in f]]
        n[::7] = 0.0
    corner = _set_free_normals(mesh, n, domain)
    zero = np.linalg.norm(corner, axis=1) == 0.0
    assert zero.sum() == (40 if domain == "POINT" else 37)          # 10 vertices x 4 corners
    for method in ("normal-map", "object-normal"):
        report = compare.compare(obj, method, RES)
        _within_bar(report, 3000)
        assert report["excluded"]["outside"] == 0, report
    obj.scale = (1.5, 0.7, 1.1)
    obj.rotation_euler = (0.3, -0.2, 0.6)
    _within_bar(compare.compare(obj, "normal-map", RES), 3000)
    shared = bpy.data.objects.new("Shared", mesh)
    bpy.context.scene.collection.objects.link(shared)
    shared.location = (4.0, 0.0, 0.0)
    _within_bar(compare.compare(obj, "normal-map", RES), 3000)


def test_free_normals_are_this_lines_storage(empty_file):
    """LineFacts.free_normals: a float CORNER 'custom_normal' is read as the mesh's custom
    normals exactly where the table says (4.5 and later)."""
    verts, faces, uvs = _grid(2)
    mesh = _object("Facts", [(verts, faces, uvs)]).data
    n = np.tile([0.0, 0.6, 0.8], (len(mesh.loops), 1))
    mesh.attributes.new("custom_normal", "FLOAT_VECTOR", "CORNER").data.foreach_set(
        "vector", n.ravel())
    mesh.update()
    assert running_line().free_normals == mesh.has_custom_normals


SNAPPED = dict(n=4, size=4.0e-4, offset=(5.0e3, 0.0, 0.0))     # 0.1 mm quads, 5 km out


def test_faces_snapped_by_float32_beside_a_good_part(empty_file):
    """4. A 2 m grid and a 0.4 mm grid of 0.1 mm quads 5 km out in the same mesh. Compared
    within the bar on every line; on 4.2 the snapped faces' 169 texels are left out and named
    (with the zero-area test measured against each face's own size alone: p99 3.9 / max 86 deg
    there); 4.5 and later compare them too (before, the mesh extent left them out)."""
    grid = _grid(8)
    snapped = _grid(uv_corner=(0.75, 0.75), uv_size=0.2, **SNAPPED)
    obj = _object("Snapped", [grid, snapped])
    report = compare.compare(obj, "normal-map", RES)
    _within_bar(report, 1500)
    left_out = report["excluded"]["outside"]
    if running_line().free_normals:
        assert left_out == 0, report
    else:
        assert left_out == 169, report
        assert any("without area" in w and "faces 64," in w for w in report["warnings"])


def test_a_mesh_snapped_by_float32_everywhere(empty_file):
    """4. The 0.1 mm quads alone, 5 km from their object's origin, filling the UV square.
    Before: a correct group scored p99 41.9 / max 165 deg on 5.2 and 40.2 / 141 on 4.2 (exit
    0). Now 4.5 and later compare it within the bar and 4.2 refuses it, saying why."""
    obj = _object("SnappedAlone", [_grid(uv_size=0.9, **SNAPPED)])
    if running_line().free_normals:
        _within_bar(compare.compare(obj, "normal-map", RES), 2500)
        return
    with pytest.raises(compare.CompareError, match="smaller than float32 can place at its "
                                                   "coordinates"):
        compare.compare(obj, "normal-map", RES)
