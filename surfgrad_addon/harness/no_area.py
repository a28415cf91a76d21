"""compare's faces without area (harness/compare.py): a mesh or UV map collapsed everywhere is
refused in the bake request's words; triangles without area in 3D are found, their texels taken
out of the comparison (counted as outside) and their faces named in a warning.

Such a triangle (corners that coincide or lie on a line: a collapsed quad, three collinear
points) can still have area in UV and claim texels. Cycles has no surface to shade there, so
its bake holds a zero vector (or a normal made of float32 rounding) whatever the material;
before, compare scored those texels at 180 degrees against a correct group.
"""

import numpy as np

from .. import reference as R
from ..reference.vecmath import FLT_EPSILON

# A triangle whose float32 normal is uncertain by this much cannot be held to compare's max
# bar (0.5 deg, tests/test_bake_compare.py): float32_slivers counts it as without area.
SLIVER_ANGLE = np.radians(0.5)
# below_float32_step: a face whose legs are at most this many float32 steps of its own largest
# coordinate holds nothing but rounding.
RESOLUTION_ULPS = 2.0


def world_positions(mesh):
    """The mesh's vertex positions (V, 3) in world space."""
    m = np.asarray(mesh.matrix_world, dtype=np.float64)
    return np.asarray(mesh.positions, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]


def collapsed_problem(mesh, world, obj, uv_map):
    """The bake request's words (input_checks) for a mesh whose every face has no area, or a
    UV map `uv_map` without area; None otherwise. obj: the object the mesh was read from."""
    return R.input_checks.collapsed_mesh_problem(
        f"mesh {obj.data.name!r} of object {obj.name!r}", world, mesh.triangles) or \
        R.input_checks.collapsed_uv_problem(uv_map, obj.name, mesh.uv(uv_map))


def degenerate_triangles(mesh, world, facts):
    """(T,) True where a triangle has no area in 3D: its corners coincide or lie on a line, to
    within float32 rounding (input_checks.zero_area_mask, world positions (V, 3); and
    float32_slivers). Cycles has
    no surface to shade there: its bake writes a zero vector, or a normal made of rounding
    noise (a float32 sliver), whatever the material. The geometric normals are taken here
    (once per mesh, cached) without numpy's division warning: normalize() of a zero cross
    product is NaN by design."""
    with np.errstate(invalid="ignore", divide="ignore"):
        ng = mesh.geometric_normals_world
    # Cycles holds the positions in world space where it applied the transform, else in
    # object space (addon/cycles_geometry.py): its float32 rounding is of those.
    held = world if mesh.transform_applied else np.asarray(mesh.positions, dtype=np.float64)
    out = (~np.isfinite(ng).all(axis=1) | R.input_checks.zero_area_mask(world, mesh.triangles)
           | float32_slivers(held, mesh.triangles))
    if not facts.free_normals:
        out |= below_float32_step(held, mesh.triangles)
    return out


def below_float32_step(positions, triangles):
    """(T,) True where a triangle is no bigger than float32 can place at its own coordinates:
    its area at most that of a right triangle of legs RESOLUTION_ULPS float32 steps of its
    largest coordinate. Such a face (0.1 mm quads 5 km out) was snapped onto float32's grid
    when the mesh was stored: what is left is rounding (flipped and collapsed triangles, their
    vertex normals anywhere). 4.5 and later reproduce Cycles there exactly; 4.2's reference,
    whose MikkTSpace input passes through Blender's encoded normals (LineFacts.free_normals),
    does not: p99 3.9 / max 86 deg on a correct group beside a good grid, 40 / 141 on such a
    mesh alone, so on 4.2 compare leaves these faces out. The extent of the whole mesh had
    stood in for this (and made a far separate part take every small face's area)."""
    p = np.asarray(positions, dtype=np.float64)[np.asarray(triangles)]
    step = RESOLUTION_ULPS * FLT_EPSILON * np.abs(p).max(axis=(1, 2))
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    return 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1) <= 0.5 * step * step


