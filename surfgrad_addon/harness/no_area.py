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


def degenerate_triangles(mesh, world):
    """(T,) True where a triangle has no area in 3D: its corners coincide or lie on a line, to
    within float32 rounding (input_checks.zero_area_mask, world positions (V, 3)). Cycles has
    no surface to shade there: its bake writes a zero vector, or a normal made of rounding
    noise (a float32 sliver), whatever the material. The geometric normals are taken here
    (once per mesh, cached) without numpy's division warning: normalize() of a zero cross
    product is NaN by design."""
    with np.errstate(invalid="ignore", divide="ignore"):
        ng = mesh.geometric_normals_world
    return ~np.isfinite(ng).all(axis=1) | R.input_checks.zero_area_mask(world, mesh.triangles)


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
