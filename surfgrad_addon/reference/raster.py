"""Meshes into texels: rasterise a mesh's triangles into the W x H texture of one UV map.

Conventions follow Blender's bake: texel (i, j) is shaded at its centre nudged by Blender's
bake offset, ((i + 0.501) / W, (j + 0.502) / H) (image_sampling.BAKE_TEXEL_OFFSET), row j = 0
at v = 0 (bottom, as in Image.pixels). Texels no triangle covers are marked (triangle index
-1), never filled in.

Contested texels follow Blender's bake (render/intern/bake.cc, RE_bake_pixels_populate):
triangles are scan-converted in loop-triangle order and each writes every texel it covers
(store_bake_pixel), so a texel several triangles claim goes to the LAST of them, the highest
triangle index (pinned on every line: tests/test_raster_rules.py). Texels are clipped to the
image: UVs outside 0..1 bake nothing (no wrap); a UDIM tile is the image of its own UV square
(uv_offset, see tiles.py). TexelData flags texels claimed by two triangles' interiors
(`contested`: overlapping UV islands) and texels within float32 rounding of an edge
(`on_edge`): there Blender's float32 scan conversion decides the side, and on an island border
Cycles' bake finds the sample outside its triangle and moves it by a hashed jitter
(integrator_init_from_bake, bake_jitter_barycentric).

Everything is vectorised over candidate texels: each triangle is cut into one span of texels
per row, and spans are expanded band by band of rows; only a loop over bands remains.

Per-texel attributes are evaluated in blocks (TexelData.blocks, evaluate_in_blocks): a block is
a TexelData over a slice of the texels that shares the whole bake's triangle image and its
per-triangle arrays, so working memory follows the block, not the image, and every per-texel
function runs on cache-sized arrays.
"""

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from . import compiled, raster_kernels
# The kernel modules, imported for their compiled.LOADERS (load_compiled runs them).
from . import (height_map_kernels, listing_kernels, normal_map_kernels,  # noqa: F401
               parallax_kernels, sampling_kernels)
from .blender_lines import MAIN_LINE, LineFacts, octahedral_unit_vectors
from .input_checks import finite_problem
from .vecmath import cross, normalize, transform

