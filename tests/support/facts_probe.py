"""Helpers for tests/test_blender_facts.py: small triangle meshes in bpy, their arrays for the
numpy reference, shader-graph builders, and numpy models of what Cycles computes in a bake.

Builds on support/bake_probe (scene set-up for exact EMIT bakes, float images, EmissionProbe).
Everything numpy here is float64 and independent of bpy except `mesh_arrays`, which reads a
bpy mesh into a `surfgrad_addon.reference.MeshArrays`.

The bake model (read from the Cycles kernels in the bpy wheels and pinned by the tests, on
every line; LINE holds the running line's facts, surfgrad_addon.reference.blender_lines):
- Blender's bake rasteriser hands Cycles barycentric differentials: HALF the per-texel ones up
  to 5.0, whole texels in 5.2 (that code is not in the wheels; the factor is pinned by the
  image-bump bakes and test_line_facts.py, where the other line's r is degrees off).
- integrator/init_from_bake.h turns them into world dP.dx, dP.dy and compacts them into one
  radius `r = 0.5 * (|dP.dx| + |dP.dy|)` (util/differential.h `differential_make_compact`),
  so r = k (|dP/ds| / W + |dP/dt| / H), k = 0.25 up to 5.0 and 0.5 in 5.2.
- The shading point expands r back into the isotropic pair `r * make_orthonormals(Ng)`
  (`differential_from_compact`): dPdx = r a, dPdy = r (Ng x a) with a = normalize((1,1,1) x Ng),
  directions in the triangle's plane that know nothing of the texel axes.
- Shifted copies of a Bump node's Height graph see P + fw * dPdx (P + fw * dPdy) and every
  triangle attribute at f + fw * df/dx (df/dy), i.e. the attribute at the shifted point: for
  attributes linear on the triangle (UVs) exactly.
- svm_node_set_bump (svm/displace.h): Rx = dPdy x N, Ry = N x dPdx, det = dPdx . Rx,
  n = normalize(fw * |det| * N - D * sign(det) * ((h_x - h_c) Rx + (h_y - h_c) Ry)),
  then normalize(Strength * n + (1 - Strength) * N).
- Shading normals: see `shading_normal` (a single-user mesh has its transform applied, so
  vertex normals are normalised in WORLD space before interpolation; 5.2 stores them
  octahedral-encoded in 2 x 16 bits); the Normal Map and Tangent nodes: `cycles_normal_map`,
  `cycles_tangent_node` (object-space frame, taken to world by the normal matrix; the frame's
  normal is unnormalised up to 5.0 and unit in 5.2).
"""

import numpy as np

from surfgrad_addon.reference.cycles_bake import bump_differentials, make_orthonormals, uv_step  # noqa: E402,F401

import bpy

from support import bake_probe as base
from surfgrad_addon.reference import MeshArrays
from surfgrad_addon.reference import rasterize as _rasterize
from surfgrad_addon.reference.blender_lines import facts_for, octahedral_unit_vectors
from surfgrad_addon.reference.image_sampling import sample_image

LINE = facts_for(bpy.app.version)


def rasterize(mesh, uv_map, width, height, **kw):
    """The reference's rasteriser with the running line's facts."""
    return _rasterize(mesh, uv_map, width, height, facts=kw.pop("facts", LINE), **kw)


def stored_normals(unit_normals, line=None):
    """Unit normals as the line's Cycles stores them (5.2: octahedral 2 x 16 bits)."""
    line = line or LINE
    return octahedral_unit_vectors(unit_normals) if line.packed_normals else unit_normals


def stored_world_normals(m, line=None):
    """Corner normals of a mesh with its transform applied, as stored: object normals stored,
    then decoded, taken to world by the normal matrix, normalised and stored again."""
    n = stored_normals(_normalize(np.asarray(m.corner_normals, np.float64)), line)
    return stored_normals(_normalize(n @ m.normal_matrix.T), line)

DETAIL_ROTATION_DEG = 30.0
DETAIL_TILING = 2.0


# ------------------------------------------------------------------------------------------
# numpy geometry

