"""A Blender mesh object as the reference's MeshArrays: what Cycles sees, as plain arrays.

The mesh as Cycles renders and bakes it (modifiers evaluated in RENDER mode:
addon/render_mesh.py) is triangulated with Blender's own loop triangles;
per-corner normals are the normals Cycles shades with (cycles_normals: corner, vertex or
per-triangle normals by the line's rule); tangents and signs are MikkTSpace for every UV map,
computed on the triangles with those normals as Cycles does.
"""

import numpy as np

from ..addon.bake_target import object_not_a_mesh
from ..addon.bake_uvs import no_faces_problem, not_rendered_problem
from ..addon.cycles_geometry import transform_applied
from ..addon.node_builder import running_line
from ..reference.blender_lines import octahedral_unit_vectors
from ..reference.raster import MeshArrays
from ..reference.vecmath import cross, normalize
from .flat_welds import unsure_welds
from .free_normal_fans import has_free_corner_normals, last_written_normals
from .weld_fans import fan_mesh, normal_classes


# How far Blender 4.2's encoded custom normals decode from the normal set on well-formed fans
# (measured up to 1.2e-3 on per-corner jitter): a joined fan decoding within it is as good.
DECODE_RESOLUTION = 2e-3


class MeshDataError(ValueError):
    """The object cannot be baked as asked; the message names the object and the fix."""


def _get(collection, attr, count, width, dtype=np.float64):
    out = np.empty(count * width, dtype=dtype)
    collection.foreach_get(attr, out)
    return out.reshape(count, width) if width > 1 else out


def flat_triangles(mesh, nt=None):
    """(T,) True where a loop triangle's face is shaded flat."""
    nt = len(mesh.loop_triangles) if nt is None else nt
    return ~_get(mesh.loop_triangles, "use_smooth", nt, 1, bool)


