"""The covered texels of one bake (TexelData): which triangle, where, and the surface there,
made by raster.rasterize.

Per-texel attributes are evaluated in blocks (TexelData.blocks, evaluate_in_blocks): a block is
a TexelData over a slice of the texels that shares the whole bake's triangle image and its
per-triangle arrays, so working memory follows the block, not the image, and every per-texel
function runs on cache-sized arrays.
"""

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from . import compiled, raster_kernels, scan_weights
from .blender_lines import MAIN_LINE, LineFacts, octahedral_unit_vectors
from .mesh_arrays import MeshArrays
from .vecmath import normalize, safe_normalize, transform

# Texels per evaluation block: a block's (n, 3) float64 arrays (0.4 MB) stay in a 2 MB L2.
# Measured on the 2-core machine (bench-reference): 8K-32K are within 10%; 1M is 2-3x slower.
BLOCK_TEXELS = 1 << 14
# Per-texel arrays the compiled rasteriser makes per block (TexelData.row_start).
_LAZY_TEXEL_FIELDS = ("pixel", "barycentric")


@dataclass
class TexelData:
    """Every covered texel of a bake: which triangle, where, and the surface there.

    `triangle` is (H, W) with -1 where no triangle covers the texel; `pixel` (N, 2) holds the
    (x, y) of the N covered texels in row-major order and every per-texel array below is (N, ...)
    in that order. World space throughout; `normal` and `tangent` are interpolated but NOT
    normalised (the MikkTSpace convention); `geometric_normal` is unit length.
    """
    mesh: MeshArrays
    uv_map: str
    width: int
    height: int
    triangle: np.ndarray
    # (N, 2) and (N, 3). The compiled rasteriser leaves them out (None) and gives row_start:
    # then a block makes its own texels (raster_kernels.texels_in_range) and the whole
    # image's are made only if asked for (__getattr__), so memory follows the block.
    pixel: np.ndarray = None
    barycentric: np.ndarray = None
    # The Blender line whose bake this models (blender_lines): differentials, normal storage.
    facts: LineFacts = MAIN_LINE
    # (H, W): texels inside two or more triangles (overlapping UVs); the triangle (other than
    # the winner) that also claims each such texel, -1 elsewhere; texels on a shared edge.
    contested: np.ndarray = None
    other_triangle: np.ndarray = None
    on_edge: np.ndarray = None
    uv_offset: tuple = (0.0, 0.0)
    # (H + 1,): covered texels before each row (row-major order), when pixel is left out.
    row_start: np.ndarray = field(default=None, repr=False, compare=False)
    # Per-triangle arrays computed once and shared by the whole bake and all of its blocks.
    _shared: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self):
        for name in _LAZY_TEXEL_FIELDS:
            if self.__dict__.get(name) is None and self.row_start is not None:
                del self.__dict__[name]          # made on first use (__getattr__)

    def __getattr__(self, name):
        """The whole image's pixel, barycentric (and tri) made on first use when the compiled
        rasteriser left them out."""
        if name in _LAZY_TEXEL_FIELDS and self.__dict__.get("row_start") is not None:
            pixel, tri, bary = self._texels(0, self.texel_count)
            self.__dict__.update(pixel=pixel, barycentric=bary)
            self.__dict__.setdefault("tri", tri)
            return self.__dict__[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def texel_count(self):
        """N, the number of covered texels."""
        if "pixel" not in self.__dict__ and self.row_start is not None:
            return int(self.row_start[-1])
        return len(self.pixel)

    def _texels(self, start, stop):
        """(pixel, tri, barycentric) of covered texels [start, stop), from the triangle image."""
        n = max(0, stop - start)
        pixel = np.empty((n, 2), dtype=np.int64)
        tri = np.empty(n, dtype=np.int32)
        bary = np.empty((n, 3))
        cx, cy, cc = self._shared["raster_coefficients"]
        raster_kernels.texels_in_range(self.triangle.reshape(-1), self.row_start, self.width,
                                       start, stop, cx, cy, cc, pixel, tri, bary)
        scan = self._shared.get("scan")
        if scan is not None:            # a bake's: Blender's float32 weights (scan_weights)
            bary = scan_weights.weights_from_planes(scan, tri, pixel, bary)
        return pixel, tri, bary

    @property
    def covered(self):
        return self.triangle >= 0

    @cached_property
    def tri(self):
        x, y = self.pixel[:, 0], self.pixel[:, 1]
        return self.triangle.ravel()[y * self.width + x]

    def block(self, start, stop):
        """The texels [start, stop) as a TexelData: same triangle image and per-triangle
        arrays, per-texel attributes computed for the block only."""
        if "pixel" not in self.__dict__:        # the compiled rasteriser's: made per block
            pixel, tri, bary = self._texels(start, stop)
        else:
            pixel, bary = self.pixel[start:stop], self.barycentric[start:stop]
            tri = self.__dict__["tri"][start:stop] if "tri" in self.__dict__ else None
        block = TexelData(mesh=self.mesh, uv_map=self.uv_map, width=self.width,
                          height=self.height, triangle=self.triangle,
                          pixel=pixel, barycentric=bary,
                          facts=self.facts, contested=self.contested,
                          other_triangle=self.other_triangle, on_edge=self.on_edge,
                          uv_offset=self.uv_offset, _shared=self._shared)
        if tri is not None:
            block.__dict__["tri"] = tri
        return block

    def blocks(self, texels=None):
        """(start, stop, block) over all covered texels, `texels` (BLOCK_TEXELS) at a time."""
        texels = texels or BLOCK_TEXELS
        n = self.texel_count
        for start in range(0, n, texels):
            stop = min(n, start + texels)
            yield start, stop, self.block(start, stop)

    def per_triangle(self, key, make):
        """make() (a per-triangle or per-corner array) once per bake, shared by its blocks."""
        value = self._shared.get(key)
        if value is None:
            value = self._shared[key] = make()
        return value

    @cached_property
    def _bary_rows(self):
        return np.ascontiguousarray(self.barycentric.T)

    def _interpolate(self, corner_values):
        """Corner values (T, 3, ...) interpolated at the texels: (N, ...), each component
        contiguous (vecmath's layout); summed over the corners in order 0, 1, 2."""
        v = np.asarray(corner_values, dtype=np.float64)
        if compiled.enabled():
            return self._interpolate_compiled(corner_values, v)
        key = ("corner_rows", id(corner_values))
        held = self._shared.get(key)
        if held is None or held[0] is not corner_values:
            # (3 * C, T): each corner's components as rows, gathered per texel below.
            held = self._shared[key] = (corner_values, np.ascontiguousarray(
                v.reshape(len(v), 3, -1).transpose(1, 2, 0).reshape(-1, len(v))))
        rows = np.take(held[1], self.tri, axis=1)
        b = self._bary_rows
        c = rows.shape[0] // 3
        out = rows[:c] * b[0]
        out += rows[c:2 * c] * b[1]
        out += rows[2 * c:] * b[2]
        return out[0] if v.ndim == 2 else out.reshape(v.shape[2:] + (-1,)).T

    def corner_table(self, corner_values):
        """Corner values (T, 3, ...) as the compiled kernels read them, (T, 3 * C) float64,
        corner by corner: made once per bake and shared by its blocks."""
        key = ("corner_table", id(corner_values))
        held = self._shared.get(key)
        if held is None or held[0] is not corner_values:
            v = np.asarray(corner_values, dtype=np.float64)
            held = self._shared[key] = (corner_values, np.ascontiguousarray(
                v.reshape(len(v), -1)))
        return held[1]

    def _interpolate_compiled(self, corner_values, v):
        """_interpolate by raster_kernels.interpolate_corners: one pass per texel over the
        corners' components (T, 3 * C), held once per bake like the numpy rows."""
        table = self.corner_table(corner_values)
        channels = table.shape[1] // 3
        out = np.empty((channels, self.texel_count))
        raster_kernels.interpolate_corners(table, np.ascontiguousarray(self.tri),
                                           np.ascontiguousarray(self.barycentric), out)
        return out[0] if v.ndim == 2 else out.reshape(v.shape[2:] + (-1,)).T

    def _interpolate_unit(self, corner_values):
        """normalize(self._interpolate(corner_values)) for (T, 3, 3) corner vectors."""
        if not compiled.enabled():
            return normalize(self._interpolate(corner_values))
        out = np.empty((3, self.texel_count))
        raster_kernels.interpolate_corners_unit(
            self.corner_table(corner_values), np.ascontiguousarray(self.tri),
            np.ascontiguousarray(self.barycentric), out)
        return out.T

    def per_texel(self, per_triangle):
        """A per-triangle array (T,) or (T, C) at every texel: (N,) or (N, C), each component
        contiguous (the same values as per_triangle[self.tri])."""
        if not compiled.enabled() or per_triangle.ndim not in (1, 2) or \
                per_triangle.dtype != np.float64:
            return per_triangle[self.tri]
        table = per_triangle.reshape(len(per_triangle), -1)
        if not table.flags.c_contiguous:
            table = np.ascontiguousarray(table)
        out = np.empty((table.shape[1], self.texel_count))
        raster_kernels.gather_rows(table, np.ascontiguousarray(self.tri), out)
        return out[0] if per_triangle.ndim == 1 else out.T

    @cached_property
    def position(self):
        return self._interpolate(self.mesh.corner_positions_world)

    @cached_property
    def position_object(self):
        return self._interpolate(self.per_triangle("corner_positions_object", lambda: np.asarray(
            self.mesh.positions, dtype=np.float64)[np.asarray(self.mesh.triangles)]))

    @cached_property
    def normal_object(self):
        return self._interpolate(self.mesh.corner_normals)

    @cached_property
    def normal_map_normal_object(self):
        """The object-space normal Cycles' Normal Map node builds its tangent frame on (smooth
        shading). Up to 5.0: the unnormalised interpolation of the stored vertex normals taken
        back to object space (each unit when the transform is applied, as given otherwise).
        In 5.2: the stored corner normals (world space and packed when the transform is
        applied) taken back to object space, interpolated and normalised."""
        corners, unit = self.normal_map_normal_corners()
        return self._interpolate_unit(corners) if unit else self._interpolate(corners)

    def normal_map_normal_corners(self):
        """The corner normals normal_map_normal_object interpolates (T, 3, 3), and whether
        it normalises the result (5.2)."""
        if not self.facts.normal_map_unit_normal:
            if not self.mesh.transform_applied:
                return self.per_triangle("normal_map_corner_normals", lambda: self._ng_where_zero(
                    np.asarray(self.mesh.corner_normals, dtype=np.float64))), False
            # Stored normalised in world space and brought back to object space normalised
            # (triangle_smooth_normal_unnormalized, object_inverse_normal_transform): unit,
            # whatever length free normals were set with (a Set Mesh Normal node).
            return self.per_triangle("normal_map_corner_normals", lambda: self._ng_where_zero(
                safe_normalize(np.asarray(self.mesh.corner_normals, dtype=np.float64),
                               0.0))), False
        if self.mesh.transform_applied:
            m3 = np.asarray(self.mesh.matrix_world, dtype=np.float64)[:3, :3]
            return self.per_triangle("normal_map_corner_normals",
                                     lambda: normalize(self._stored_world_normals @ m3)), True
        return self._stored_object_normals, True

    @cached_property
    def normal(self):
        return transform(self.normal_object, self.mesh.normal_matrix.T)

    @cached_property
    def shading_normal(self):
        """The unit shading normal a renderer shades with (Cycles' sd->N), world space: the
        interpolated corner normals, each taken to world space and normalised first when the
        transform is applied to the mesh (the default), else interpolated in object space and
        then transformed. The two differ only under non-uniform scale."""
        if self.mesh.transform_applied:
            return self._interpolate_unit(self._stored_world_normals)
        n = self._interpolate(self._stored_object_normals)
        return safe_normalize(transform(n, self.mesh.normal_matrix.T), self.geometric_normal)

    def _ng_where_zero(self, corners):
        """(T, 3, 3) `corners` with each triangle whose three normals are zero given its
        world geometric normal at every corner: a zero interpolated normal is replaced by
        Ng in Cycles (triangle_smooth_normal, triangle_smooth_normal_unnormalized), as free
        normals set to zero (a Set Mesh Normal node fed a zero vector; 4.5 and 5.0 store
        them as they are) give. Where only some are zero the interpolation is not."""
        zero = ~np.any(corners.reshape(len(corners), -1), axis=1)
        if not zero.any():
            return corners
        out = corners.copy()
        out[zero] = self.mesh.geometric_normals_world[zero][:, None, :]
        return out

    def _stored(self, unit_normals):
        """Unit normals as the renderer stores them (octahedral 16-bit where it packs)."""
        if self.facts.packed_normals:
            return octahedral_unit_vectors(unit_normals)
        return unit_normals

    @property
    def _stored_object_normals(self):
        return self.per_triangle("stored_object_normals", lambda: self._stored(
            np.asarray(self.mesh.corner_normals, dtype=np.float64)))

    @property
    def _stored_world_normals(self):
        """Corner normals (T, 3, 3) as stored for a mesh with its transform applied: where the
        line packs normals they are packed in object space, then decoded, transformed,
        normalised and packed again (measured: 5e-5 degrees against 0.003-0.006 for one
        packing)."""
        return self.per_triangle("stored_world_normals", lambda: self._ng_where_zero(
            self._stored(safe_normalize(self._stored_object_normals @ self.mesh.normal_matrix.T,
                                        0.0))))

    @cached_property
    def geometric_normal(self):
        return self.per_texel(self.mesh.geometric_normals_world)

    def uv(self, name=None):
        return self._interpolate(self.mesh.uv(name or self.uv_map))

    def point_attribute(self, name):
        """A per-vertex attribute of the mesh interpolated at each texel."""
        if name not in self.mesh.point_attributes:
            raise KeyError(f"{self.mesh.name}: no point attribute {name!r}")
        return self._interpolate(self.per_triangle(("point_attribute", name), lambda: np.asarray(
            self.mesh.point_attributes[name], dtype=np.float64)[np.asarray(self.mesh.triangles)]))

    def tangent_object(self, name=None):
        """Interpolated object-space tangent (N, 3), unnormalised, and its sign (N,), for a UV
        map. The sign is interpolated like any attribute, as Cycles' Normal Map node does;
        MikkTSpace gives one sign per triangle, so it is +-1 in practice."""
        name = name or self.uv_map
        if name not in self.mesh.tangents:
            raise KeyError(f"{self.mesh.name}: no tangents for UV map {name!r}; compute "
                           f"MikkTSpace tangents for it (or use the procedural basis, L4)")
        t = self._interpolate(self.mesh.tangents[name])
        return t, self._interpolate(self.mesh.tangent_signs[name])

    def tangent(self, name=None):
        """The tangent of tangent_object carried to world space as a direction (by the
        object matrix), with its sign."""
        t, sign = self.tangent_object(name)
        m3 = np.asarray(self.mesh.matrix_world, dtype=np.float64)[:3, :3]
        return transform(t, m3.T), sign

    def derivatives(self, name=None):
        """Exact per-triangle world dP/ds, dP/dt (N, 3) for a UV map, and the degenerate mask."""
        name = name or self.uv_map
        dp_ds, dp_dt, bad = self.per_triangle(("derivatives", name),
                                              lambda: self.mesh.triangle_derivatives(name))
        return self.per_texel(dp_ds), self.per_texel(dp_dt), bad[self.tri]

    def texel_steps(self, name=None):
        """Derivatives per bake-texel step, the bake's stand-in for ddx/ddy: returns
        (dpdx, dpdy, dst_dx, dst_dy) where x steps one texel in s and y one texel in t of
        the bake's UV map, and dst_* are the matching steps of UV map `name`."""
        dp_ds, dp_dt, _ = self.derivatives(self.uv_map)
        dpdx, dpdy = dp_ds / self.width, dp_dt / self.height
        if name is None or name == self.uv_map:
            n = len(self.pixel)
            dst_dx = np.tile([1.0 / self.width, 0.0], (n, 1))
            dst_dy = np.tile([0.0, 1.0 / self.height], (n, 1))
            return dpdx, dpdy, dst_dx, dst_dy
        def chain():
            # Chain rule through each triangle's affine map from the bake UVs to the others.
            uv_a, uv_b = self.mesh.uv(self.uv_map), self.mesh.uv(name)
            a1, a2 = uv_a[:, 1] - uv_a[:, 0], uv_a[:, 2] - uv_a[:, 0]
            b1, b2 = uv_b[:, 1] - uv_b[:, 0], uv_b[:, 2] - uv_b[:, 0]
            det = (a1[:, 0] * a2[:, 1] - a2[:, 0] * a1[:, 1])[:, None]
            with np.errstate(divide="ignore", invalid="ignore"):
                dst_ds = (b1 * a2[:, 1:2] - b2 * a1[:, 1:2]) / det
                dst_dt = (b2 * a1[:, 0:1] - b1 * a2[:, 0:1]) / det
            return dst_ds / self.width, dst_dt / self.height
        dst_dx, dst_dy = self.per_triangle(("uv_steps", name), chain)
        return dpdx, dpdy, self.per_texel(dst_dx), self.per_texel(dst_dy)

    def to_image(self, values, fill=np.nan):
        """Scatter per-texel values (N, ...) into an (H, W, ...) image, `fill` elsewhere."""
        values = np.asarray(values)
        # The fill is a weak scalar: float32 values stay float32 under numpy 1 and 2 alike.
        out = np.full((self.height, self.width) + values.shape[1:], fill,
                      dtype=np.result_type(values, fill))
        out[self.pixel[:, 1], self.pixel[:, 0]] = values
        return out

    def interior(self, margin=1):
        """(N,) mask of covered texels whose (2 margin + 1)^2 neighbourhood is all covered:
        their footprint does not touch a UV-island border or the image edge."""
        def image():
            cov = self.covered
            ok = np.zeros_like(cov)
            h, w = cov.shape
            ok[margin:h - margin, margin:w - margin] = True
            for dy in range(-margin, margin + 1):
                for dx in range(-margin, margin + 1):
                    ok[margin:h - margin, margin:w - margin] &= \
                        cov[margin + dy:h - margin + dy, margin + dx:w - margin + dx]
            return ok.ravel()
        ok = self.per_triangle(("interior", margin), image)     # one image for all blocks
        return ok[self.pixel[:, 1] * self.width + self.pixel[:, 0]]


# The dataclass keeps the fields' None defaults as class attributes; without them a texel
# field left out falls through to __getattr__, which makes it.
for _name in _LAZY_TEXEL_FIELDS:
    delattr(TexelData, _name)