def float32_slivers(positions, triangles):
    """(T,) True where a triangle's normal is float32 rounding: the rounding bound of the
    float32 cross product of its edges, FLT_EPSILON times the sums of its terms' magnitudes
    (|e1y e2z| + |e1z e2y|, ...: Cycles' Mesh::Triangle::compute_normal, and Blender's face
    normal, the reference's MikkTSpace input, alike), turns the normal by SLIVER_ANGLE or more.
    Three points on a diagonal, collinear in reals but not in float32, have an area far above
    zero_area_mask's (2e-9 of their longest edge squared) and a normal that points anywhere there
    (measured: one texel at 2.4 deg); a thin sliver along an axis keeps an exact normal (its
    terms vanish) and stays compared."""
    p = np.asarray(positions, dtype=np.float64)[np.asarray(triangles)]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    cross = np.linalg.norm(np.cross(e1, e2), axis=1)
    # cross = e1[yzx] e2[zxy] - e1[zxy] e2[yzx]: the magnitudes of the two products.
    terms = (np.abs(e1[:, [1, 2, 0]] * e2[:, [2, 0, 1]])
             + np.abs(e1[:, [2, 0, 1]] * e2[:, [1, 2, 0]]))
    return FLT_EPSILON * np.linalg.norm(terms, axis=1) >= np.tan(SLIVER_ANGLE) * cross


def all_degenerate_problem(obj, degenerate):
    """None unless every triangle of obj's mesh is without area (degenerate_triangles); then
    why and the fix. Faces snapped onto float32's grid everywhere (a small mesh whose vertices
    lie far from its object's origin: a georeferenced import) pass the bake request's test,
    which asks only whether faces collapsed; on 4.2 compare cannot hold them to its bar
    (below_float32_step)."""
    if len(degenerate) == 0 or not np.all(degenerate):
        return None
    return (f"every face of mesh {obj.data.name!r} of object {obj.name!r} has no area Cycles "
            f"can shade: collapsed to a point or a line, or smaller than float32 can place at "
            f"its coordinates (its vertices are far from the object's origin for its size), "
            f"so the bake would be rounding: fix the mesh, or move its vertices nearer the "
            f"object's origin (Object > Set Origin > Origin to Geometry)")


def without_degenerate(td, covered, degenerate):
    """The bake's coverage with the texels of triangles without area taken out (counted as
    "outside" by compare_tile: the reference does not model them). A pass over the triangle
    image only when the mesh has such triangles."""
    if not degenerate.any():
        return covered
    claimed = td.triangle >= 0
    claimed[claimed] = degenerate[td.triangle[claimed]]
    return covered & ~claimed


def faces_text(mesh, triangles):
    """The mesh faces of the given triangles as compare's warnings name them: the first 8 in
    order, then how many more (the triangles themselves where the faces are unknown)."""
    faces = np.asarray(triangles, dtype=np.int64)
    if mesh.triangle_faces is not None:
        faces = np.asarray(mesh.triangle_faces)[faces]
    faces = np.unique(faces)
    return ", ".join(map(str, faces[:8].tolist())) + (f" and {len(faces) - 8} more"
                                                      if len(faces) > 8 else "")


def degenerate_warning(mesh, degenerate, texels):
    """A warning naming the faces without area whose texels were not compared, or None."""
    if not texels:
        return None
    shown = faces_text(mesh, np.flatnonzero(degenerate))
    return (f"{mesh.name!r}: {texels} texels of {int(degenerate.sum())} triangles without "
            f"area in 3D (faces {shown}) are not compared (counted as outside): Cycles has no "
            f"surface to shade there and bakes a zero vector (or a normal made of float32 "
            f"rounding), whatever the material. If that is not meant, remove them (Mesh > "
            f"Clean Up > Degenerate Dissolve).")