def _normalize(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _dot(a, b):
    return np.sum(a * b, axis=-1, keepdims=True)


def detail_uv(uv):
    """A second unwrap: the first rotated 30 degrees about (0.5, 0.5) and tiled twice."""
    a = np.radians(DETAIL_ROTATION_DEG)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return ((np.asarray(uv) - 0.5) @ rot.T) * DETAIL_TILING + 0.5


def sphere_mesh_data(segments=16, rings=8, radius=1.0):
    """A lat-long sphere made of triangles only, with shared vertices (one per pole, none
    duplicated on the seam) so that smooth vertex normals are continuous.

    Returns (positions (V, 3), triangles (T, 3) vertex indices, corner_uv (T, 3, 2)): u runs
    around the equator in [0, 1], v from the south (0) to the north pole (1); a pole corner
    sits at the middle u of its triangle."""
    verts = [(0.0, 0.0, -radius)]
    for k in range(1, rings):
        theta = np.pi * (k / rings - 0.5)
        for j in range(segments):
            phi = 2 * np.pi * j / segments
            verts.append((radius * np.cos(theta) * np.cos(phi),
                          radius * np.cos(theta) * np.sin(phi), radius * np.sin(theta)))
    north = len(verts)
    verts.append((0.0, 0.0, radius))

    def vid(k, j):                      # ring k in 1..rings-1, column j (wrapped)
        return 1 + (k - 1) * segments + (j % segments)

    tris, uvs = [], []
    for j in range(segments):
        u0, u1, um = j / segments, (j + 1) / segments, (j + 0.5) / segments
        # south fan, counter-clockwise seen from outside
        tris.append((0, vid(1, j + 1), vid(1, j)))
        uvs.append(((um, 0.0), (u1, 1 / rings), (u0, 1 / rings)))
        for k in range(1, rings - 1):
            t0, t1 = k / rings, (k + 1) / rings
            a, b, c, d = vid(k, j), vid(k, j + 1), vid(k + 1, j + 1), vid(k + 1, j)
            tris.append((a, b, c))
            uvs.append(((u0, t0), (u1, t0), (u1, t1)))
            tris.append((a, c, d))
            uvs.append(((u0, t0), (u1, t1), (u0, t1)))
        tris.append((vid(rings - 1, j), vid(rings - 1, j + 1), north))
        uvs.append(((u0, (rings - 1) / rings), (u1, (rings - 1) / rings), (um, 1.0)))
    return np.array(verts), np.array(tris), np.array(uvs)


def plane_mesh_data(size=2.0, n=4):
    """An n x n grid of the square [-size/2, size/2]^2 (z = 0, normal +Z) in triangles, UVs
    covering [0, 1]^2."""
    s = np.linspace(0.0, 1.0, n + 1)
    ss, tt = np.meshgrid(s, s)
    pos = np.stack([(ss - 0.5) * size, (tt - 0.5) * size, 0 * ss], -1).reshape(-1, 3)
    uv = np.stack([ss, tt], -1).reshape(-1, 2)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    d, c = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return pos, tris, uv[tris]


def trs_matrix(location=(0, 0, 0), euler_xyz_deg=(0, 0, 0), scale=(1, 1, 1)):
    """4x4 T @ Rz @ Ry @ Rx @ S, Blender's XYZ Euler order."""
    ax, ay, az = np.radians(euler_xyz_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    m = np.eye(4)
    m[:3, :3] = rz @ ry @ rx @ np.diag(scale)
    m[:3, 3] = location
    return m


# ------------------------------------------------------------------------------------------
# bpy meshes

def add_mesh_object(name, positions, triangles, corner_uv, smooth=True, matrix_world=None,
                    extra_uv_maps=None):
    """Link a triangle mesh into the scene. corner_uv (T, 3, 2) becomes "UVMap" (active for
    baking and rendering); extra_uv_maps {name: (T, 3, 2)} are added after it."""
    bpy = base.bpy
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, p)) for p in positions], [],
                     [tuple(map(int, t)) for t in triangles])
    maps = {"UVMap": np.asarray(corner_uv)}
    maps.update(extra_uv_maps or {})
    for uv_name, uv in maps.items():
        layer = mesh.uv_layers.new(name=uv_name)
        layer.data.foreach_set("uv", np.asarray(uv, dtype=np.float32).reshape(-1))
    mesh.uv_layers["UVMap"].active = True
    mesh.uv_layers["UVMap"].active_render = True
    mesh.polygons.foreach_set("use_smooth", [bool(smooth)] * len(mesh.polygons))
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    if matrix_world is not None:
        from mathutils import Matrix  # noqa: PLC0415 (bpy's own module)
        obj.matrix_world = Matrix([list(map(float, r)) for r in matrix_world])
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.context.view_layer.update()
    return obj


