"""A triangulated mesh as plain arrays (MeshArrays), per triangle corner like Blender's loop
triangles: what the rasteriser (raster.py) reads and the texels (texels.py) interpolate.
Built from a Blender object by harness/mesh_data.py, or procedurally by meshes.py."""

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .input_checks import finite_problem
from .vecmath import cross, normalize


@dataclass
class MeshArrays:
    """A triangulated mesh as plain arrays, per triangle corner like Blender's loop triangles.

    positions (V, 3) object space; triangles (T, 3) vertex indices; corner_normals (T, 3, 3)
    (split normals); uv_maps {name: (T, 3, 2)}; tangents {name: (T, 3, 3)} and
    tangent_signs {name: (T, 3)} as MikkTSpace gives them (optional per UV map);
    matrix_world (4, 4).
    """
    positions: np.ndarray
    triangles: np.ndarray
    corner_normals: np.ndarray
    uv_maps: dict
    tangents: dict = field(default_factory=dict)
    tangent_signs: dict = field(default_factory=dict)
    matrix_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "mesh"
    # Cycles applies the object transform to a mesh only one object uses: its corner normals
    # then go to world space and are normalised before interpolation (see shading_normal).
    transform_applied: bool = True
    point_attributes: dict = field(default_factory=dict)   # {name: (V, C)} per vertex
    # (T,) the mesh face (polygon) each triangle comes from, when known: for messages.
    triangle_faces: np.ndarray = None
    # {uv map: (T,) bool}: flat triangles whose MikkTSpace welds the tangents above may not
    # match (lines without float corner normals: harness/flat_welds.py).
    unsure_welds: dict = field(default_factory=dict)

    def validate(self):
        """Raise ValueError naming the problem and the fix; return self when usable."""
        p = np.asarray(self.positions)
        t = np.asarray(self.triangles)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
            raise ValueError(f"{self.name}: positions must be a non-empty (V, 3) array, "
                             f"got shape {p.shape}; the object has no mesh data")
        if t.ndim != 2 or t.shape[1] != 3 or len(t) == 0:
            raise ValueError(f"{self.name}: triangles must be a non-empty (T, 3) array, got "
                             f"shape {t.shape}; the mesh has no faces to bake")
        if t.min() < 0 or t.max() >= len(p):
            raise ValueError(f"{self.name}: triangle indices must lie in [0, {len(p)})")
        if np.asarray(self.corner_normals).shape != (len(t), 3, 3):
            raise ValueError(f"{self.name}: corner_normals must have shape {(len(t), 3, 3)}")
        if not self.uv_maps:
            raise ValueError(f"{self.name}: the mesh has no UV map; add one (UV > Unwrap) "
                             f"before baking")
        for name, uv in self.uv_maps.items():
            if np.asarray(uv).shape != (len(t), 3, 2):
                raise ValueError(f"{self.name}: UV map {name!r} must have shape {(len(t), 3, 2)}")
        for label, arr in (("positions", p), ("corner_normals", self.corner_normals),
                           ("matrix_world", self.matrix_world),
                           *((f"the UVs of UV map {k!r}", v) for k, v in self.uv_maps.items())):
            problem = finite_problem(label, arr)
            if problem:
                raise ValueError(f"{self.name}: {problem}")
        if np.linalg.det(np.asarray(self.matrix_world, dtype=np.float64)[:3, :3]) == 0:
            # (the normal matrix's inverse raised numpy's bare "Singular matrix")
            raise ValueError(f"{self.name}: matrix_world scales an axis to zero, so its normals "
                             f"have no direction: fix the object's scale")
        return self

    def uv(self, name):
        if name not in self.uv_maps:
            raise KeyError(f"{self.name}: no UV map named {name!r}; available: "
                           f"{sorted(self.uv_maps)}")
        return np.asarray(self.uv_maps[name], dtype=np.float64)

    @cached_property
    def normal_matrix(self):
        """Inverse transpose of the upper 3x3: how normals go from object to world."""
        return np.linalg.inv(np.asarray(self.matrix_world, dtype=np.float64)[:3, :3]).T

    @cached_property
    def corner_positions_world(self):
        m = np.asarray(self.matrix_world, dtype=np.float64)
        p = np.asarray(self.positions, dtype=np.float64)[np.asarray(self.triangles)]
        return p @ m[:3, :3].T + m[:3, 3]

    @cached_property
    def geometric_normals_world(self):
        """Unit face normals (T, 3) in world space, from the object-space winding (so they keep
        facing out under negative scale, as in Cycles)."""
        p = np.asarray(self.positions, dtype=np.float64)[np.asarray(self.triangles)]
        ng = cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        return normalize(ng @ self.normal_matrix.T)

    def triangle_derivatives(self, uv_name):
        """Exact world-space dP/ds and dP/dt per triangle (T, 3) each, for one UV map, and a
        (T,) mask of triangles whose UVs are degenerate (zero area: derivatives set to 0)."""
        p = self.corner_positions_world
        uv = self.uv(uv_name)
        e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
        det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
        scale = np.abs(d1).sum(1) * np.abs(d2).sum(1)
        degenerate = np.abs(det) <= 1e-14 * np.maximum(scale, 1e-300)
        inv = np.where(degenerate, 0.0, 1.0 / np.where(degenerate, 1.0, det))[:, None]
        # [dP/ds dP/dt] = [e1 e2] [d1 d2]^-1
        dp_ds = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv
        dp_dt = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv
        return dp_ds, dp_dt, degenerate
