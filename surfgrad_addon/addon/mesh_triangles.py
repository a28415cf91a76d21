"""A mesh's loop triangles as arrays: the bake's mesh (bake_uvs.py) and the meshes an object
instances (unrealized_instances.py) are read the same way."""

import numpy as np


def triangles(mesh, per_triangle="polygon_index"):
    """(loops (T*3,), the triangles' `per_triangle` values (T,)) of the mesh's loop
    triangles (polygon_index: the face each comes from; material_index: its material slot)."""
    mesh.calc_loop_triangles()
    nt = len(mesh.loop_triangles)
    loops = np.empty(nt * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    values = np.empty(nt, dtype=np.int64)
    mesh.loop_triangles.foreach_get(per_triangle, values)
    return loops, values


def triangle_uvs(mesh, uv_map, loops):
    """(T, 3, 2) float64 UVs of UV map `uv_map` at the triangles' `loops`."""
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float64)
    mesh.uv_layers[uv_map].data.foreach_get("uv", uv)
    return uv.reshape(-1, 2)[loops].reshape(-1, 3, 2)