def add_sphere(name="Sphere", matrix_world=None, smooth=True, segments=16, rings=8):
    pos, tris, uv = sphere_mesh_data(segments, rings)
    return add_mesh_object(name, pos, tris, uv, smooth, matrix_world,
                           {"Detail": detail_uv(uv)})


def add_plane(name="Plane", matrix_world=None, smooth=True, n=4):
    pos, tris, uv = plane_mesh_data(n=n)
    return add_mesh_object(name, pos, tris, uv, smooth, matrix_world,
                           {"Detail": detail_uv(uv)})


def mesh_arrays(obj, tangent_maps=("UVMap",)):
    """Read a bpy mesh object into MeshArrays: object-space positions, loop triangles, corner
    (split) normals, every UV map per triangle corner, MikkTSpace tangents and bitangent signs
    of `tangent_maps` (Mesh.calc_tangents), and matrix_world."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    nt = len(mesh.loop_triangles)
    loops = np.empty(nt * 3, np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    loops = loops.reshape(nt, 3)
    tris = np.empty(nt * 3, np.int64)
    mesh.loop_triangles.foreach_get("vertices", tris)
    pos = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", pos)
    cn = np.empty(len(mesh.loops) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", cn)
    cn = cn.reshape(-1, 3)
    uv_maps = {}
    for layer in mesh.uv_layers:
        uv = np.empty(len(mesh.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        uv_maps[layer.name] = uv.reshape(-1, 2)[loops].astype(np.float64)
    tangents, signs = {}, {}
    for name in tangent_maps:
        mesh.calc_tangents(uvmap=name)
        t = np.empty(len(mesh.loops) * 3, np.float32)
        mesh.loops.foreach_get("tangent", t)
        s = np.empty(len(mesh.loops), np.float32)
        mesh.loops.foreach_get("bitangent_sign", s)
        tangents[name] = t.reshape(-1, 3)[loops].astype(np.float64)
        signs[name] = s[loops].astype(np.float64)
    mesh.free_tangents()
    mw = np.array([list(r) for r in obj.matrix_world], dtype=np.float64)
    return MeshArrays(positions=pos.reshape(-1, 3).astype(np.float64),
                      triangles=tris.reshape(nt, 3), corner_normals=cn[loops].astype(np.float64),
                      uv_maps=uv_maps, tangents=tangents, tangent_signs=signs,
                      matrix_world=mw, name=obj.name).validate()


# ------------------------------------------------------------------------------------------
# numpy expectations

def shading_normal(td, smooth=True, transform_applied=True, line=None):
    """Cycles' sd->N at each texel, world space. Flat: the geometric normal. Smooth: the
    interpolated vertex normal, normalised. Cycles bakes a single-user mesh with its object
    transform APPLIED: each corner normal goes to world space by the normal matrix and is
    normalised BEFORE the interpolation, which under a non-uniform scale tilts the result by
    degrees against interpolating in object space (td.normal, transform_applied=False, what an
    instanced mesh gets)."""
    if not smooth:
        return td.geometric_normal
    m = td.mesh
    if not transform_applied:
        n = stored_normals(_normalize(np.asarray(m.corner_normals, np.float64)), line)
        return _normalize(td._interpolate(n) @ m.normal_matrix.T)
    return _normalize(td._interpolate(stored_world_normals(m, line)))


def triangle_edges(td):
    """World edge vectors P1 - P0, P2 - P0 of each texel's triangle."""
    p = td.mesh.corner_positions_world[td.tri]
    return p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]