def cycles_normals(mesh, positions, tri_loops, tri_verts, facts):
    """((T, 3, 3) the normals Cycles shades each triangle corner with
    (LineFacts.sharp_faces_give_corner_normals): corner normals, vertex normals for smooth
    faces, or the triangle's own geometric normal for flat ones; (T,) True where Cycles takes
    the triangle as flat, so MikkTSpace sees its own normal there
    (LineFacts.corner_normals_keep_flat_faces))."""
    nl, nv, nt = len(mesh.loops), len(mesh.vertices), len(tri_loops)
    corner = _get(mesh.corner_normals, "vector", nl, 3)[tri_loops]
    domain = mesh.normals_domain
    if domain == "CORNER":
        sharp_edge = mesh.attributes.get("sharp_edge")
        has_sharp_edges = sharp_edge is not None and sharp_edge.domain == "EDGE" and bool(
            _get(sharp_edge.data, "value", len(mesh.edges), 1, bool).any())
        if (facts.sharp_faces_give_corner_normals or mesh.has_custom_normals
                or has_sharp_edges):
            flat = flat_triangles(mesh, nt) if facts.corner_normals_keep_flat_faces else \
                np.zeros(nt, dtype=bool)
            if not facts.free_corner_normals_split and (has_free_corner_normals(mesh)
                                                        or mesh.has_custom_normals):
                corner = last_written_normals(mesh, tri_loops)
            return corner, flat
    flat = flat_triangles(mesh, nt)
    if domain == "FACE":
        # Free custom normals on the faces (a FACE 'custom_normal', 4.5 and later) are not
        # Cycles' normals: it reads corner normals only for the CORNER domain, else Blender's
        # vertex normals for faces marked smooth, and with no 'sharp_face' attribute at all
        # it makes every face of a FACE-domain mesh flat (cycles/blender/mesh.cc
        # create_mesh). Before, a correct SG Normal Map scored p99 20 / max 23 deg there.
        if mesh.attributes.get("sharp_face") is None:
            flat[:] = True
        corner = _get(mesh.vertex_normals, "vector", nv, 3)[tri_verts]
    if not flat.any():
        return corner, flat
    p = positions[tri_verts]
    with np.errstate(invalid="ignore", divide="ignore"):
        tri_normal = normalize(cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
    # A triangle without area: (1, 0, 0), as Cycles' Mesh::Triangle::compute_normal gives it
    # (compare leaves its texels out: harness/compare.degenerate_triangles).
    tri_normal[~np.isfinite(tri_normal).all(axis=1)] = (1.0, 0.0, 0.0)
    # Per-vertex normals (custom ones included) are the corner normals of a POINT domain.
    vertex = corner if domain == "POINT" else \
        _get(mesh.vertex_normals, "vector", nv, 3)[tri_verts]
    return np.where(flat[:, None, None], tri_normal[:, None, :], vertex), flat


def _mikktspace_normals(corner_normals, packed_normals):
    """The corner normals Cycles hands MikkTSpace. 5.2 (`packed_normals`) reads its stored
    normals, octahedral-packed and decoded: unit, and corners of one direction bitwise equal
    whatever length free normals were set with (a Set Mesh Normal node fed an unnormalised
    vector), so MikkTSpace welds them (measured on 5.2: a correct SG Normal Map at p99 1.55 /
    max 3.28 deg with the raw normals, 0.35 / 0.54 with each normalised, where corners of a
    vertex differ in length only). Up to 5.0 MikkTSpace reads Cycles' vertex normal attribute
    as Blender gave it, lengths and all (measured on 4.5 and 5.0: p99 1.6 / max 2.8 deg with
    unit normals, 0.0006 / 0.0015 with these)."""
    if not packed_normals:
        return corner_normals
    return octahedral_unit_vectors(corner_normals)


def mesh_arrays_from_object(obj, depsgraph=None, need_tangents=True, facts=None):
    """MeshArrays of `obj` (evaluated, world matrix included), as the running line's Cycles
    (or `facts`' line) sees it. Without `depsgraph` the object is evaluated as Cycles renders
    and bakes it, in RENDER mode (render_mesh.read_in_render_mode: Subdivision's Render levels,
    modifiers shown in renders only, Geometry Nodes' Is Viewport false); a given depsgraph is
    used as it is. Raises MeshDataError for an object without mesh data, faces or UV maps."""
    if obj is None:
        raise MeshDataError("no object given")
    if obj.type != "MESH":
        raise MeshDataError(object_not_a_mesh(obj))
    facts = facts or running_line()
    if depsgraph is None:
        from ..addon.render_mesh import read_in_render_mode
        arrays, flat = read_in_render_mode(obj, lambda dg: _evaluated_arrays(obj, dg, facts))
    else:
        arrays, flat = _evaluated_arrays(obj, depsgraph, facts)
    if need_tangents:
        arrays.tangents, arrays.tangent_signs, arrays.unsure_welds = triangle_mikktspace(
            arrays, flat, packed_normals=facts.packed_normals,
            normal_divides=facts.triangle_normal_divides)
    return arrays


def _evaluated_arrays(obj, depsgraph, facts):
    """(MeshArrays without tangents, flat triangles (T,)) of obj evaluated in `depsgraph`."""
    eval_obj = obj.evaluated_get(depsgraph)
    if not eval_obj.is_evaluated:
        raise MeshDataError(f"object {obj.name!r} is not part of what Cycles renders (its "
                            f"collection is disabled for renders, or it is in no view layer "
                            f"of this scene); enable it for renders")
    mesh = eval_obj.to_mesh()
    try:
        if len(mesh.polygons) == 0:
            raise MeshDataError(no_faces_problem(obj, 0) or
                                f"object {obj.name!r} has no faces to bake; add geometry")
        if len(mesh.uv_layers) == 0 and len(obj.data.uv_layers):
            raise MeshDataError(not_rendered_problem(obj.name, obj.data.uv_layers[0].name, [],
                                                     obj))
        if len(mesh.uv_layers) == 0:
            raise MeshDataError(f"object {obj.name!r} has no UV map; add one (UV > Unwrap) "
                                f"before baking")
        mesh.calc_loop_triangles()
        nv, nl, nt = len(mesh.vertices), len(mesh.loops), len(mesh.loop_triangles)
        positions = _get(mesh.vertices, "co", nv, 3)
        tri_loops = _get(mesh.loop_triangles, "loops", nt, 3, np.int64)
        tri_verts = _get(mesh.loop_triangles, "vertices", nt, 3, np.int64)
        # As Blender gives them (free normals keep their length): the texels normalise where
        # Cycles does (TexelData.shading_normal, normal_map_normal_corners).
        corner_normals, flat = cycles_normals(mesh, positions, tri_loops, tri_verts, facts)
        triangle_faces = _get(mesh.loop_triangles, "polygon_index", nt, 1, np.int64)
        names = [layer.name for layer in mesh.uv_layers]
        uv_maps = {name: _get(mesh.uv_layers[name].uv, "vector", nl, 2)[tri_loops]
                   for name in names}
        # Vector point attributes (e.g. SG Displace's rest position) for methods that read them.
        point_attributes = {}
        for attr in mesh.attributes:
            if (attr.domain == "POINT" and attr.data_type == "FLOAT_VECTOR"
                    and not attr.name.startswith(".") and attr.name != "position"):
                point_attributes[attr.name] = _get(attr.data, "vector", nv, 3)
        matrix = np.array(eval_obj.matrix_world, dtype=np.float64)
        # Cycles applies the object transform to geometry used by one object only
        # (addon/cycles_geometry.py: by the object when modified, else by the mesh).
        arrays = MeshArrays(positions=positions, triangles=tri_verts,
                            corner_normals=corner_normals, uv_maps=uv_maps,
                            matrix_world=matrix, name=obj.name,
                            transform_applied=transform_applied(obj, depsgraph),
                            point_attributes=point_attributes,
                            triangle_faces=triangle_faces).validate()
    finally:
        eval_obj.to_mesh_clear()
    return arrays, flat


def triangle_mikktspace(arrays, flat=None, packed_normals=True, normal_divides=True):
    """MikkTSpace tangents and signs per triangle corner for every UV map, computed as Cycles
    does: on the triangulated mesh (Cycles' own triangles) with the corner normals: with
    `packed_normals` (5.2) as Cycles stores them, octahedral-packed and decoded (unit), up to
    5.0 as Blender gives them (cycles/scene/mesh.cpp, MikkMeshWrapper::GetNormal). Blender's
    calc_tangents on the original quads splits some quads differently (their UV diagonals tie)
    and can differ by degrees. Triangles in `flat` (T,) are flat faces of the temporary mesh
    without custom normals, so MikkTSpace sees each one's own float32 triangle normal as
    Cycles' does (`normal_divides`: cycles_triangle_normals) (as custom normals they would be quantised, nearly coplanar neighbours would
    weld: up to 1.1 degrees; as the face's corner normals, a flat quad's normal, they were up
    to 33 degrees off on flat faces mixed with smooth ones). Works on a temporary mesh that is
    removed afterwards.

    MikkTSpace welds corners whose position, normal and UV are bitwise equal, as Cycles' does
    with the float normals it reads. Where the line stores free normals (a float
    "custom_normal" corner attribute, 4.5 and later) the temporary mesh gets them exactly.
    Without (4.2) custom normals are re-encoded in the temporary mesh's own normal spaces, one
    per smooth fan, so corners Cycles welds did not weld where its fans split them (measured:
    0.8 degrees of tangent on custom normals, 1.2 on a Mirror crossing its plane): there the
    mesh is weld_fans.fan_mesh, whose fans are the groups Cycles welds. There flat triangles
    carry Blender's face normal: the third value, {uv map: (T,) bool}, marks those whose welds
    may differ from Cycles' (flat_welds.unsure_welds; empty where the line has float normals)."""
    import bpy

    tmp = bpy.data.meshes.new(".surfgrad_tangents")
    try:
        tmp.from_pydata(arrays.positions.tolist(), [], arrays.triangles.tolist())
        flat = None if flat is None or not np.any(flat) else np.asarray(flat, dtype=bool)
        smooth = np.ones(len(tmp.polygons), dtype=bool) if flat is None else ~flat
        tmp.polygons.foreach_set("use_smooth", smooth)
        given = _mikktspace_normals(arrays.corner_normals, packed_normals)
        values = _intended_normals(given, flat, cycles_triangle_normals(
            arrays.positions, arrays.triangles, divides=normal_divides))
        # Read before any attribute is added: Blender then leaves polygon_normals zero.
        blender_values = _intended_normals(given, flat, _face_normals(tmp))
        extra, unsure = 0, {}
        if not _free_normals(tmp, values.reshape(-1)):
            # No float normals (4.2): encoded ones, on a mesh whose fans are the groups Cycles
            # welds where that decodes as well (weld_fans.py). A flat triangle keeps its own
            # face normal there, Blender's: no custom normal can carry Cycles' bits.
            values = blender_values
            if flat is not None:        # flat triangles weld by their own normals' bits
                cycles = cycles_triangle_normals(arrays.positions, arrays.triangles,
                                                 divides=normal_divides)
                unsure = {name: unsure_welds(arrays.triangles, uv, flat, blender_values[:, 0],
                                             cycles, arrays.positions)
                          for name, uv in arrays.uv_maps.items()}
            _encode_normals(tmp, values, ~smooth)
            tmp, extra = _with_welded_fans(bpy, tmp, arrays, values, smooth)
        # The extra triangles' UVs lie beyond every real one: MikkTSpace welds none of theirs.
        beyond = max([float(np.abs(uv).max()) for uv in arrays.uv_maps.values()] + [0.0]) + 8.0
        extra_uv = beyond + np.tile([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], (extra, 1)) + \
            np.repeat(np.arange(extra) * 2.0, 3)[:, None]
        for name, uv in arrays.uv_maps.items():
            # As an attribute: uv_layers.new makes at most 8 (it returned None for a ninth,
            # an importer's extra channel, and compare ended in a KeyError).
            tmp.attributes.new(name, "FLOAT2", "CORNER")
            tmp.uv_layers[name].uv.foreach_set(
                "vector", np.concatenate([uv.reshape(-1, 2), extra_uv]).reshape(-1))
        n = 3 * len(arrays.triangles)
        tangents, signs = {}, {}
        for name in arrays.uv_maps:
            try:
                tmp.calc_tangents(uvmap=name)
            except RuntimeError as err:
                raise MeshDataError(f"object {arrays.name!r}: MikkTSpace tangents for UV map "
                                    f"{name!r} failed ({err})") from err
            tangents[name] = _get(tmp.loops, "tangent", n + 3 * extra, 3)[:n].reshape(-1, 3, 3)
            signs[name] = _get(tmp.loops, "bitangent_sign", n + 3 * extra, 1)[:n].reshape(-1, 3)
        return tangents, signs, unsure
    finally:
        if tmp is not None:
            bpy.data.meshes.remove(tmp)


def _with_welded_fans(bpy, tmp, arrays, values, smooth):
    """(mesh, extra triangles): weld_fans.fan_mesh of the triangles with `values` encoded,
    where it differs from the plain mesh `tmp` (encoded already) and decodes no corner worse
    than it beyond DECODE_RESOLUTION (joining fans can put corners in a fan whose normal space
    Blender encodes badly: folded n-gon triangles, 0.7 deg), else tmp itself; the other mesh is
    removed."""
    made = fan_mesh(bpy, arrays.positions, arrays.triangles, values, ~smooth)
    if made is None:
        return tmp, 0
    fans, extra_tris, extra_normals = made
    try:
        flat = np.concatenate([~smooth, np.zeros(len(extra_tris), dtype=bool)])
        fans.polygons.foreach_set("use_smooth", ~flat)
        _encode_normals(fans, np.concatenate([values, extra_normals]), flat)
        n = values.size
        want = values.reshape(-1, 3).astype(np.float64)
        plain = np.linalg.norm(_get(tmp.corner_normals, "vector", n // 3, 3) - want, axis=1)
        joined = np.linalg.norm(_get(fans.corner_normals, "vector", len(fans.loops), 3)[:n // 3]
                                - want, axis=1)
    except BaseException:
        bpy.data.meshes.remove(fans)      # the caller removes tmp; leave no second mesh
        raise
    if np.all(joined <= np.maximum(plain, DECODE_RESOLUTION)):
        bpy.data.meshes.remove(tmp)
        return fans, len(extra_tris)
    bpy.data.meshes.remove(fans)
    return tmp, 0


def _intended_normals(corner_normals, flat, face_normals):
    """(T, 3, 3) float32: the corner normals MikkTSpace is to see on the temporary triangle
    mesh: the given ones, and on a flat triangle (`flat`, or None) `face_normals` (T, 3)."""
    values = np.asarray(corner_normals, dtype=np.float32)
    if flat is None:
        return values
    return np.where(flat[:, None, None], np.asarray(face_normals, dtype=np.float32)
                    .reshape(-1, 1, 3), values)


def _face_normals(tmp):
    """(T, 3) float32: Blender's face normal of each triangle of the temporary mesh `tmp`."""
    out = np.empty(len(tmp.polygons) * 3, dtype=np.float32)
    tmp.polygon_normals.foreach_get("vector", out)
    return out.reshape(-1, 3)


def cycles_triangle_normals(positions, triangles, divides=True):
    """(T, 3) float32: Cycles' Mesh::Triangle::compute_normal in its float32 operations,
    cross(v1 - v0, v2 - v0) scaled to unit length, (1, 0, 0) where that is 0: `divides` (5.2)
    divides by the length, up to 5.0 it multiplies by the length's reciprocal (Cycles' float3
    division there, one rounding more). MikkTSpace welds corners whose normals are bitwise
    equal, and Blender's face normal of a triangle (another formula) differs from either in
    the last bit on some: the two triangles of a flat quad then welded in one and not the
    other, and compare called a correct SG Normal Map up to 30 degrees wrong on a quad of
    castle-engine's chopper (red team 47c on 5.2, 48c on 5.0 and 4.5)."""
    p = np.asarray(positions, dtype=np.float32)[np.asarray(triangles, dtype=np.int64)]
    a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    n = np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                  a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                  a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)
    length = np.sqrt(n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        out = n / length[:, None] if divides else n * (np.float32(1.0) / length)[:, None]
    out[length == 0] = (1.0, 0.0, 0.0)
    return out.astype(np.float32)


def _encode_normals(tmp, values, flat):
    """Set `values` (T, 3, 3) as tmp's custom normals (lines without free normals): flat
    triangles get none (their face's own normal), the edges across which the normals differ
    are marked sharp first (_mark_normal_seams)."""
    custom = np.where(flat[:, None, None], 0.0, np.asarray(values, dtype=np.float64))
    _mark_normal_seams(tmp, np.asarray(values, dtype=np.float32).reshape(-1, 3))
    tmp.normals_split_custom_set(custom.reshape(-1, 3).tolist())


def _mark_normal_seams(tmp, values):
    """Mark sharp the edges of the temporary triangle mesh `tmp` across which the corner
    normals `values` (corners x 3, float32) differ at either end, before its custom normals are
    encoded (lines without free normals: 4.2). Blender encodes one normal per smooth fan, and on
    its own it splits a fan whose normals differ where its walk round the vertex happens to
    meet the difference, which can cut between the two triangles of one quad corner (one
    normal in Cycles, so welded there): measured on per-corner jitter, 28 of 256 welded groups
    split and the tangents 0.8 deg off. With these edges sharp every fan holds one normal and
    corners of equal normals across a smooth edge stay in one fan, so they decode bitwise
    equal and weld as Cycles' do (the decoded value is still the encoding's, within ~1e-3 of
    Cycles' float). Fans split at non-manifold edges still decode apart: no edge flag joins them."""
    nl = len(tmp.loops)
    corner_vert = np.empty(nl, dtype=np.int64)
    corner_edge = np.empty(nl, dtype=np.int64)
    tmp.loops.foreach_get("vertex_index", corner_vert)
    tmp.loops.foreach_get("edge_index", corner_edge)
    # Each corner touches two edges of its triangle: the one to the next corner and the one
    # from the previous corner (corners are 3 per triangle, in order).
    prev_edge = corner_edge.reshape(-1, 3)[:, [2, 0, 1]].reshape(-1)
    normal = np.tile(normal_classes(values), 2)
    end = np.concatenate([corner_edge, prev_edge]) * len(tmp.vertices) + np.tile(corner_vert, 2)
    order = np.argsort(end, kind="stable")
    end, normal = end[order], normal[order]
    # An (edge, vertex) whose corners differ has two neighbours (in that order) that differ.
    differ = (end[1:] == end[:-1]) & (normal[1:] != normal[:-1])
    sharp = np.zeros(len(tmp.edges), dtype=bool)
    sharp[end[1:][differ] // len(tmp.vertices)] = True
    if sharp.any():
        tmp.edges.foreach_set("use_edge_sharp", sharp)


def _free_normals(tmp, values):
    """Store `values` (corners x 3, float32) as tmp's float "custom_normal" corner attribute;
    True when Blender then reads them back exactly as the corner normals (free normals, 4.5
    and later), else the attribute is removed again and False."""
    if not hasattr(tmp, "normals_domain"):
        return False
    attr = tmp.attributes.new("custom_normal", "FLOAT_VECTOR", "CORNER")
    if attr is None:
        return False
    attr.data.foreach_set("vector", values)
    tmp.update()
    read = np.empty(len(values), dtype=np.float32)
    tmp.corner_normals.foreach_get("vector", read)
    # Bit for bit, as MikkTSpace welds: 4.2 ignores the attribute and reads back its flat
    # faces' own normals, (0, 1, 0) where Cycles' triangle normal is (-0, 1, 0); == took them
    # for free normals, and two such triangles welded in the reference only (trimesh's
    # jacked.obj: a correct SG Normal Map p99 12.4 / max 36.7 deg on 4.2).
    if _same_bits(read, np.asarray(values, dtype=np.float32)):
        return True
    tmp.attributes.remove(tmp.attributes["custom_normal"])
    return False


def _same_bits(a, b):
    """True where float32 arrays a and b hold the same bits (any NaN matching any NaN)."""
    a, b = np.ascontiguousarray(a, dtype=np.float32), np.ascontiguousarray(b, dtype=np.float32)
    if a.shape != b.shape:
        return False
    nan = np.isnan(a)
    return bool(np.array_equal(nan, np.isnan(b))
                and np.array_equal(a.view(np.uint32)[~nan], b.view(np.uint32)[~nan]))
