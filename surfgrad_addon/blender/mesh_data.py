"""A Blender mesh object as the reference's MeshArrays: what Cycles sees, as plain arrays.

The evaluated mesh (modifiers applied) is triangulated with Blender's own loop triangles;
per-corner normals are Blender's corner normals (smooth, flat and custom split normals alike);
tangents and signs are Blender's MikkTSpace (`Mesh.calc_tangents`) for every UV map.
"""

import numpy as np

from ..reference.raster import MeshArrays


class MeshDataError(ValueError):
    """The object cannot be baked as asked; the message names the object and the fix."""


def _get(collection, attr, count, width, dtype=np.float64):
    out = np.empty(count * width, dtype=dtype)
    collection.foreach_get(attr, out)
    return out.reshape(count, width) if width > 1 else out


def mesh_arrays_from_object(obj, depsgraph=None, need_tangents=True):
    """MeshArrays of `obj` (evaluated, world matrix included). Raises MeshDataError for an
    object without mesh data, faces or UV maps."""
    import bpy

    if obj is None:
        raise MeshDataError("no object given")
    if obj.type != "MESH":
        raise MeshDataError(f"object {obj.name!r} is a {obj.type.lower()}, not a mesh; pick a "
                            f"mesh object (or convert it with Object > Convert > Mesh)")
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    eval_obj = obj.evaluated_get(depsgraph)
    mesh = eval_obj.to_mesh()
    try:
        if len(mesh.polygons) == 0:
            raise MeshDataError(f"object {obj.name!r} has no faces to bake; add geometry")
        if len(mesh.uv_layers) == 0:
            raise MeshDataError(f"object {obj.name!r} has no UV map; add one (UV > Unwrap) "
                                f"before baking")
        mesh.calc_loop_triangles()
        nv, nl, nt = len(mesh.vertices), len(mesh.loops), len(mesh.loop_triangles)
        positions = _get(mesh.vertices, "co", nv, 3)
        tri_loops = _get(mesh.loop_triangles, "loops", nt, 3, np.int64)
        tri_verts = _get(mesh.loop_triangles, "vertices", nt, 3, np.int64)
        corner_normals = _get(mesh.corner_normals, "vector", nl, 3)[tri_loops]
        uv_maps, tangents, signs = {}, {}, {}
        for layer in mesh.uv_layers:
            uv = _get(layer.uv, "vector", nl, 2)
            uv_maps[layer.name] = uv[tri_loops]
            if need_tangents:
                try:
                    mesh.calc_tangents(uvmap=layer.name)
                except RuntimeError as err:   # n-gons with more than 4 sides, etc.
                    raise MeshDataError(f"object {obj.name!r}: MikkTSpace tangents for UV map "
                                        f"{layer.name!r} failed ({err})") from err
                tangents[layer.name] = _get(mesh.loops, "tangent", nl, 3)[tri_loops]
                signs[layer.name] = _get(mesh.loops, "bitangent_sign", nl, 1)[tri_loops]
        if need_tangents:
            mesh.free_tangents()
        matrix = np.array(eval_obj.matrix_world, dtype=np.float64)
        return MeshArrays(positions=positions, triangles=tri_verts,
                          corner_normals=corner_normals, uv_maps=uv_maps, tangents=tangents,
                          tangent_signs=signs, matrix_world=matrix, name=obj.name).validate()
    finally:
        eval_obj.to_mesh_clear()