def linear_surface_gradient(td, corner_values, n):
    """The surface gradient, relative to the normal n, of a scalar that is linear on each
    triangle with the given corner values (T, 3): the vector g with g . n = 0 and g . v equal
    to the scalar's change along v for every v in the triangle's plane:
        g = (df1 (e2 x n) + df2 (n x e1)) / (e1 . (e2 x n)).
    For the UV map's s this is the gs with gs . dP/ds = 1, gs . dP/dt = 0."""
    f = np.asarray(corner_values, dtype=np.float64)[td.tri]
    e1, e2 = triangle_edges(td)
    df1, df2 = f[:, 1:2] - f[:, 0:1], f[:, 2:3] - f[:, 0:1]
    r1, r2 = np.cross(e2, n), np.cross(n, e1)
    return (df1 * r1 + df2 * r2) / _dot(e1, r1)


def uv_surface_gradients(td, n, name=None):
    """(gs, gt): surface gradients of a UV map's s and t, relative to the normal n."""
    uv = td.mesh.uv(name or td.uv_map)
    return (linear_surface_gradient(td, uv[..., 0], n),
            linear_surface_gradient(td, uv[..., 1], n))


def _object_frame(td, name, smooth, line=None):
    """What Cycles' Normal Map node works in (object space): the interpolated, UNnormalised
    MikkTSpace tangent and sign of UV map `name`, and the normal: smooth, up to 5.0 the
    UNnormalised interpolation of the unit object-space vertex normals, in 5.2 the stored
    world normals taken back to object space (each normalised), interpolated and normalised;
    flat, the unit geometric normal."""
    line = line or LINE
    m = td.mesh
    t = td._interpolate(m.tangents[name])
    sign = td._interpolate(m.tangent_signs[name])
    if smooth and line.normal_map_unit_normal:
        world = stored_world_normals(m, line)
        m3 = np.asarray(m.matrix_world, np.float64)[:3, :3]
        n = _normalize(td._interpolate(_normalize(world @ m3)))
    elif smooth:
        n = td._interpolate(_normalize(np.asarray(m.corner_normals, np.float64)))
    else:
        p = np.asarray(m.positions, np.float64)[np.asarray(m.triangles)]
        n = _normalize(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))[td.tri]
    return t, sign, n


def cycles_normal_map(td, color, name=None, smooth=True, strength=1.0, line=None):
    """svm_node_normal_map, tangent space (svm/tex_coord.h), for a constant colour:
    c = 2 colour - 1 (xy scaled by strength, z = mix(1, z, saturate(strength))),
    B = sign * cross(N, T) and normalize(c.x T + c.y B + c.z N) in OBJECT space with the
    unnormalised frame of `_object_frame`, then to world by the NORMAL matrix (inverse
    transpose), normalised."""
    t, sign, n = _object_frame(td, name or td.uv_map, smooth, line)
    c = 2.0 * (np.asarray(color, np.float64)[:3] - 0.5)
    c = np.array([c[0] * strength, c[1] * strength,
                  1.0 + (c[2] - 1.0) * min(max(strength, 0.0), 1.0)])
    b = sign[:, None] * np.cross(n, t)
    v = _normalize(c[0] * t + c[1] * b + c[2] * n)
    return _normalize(v @ td.mesh.normal_matrix.T)


def cycles_tangent_node(td, name=None, smooth=True):
    """svm_node_tangent, UV-map direction: the interpolated MikkTSpace tangent (no sign) taken
    to world by the NORMAL matrix, then cross(N, normalize(cross(T, N))) with the shading
    normal N: projected onto N's plane, unit length."""
    t, _, _ = _object_frame(td, name or td.uv_map, smooth)
    tw = _normalize(t @ td.mesh.normal_matrix.T)
    n = shading_normal(td, smooth)
    return np.cross(n, _normalize(np.cross(tw, n)))


# The bake's differentials live in the reference (reference/cycles_bake.py); the tests here
# pin them against real bakes.
cycles_bake_bump_differentials = bump_differentials