# Texels per band of rows in rasterize (its working memory is about 150 bytes x this);
# 16K measured 1.1-2x faster than 64K (cache).
_BAND_TEXELS = 1 << 14
# Texels per evaluation block: a block's (n, 3) float64 arrays (0.4 MB) stay in a 2 MB L2.
# Measured on the 2-core machine (bench-reference): 8K-32K are within 10%; 1M is 2-3x slower.
BLOCK_TEXELS = 1 << 14
# Per-texel arrays the compiled rasteriser makes per block (TexelData.row_start).
_LAZY_TEXEL_FIELDS = ("pixel", "barycentric")
# Float32 rounding of Blender's scan conversion, in texels at 256^2 (scaled with the size).
_EDGE_TEXELS = 1e-4


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
                           *((f"UV map {k!r}", v) for k, v in self.uv_maps.items())):
            problem = finite_problem(label, arr)
            if problem:
                raise ValueError(f"{self.name}: {problem}")
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
        shading). Up to 5.0: the unnormalised interpolation of the object's corner normals.
        In 5.2: the stored corner normals (world space and packed when the transform is
        applied) taken back to object space, interpolated and normalised."""
        corners, unit = self.normal_map_normal_corners()
        return self._interpolate_unit(corners) if unit else self.normal_object

    def normal_map_normal_corners(self):
        """The corner normals normal_map_normal_object interpolates (T, 3, 3), and whether
        it normalises the result (5.2)."""
        if not self.facts.normal_map_unit_normal:
            return self.mesh.corner_normals, False
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
        return normalize(transform(n, self.mesh.normal_matrix.T))

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
        return self.per_triangle("stored_world_normals", lambda: self._stored(
            normalize(self._stored_object_normals @ self.mesh.normal_matrix.T)))

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


def rasterize(mesh, uv_map, width, height, sample_offset=None, facts=MAIN_LINE,
              uv_offset=(0.0, 0.0)):
    """Rasterise `mesh` into a width x height texture of UV map `uv_map` (see module doc).
    sample_offset: where in its texel each texel is sampled (default: where the bake of
    `facts`' line shades; (0.5, 0.5) for exact centres). facts: the Blender line modelled.
    uv_offset: the UV corner of the image (a UDIM tile's, tiles.tile_uv_offset)."""
    if sample_offset is None:
        sample_offset = facts.bake_texel_offset
    mesh.validate()
    if width < 1 or height < 1:
        raise ValueError(f"bake resolution must be positive, got {width} x {height}")
    uv = mesh.uv(uv_map)
    # Sample space: texel (i, j) is sampled at (i, j).
    q = ((uv - np.asarray(uv_offset, dtype=np.float64)) * np.array([width, height], dtype=np.float64)
         - np.asarray(sample_offset))
    a, b, c = q[:, 0], q[:, 1], q[:, 2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    lo = np.ceil(q.min(axis=1) - 1e-9).astype(np.int64)
    hi = np.floor(q.max(axis=1) + 1e-9).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [width - 1, height - 1])
    span = np.maximum(hi - lo + 1, 0)
    counts = span[:, 0] * span[:, 1]
    counts[area == 0] = 0  # zero-area UV triangles cover nothing
    coef = _barycentric_coefficients(a, b, c, area)
    # Near an edge (within float32 rounding of Blender's scan conversion, in barycentric units
    # of each triangle) a texel's side is not decided by exact arithmetic.
    edge_len = np.stack([np.hypot(*(b - c).T), np.hypot(*(c - a).T), np.hypot(*(a - b).T)], 1)
    altitude = np.abs(area) / np.maximum(edge_len.max(axis=1), 1e-300)
    tol = _EDGE_TEXELS * max(width, height) / 256 / np.maximum(altitude, 1e-300)
    # Each triangle's texels, row by row: a row of a triangle is one span of x (the three
    # edge half-planes cut the row into an interval), widened by a texel each side so that
    # the per-texel test below, not the span's rounding, decides every texel. Spans are taken
    # in row order (triangle order within a row) and expanded band by band of rows, so the
    # working memory is a band's, not the image's.
    if compiled.enabled():
        return _rasterize_compiled(mesh, uv_map, width, height, facts, uv_offset, coef, tol,
                                   lo, hi, counts)
    span_t, span_y, span_x0, span_x1 = _row_spans(coef, lo, hi, counts, np.maximum(tol, 1e-12))
    npx = width * height
    triangle = np.full(npx, -1, dtype=np.int32)
    other_tri = np.full(npx, -1, dtype=np.int32)
    contested = np.zeros(npx, dtype=bool)
    on_edge = np.zeros(npx, dtype=bool)
    # Texels are at most the candidates; filled band by band in row-major order.
    n_max = min(npx, int(np.sum(span_x1 - span_x0 + 1)))
    pixel = np.empty((n_max, 2), dtype=np.int64)
    bary_out = np.empty((n_max, 3))
    n_out = 0
    band_rows = max(1, _BAND_TEXELS // width)
    row_start = np.searchsorted(span_y, np.arange(0, height + band_rows, band_rows))
    # Barycentric k is affine in the texel position: (coef[t, k, 0] x + coef[t, k, 1] y) +
    # coef[t, k, 2], evaluated in exactly that order everywhere (bit-identical results).
    cx = [np.ascontiguousarray(coef[:, k, 0]) for k in range(3)]
    cy = [np.ascontiguousarray(coef[:, k, 1]) for k in range(3)]
    cc = [np.ascontiguousarray(coef[:, k, 2]) for k in range(3)]
    for b, y0 in enumerate(range(0, height, band_rows)):
        s0, s1 = row_start[b], row_start[b + 1]
        if s1 <= s0:
            continue
        y1 = min(height, y0 + band_rows)
        st, sy = span_t[s0:s1], span_y[s0:s1]
        n = span_x1[s0:s1] - span_x0[s0:s1] + 1
        t = np.repeat(st, n)
        px = np.repeat(span_x0[s0:s1] - np.cumsum(n) + n, n) + np.arange(n.sum())
        bary = []
        for k in range(3):      # per span: the row's term; per texel: the rest
            bk = np.repeat(cx[k][st], n) * px
            bk += np.repeat(cy[k][st] * sy, n)
            bk += np.repeat(cc[k][st], n)
            bary.append(bk)
        score = np.minimum(np.minimum(bary[0], bary[1]), bary[2])
        tol_t = np.repeat(tol[st], n)
        cand = np.nonzero(score >= -tol_t)[0]       # near an edge or inside
        flat = (np.repeat(sy - y0, n) * width + px)[cand]
        score, t, tol_t = score[cand], t[cand], tol_t[cand]
        band_px = (y1 - y0) * width
        near_claims = np.bincount(flat, minlength=band_px)
        strict_claims = np.bincount(flat[score > tol_t], minlength=band_px)
        # The bake's rule: the last triangle (highest index) containing the sample point wins.
        # A texel's candidates come in ascending triangle order (spans are), so the last one
        # is the winner and the one before it the other claimant; only texels claimed more
        # than once need sorting.
        inside = score >= -1e-12
        fi, ti, ci = flat[inside], t[inside], cand[inside]
        best = np.full(band_px, -1, dtype=np.int32)
        other = np.full(band_px, -1, dtype=np.int32)
        winner = np.zeros(band_px, dtype=np.int64)     # the winning candidate of a texel
        claims = np.bincount(fi, minlength=band_px)
        multi = claims[fi] > 1
        one = ~multi
        best[fi[one]] = ti[one]
        winner[fi[one]] = ci[one]
        if multi.any():
            m = np.nonzero(multi)[0]
            m = m[np.argsort(fi[m], kind="stable")]
            fm, tm = fi[m], ti[m]
            last = np.ones(len(m), dtype=bool)
            last[:-1] = fm[1:] != fm[:-1]
            prev = np.nonzero(last[1:] & ~last[:-1])[0]
            other[fm[prev + 1]] = tm[prev]
            best[fm[last]] = tm[last]
            winner[fm[last]] = ci[m[last]]
        cov = np.nonzero(best >= 0)[0]
        k = len(cov)
        x, y = cov % width, cov // width + y0
        tc = best[cov]
        # The winner's barycentrics, clamped and renormalised (summed in order 0, 1, 2).
        wc = winner[cov]
        bb = bary_out[n_out:n_out + k]
        cols = [b[wc] for b in bary]
        lowest = np.minimum(np.minimum(cols[0], cols[1]), cols[2])
        for j in range(3):
            np.maximum(cols[j], 0.0, out=bb[:, j])
        bb /= ((bb[:, 0] + bb[:, 1]) + bb[:, 2])[:, None]
        pixel[n_out:n_out + k, 0] = x
        pixel[n_out:n_out + k, 1] = y
        n_out += k
        sl = slice(y0 * width, y1 * width)
        triangle[sl] = best
        other_tri[sl] = other
        contested[sl] = strict_claims >= 2
        # Within rounding of an edge: another triangle may take the texel, or (an island
        # border) Cycles finds the sample outside its triangle and moves it
        # (bake_jitter_barycentric).
        edge = (near_claims >= 2) & (strict_claims < 2) & (best >= 0)
        edge[cov] |= lowest <= tol[tc]
        on_edge[sl] = edge
    return TexelData(mesh=mesh, uv_map=uv_map, width=width, height=height,
                     triangle=triangle.reshape(height, width), pixel=pixel[:n_out],
                     barycentric=bary_out[:n_out],
                     facts=facts, uv_offset=tuple(float(o) for o in uv_offset),
                     contested=contested.reshape(height, width),
                     other_triangle=other_tri.reshape(height, width),
                     on_edge=on_edge.reshape(height, width))


_LOADED = []


def load_compiled():
    """Load (or, once per machine, compile) the compiled kernels before any timing, the way a
    process imports its libraries: a tiny rasterisation and interpolation of every type the
    real ones use. Returns the seconds it took (0 when kernels are off or already loaded)."""
    if not compiled.enabled() or _LOADED:
        return 0.0
    import time
    t0 = time.perf_counter()
    tri = MeshArrays(positions=np.eye(3), triangles=np.array([[0, 1, 2]]),
                     corner_normals=np.tile([0.0, 0.0, 1.0], (1, 3, 1)),
                     uv_maps={"UV": np.array([[[0.1, 0.1], [0.9, 0.1], [0.1, 0.9]]])})
    td = rasterize(tri, "UV", 4, 4)
    block = td.block(0, td.texel_count)
    block.position
    block.shading_normal
    td.pixel
    td.uv()
    for hook in compiled.LOADERS:
        hook()
    _LOADED.append(True)
    return time.perf_counter() - t0


def _rasterize_compiled(mesh, uv_map, width, height, facts, uv_offset, coef, tol, lo, hi,
                        counts):
    """rasterize's spans and band loop as two compiled passes (raster_kernels): the scan of
    every triangle's rows, then the flags and the covered texels per row. The texels' (x, y)
    and barycentrics are left to the blocks (TexelData.row_start): identical values, and
    memory of the triangle image, not of every texel's attributes."""
    npx = width * height
    triangle = np.full(npx, -1, dtype=np.int32)
    other_tri = np.full(npx, -1, dtype=np.int32)
    near = np.zeros(npx, dtype=np.uint8)
    strict = np.zeros(npx, dtype=np.uint8)
    cx, cy, cc = (np.ascontiguousarray(coef[:, :, j].T) for j in range(3))
    tol = np.ascontiguousarray(tol, dtype=np.float64)
    raster_kernels.scan_triangles(cx, cy, cc, tol, np.maximum(tol, 1e-12),
                                  np.ascontiguousarray(lo), np.ascontiguousarray(hi), counts,
                                  width, triangle, other_tri, near, strict)
    on_edge = np.zeros(npx, dtype=bool)
    row_count = np.zeros(height, dtype=np.int64)
    contested = np.empty(npx, dtype=bool)
    raster_kernels.texel_flags(triangle, near, strict, cx, cy, cc, tol, width, row_count,
                               contested, on_edge)
    row_start = np.zeros(height + 1, dtype=np.int64)
    np.cumsum(row_count, out=row_start[1:])
    return TexelData(mesh=mesh, uv_map=uv_map, width=width, height=height,
                     triangle=triangle.reshape(height, width), facts=facts,
                     uv_offset=tuple(float(o) for o in uv_offset),
                     contested=contested.reshape(height, width),
                     other_triangle=other_tri.reshape(height, width),
                     on_edge=on_edge.reshape(height, width), row_start=row_start,
                     _shared={"raster_coefficients": (cx, cy, cc)})


def _row_spans(coef, lo, hi, counts, tol):
    """Per (triangle, row) the x range [x0, x1] (inclusive, within the triangle's texel bounds)
    that holds every texel with all three barycentrics >= -tol, plus one texel each side.
    Returns (t, y, x0, x1) sorted by row, triangles ascending within a row; empty spans
    dropped."""
    tris = np.nonzero(counts)[0]
    rows = hi[tris, 1] - lo[tris, 1] + 1
    t = np.repeat(tris, rows)
    y = np.repeat(lo[tris, 1] - np.cumsum(rows) + rows, rows) + np.arange(rows.sum())
    x0 = lo[t, 0].astype(np.float64)
    x1 = hi[t, 0].astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for k in range(3):
            a = coef[t, k, 0]
            # a x + c >= -tol  <=>  x >= (-tol - c) / a for a > 0, x <= it for a < 0.
            bound = (-tol[t] - (coef[t, k, 1] * y + coef[t, k, 2])) / a
            x0 = np.where(a > 0, np.maximum(x0, np.floor(bound) - 1), x0)
            x1 = np.where(a < 0, np.minimum(x1, np.ceil(bound) + 1), x1)
    x0 = np.maximum(x0, lo[t, 0])
    x1 = np.minimum(x1, hi[t, 0])
    keep = x1 >= x0         # compared as floats: a sliver's huge bound must not wrap as int64
    x0, x1 = x0.astype(np.int64), x1.astype(np.int64)
    t, y, x0, x1 = t[keep], y[keep], x0[keep], x1[keep]
    order = np.argsort(y, kind="stable")
    return t[order], y[order], x0[order], x1[order]


def _barycentric_coefficients(a, b, c, area):
    """(T, 3, 3): barycentric k of texel (x, y) is coef[:, k, 0] x + coef[:, k, 1] y +
    coef[:, k, 2]. Signed sub-triangle areas over the signed area, so the inside test holds for
    clockwise and counter-clockwise (mirrored) UVs alike."""
    safe = np.where(area == 0, 1.0, area)
    rows = []
    for p0, p1 in ((b, c), (c, a), (a, b)):     # the edge opposite each corner
        ex, ey = p1[:, 0] - p0[:, 0], p1[:, 1] - p0[:, 1]
        rows.append(np.stack([-ey, ex, ey * p0[:, 0] - ex * p0[:, 1]], axis=1) / safe[:, None])
    return np.stack(rows, axis=1)
