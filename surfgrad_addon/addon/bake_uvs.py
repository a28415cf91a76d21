"""The mesh a bake sees, and the UDIM tiles its UV maps cover there.

Blender's bake renders the object's mesh as Cycles evaluates it for a render (object_bake_api.cc
builds a RENDER depsgraph): modifiers at their render settings. Modifiers can move UVs (UV Warp,
UV Project, Array's and Mirror's UV offsets, Geometry Nodes) and can be shown in renders only or
in the viewport only, so the tiles a bake writes and the faces it covers are those of that mesh,
not of the mesh data: a layout checked on the mesh data bakes a blank map, or leaves a tile out,
with exit 0. An object without modifiers is read from the viewport's depsgraph
(the same mesh, and no render-mode pass); one with modifiers through render_mesh.py.
"""

import numpy as np

from ..reference import tiles as T
from .bake_target import bake_target_problem


def modified(obj):
    """obj has modifiers: its rendered mesh may differ from the mesh data and, through their
    render and viewport switches and settings, from the viewport's."""
    return len(obj.modifiers) > 0


def read_as_baked(obj, read):
    """read(evaluated object) for obj evaluated as the bake evaluates it; returns what read
    returns."""
    import bpy
    # An object the bake refuses (linked, outside the view layer) is read as the viewport
    # has it: its refusal names the problem, the render-mode pass could not reach it.
    if modified(obj) and bake_target_problem(obj, bpy.context.view_layer) is None:
        from .render_mesh import read_in_render_mode
        return read_in_render_mode(obj, lambda depsgraph: read(obj.evaluated_get(depsgraph)))
    return read(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()))


def uv_tiles(mesh, uv_map):
    """The UDIM tiles the faces of `uv_map` cover, sorted, and how many faces lie (partly)
    outside the UDIM range (u in 0..10, v >= 0). Exact (reference/tiles.py): a tile counts
    when a face's triangle covers part of it, not when only its bounding box reaches in, and
    a face across the range's border still names the tiles its inside part covers."""
    if len(mesh.polygons) == 0:
        return [], 0
    mesh.calc_loop_triangles()
    nt = len(mesh.loop_triangles)
    loops = np.empty(nt * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    faces = np.empty(nt, dtype=np.int64)
    mesh.loop_triangles.foreach_get("polygon_index", faces)
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float64)
    mesh.uv_layers[uv_map].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)[loops].reshape(-1, 3, 2)
    outside = np.unique(faces[T.triangles_outside(uv)])
    return T.tiles_with_uvs(uv), int(len(outside))


def baked_uv_tiles(obj):
    """{UV map name: (tiles, faces outside the UDIM range)} of every UV map of the mesh the
    bake renders (uv_tiles on it)."""
    def read(evaluated):
        mesh = evaluated.to_mesh()
        try:
            return {uv.name: uv_tiles(mesh, uv.name) for uv in mesh.uv_layers}
        finally:
            evaluated.to_mesh_clear()
    return read_as_baked(obj, read)