def cycles_bump_normal(n, dpdx, dpdy, h_c, h_x, h_y, distance=1.0, filter_width=0.1,
                       strength=1.0, invert=False):
    """svm_node_set_bump (svm/displace.h) in float64: Rx = dPdy x N, Ry = N x dPdx,
    det = dPdx . Rx, n' = normalize(fw |det| N - D sign(det) ((h_x - h_c) Rx + (h_y - h_c) Ry)),
    then normalize(strength n' + (1 - strength) N). h_* are (N,) heights."""
    n = np.asarray(n, dtype=np.float64)
    d = -distance if invert else distance
    rx, ry = np.cross(dpdy, n), np.cross(n, dpdx)
    det = _dot(dpdx, rx)
    sg = (np.asarray(h_x) - h_c)[:, None] * rx + (np.asarray(h_y) - h_c)[:, None] * ry
    out = _normalize(filter_width * np.abs(det) * n - d * np.sign(det) * sg)
    strength = max(strength, 0.0)
    return _normalize(strength * out + (1.0 - strength) * n)


def cycles_bake_bump_image(td, image, filter_width=1.0, distance=1.0, smooth=True,
                           interpolation="Linear", extension="REPEAT", uv_name=None):
    """The Bump node's output in a Cycles bake when Height = Image Texture(image) at UV map
    `uv_name` (Normal unlinked: the shading normal). image (H, W) heights."""
    name = uv_name or td.uv_map
    filter_width = LINE.bump_step_scale(filter_width)     # 4.2: no Filter Width, one step
    dpdx, dpdy = cycles_bake_bump_differentials(td)
    uv = td.uv(name)
    h = lambda st: sample_image(image, st, interpolation, extension)  # noqa: E731
    h_c = h(uv)
    h_x = h(uv + filter_width * uv_step(td, dpdx, name))
    h_y = h(uv + filter_width * uv_step(td, dpdy, name))
    return cycles_bump_normal(shading_normal(td, smooth), dpdx, dpdy, h_c, h_x, h_y,
                              distance, filter_width)


def angle_deg(a, b):
    """Angle between vectors (N,) in degrees, robust near zero."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    c = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(c, np.sum(a * b, axis=-1)))


def texels(td, img):
    """The baked values (N, C) of the covered texels of img (H, W, C), in td's texel order."""
    return np.asarray(img)[td.pixel[:, 1], td.pixel[:, 0]].astype(np.float64)


def rasterize_object(obj, width, height, tangent_maps=("UVMap",)):
    return rasterize(mesh_arrays(obj, tangent_maps), "UVMap", width, height)


# ------------------------------------------------------------------------------------------
# shader graphs

class Graph(base.EmissionProbe):
    """EmissionProbe with a few more builders."""

    def geometry(self):
        if not hasattr(self, "_geo"):
            self._geo = self.node("ShaderNodeNewGeometry")
        return self._geo

    def texcoord(self):
        if not hasattr(self, "_tc"):
            self._tc = self.node("ShaderNodeTexCoord")
        return self._tc

    def uv_map_node(self, name):
        return self.node("ShaderNodeUVMap", uv_map=name).outputs["UV"]

    def attribute(self, name, output="Vector"):
        return self.node("ShaderNodeAttribute", attribute_type="GEOMETRY",
                         attribute_name=name).outputs[output]

    def bump(self, height=None, normal=None, distance=1.0, filter_width=0.1, strength=1.0):
        b = self.node("ShaderNodeBump")
        b.inputs["Strength"].default_value = strength
        b.inputs["Distance"].default_value = distance
        if "Filter Width" in b.inputs:      # 4.4 and later; 4.2 steps one differential
            b.inputs["Filter Width"].default_value = filter_width
        if height is not None:
            self.links.new(height, b.inputs["Height"])
        if normal is not None:
            self.links.new(normal, b.inputs["Normal"])
        return b.outputs["Normal"]

    def inverted_bump_gradient(self, height, distance=1.0, filter_width=0.1, normal=None):
        """g = (N - n / (n . N)) / D with n the Bump output for Height `height`, Strength 1,
        Normal N (default: the Geometry node's Normal, i.e. the shading normal)."""
        if normal is None:
            normal = self.geometry().outputs["Normal"]
        n = self.bump(height, normal, distance, filter_width)
        k = self.math("DIVIDE", 1.0, self.dot(n, normal))
        scaled = self.vmath("SCALE", n)
        self.links.new(k, scaled.node.inputs["Scale"])
        diff = self.vmath("SUBTRACT", normal, scaled)
        out = self.vmath("SCALE", diff)
        out.node.inputs["Scale"].default_value = 1.0 / distance
        return out
