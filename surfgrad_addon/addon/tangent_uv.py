"""The UV map whose tangents a tangent-space bake converts with.

Blender's bake takes the tangent frame from the active UV map of the mesh as it renders, not
from the UV map it is given (object_bake_api.cc, RE_bake_normal_world_to_tangent), so the bake
makes the asked-for map active first. Modifiers can move that: up to 5.0 a Geometry Nodes
modifier that writes the UV map anew (a Remove and a Store Named Attribute of it) leaves it last
and inactive, and the rendered mesh's active UV map is another one. The map was then in the
other UV map's frame, with exit 0 (a frame turned 90 degrees: up to 0.49 off in a PNG's 0..1).
Where that happens, the bake goes through a temporary copy of the render mesh (the far-bake
route's render_mesh_swapped: the same shading), on which the asked-for map is made active.
"""

from contextlib import contextmanager

from .bake_uvs import baked_mesh, modified, uv_active
from .precise_bake import render_mesh_swapped


@contextmanager
def tangents_of(obj, uv_map, space):
    """For the block: a tangent-space bake of obj converts with `uv_map`'s tangents (obj's
    mesh is a copy of its render mesh where its modifiers would make another UV map active).
    The rendered mesh is the request's one read of it (bake_uvs.baked_mesh, read with
    `uv_map` active). Yields whether the copy stands in."""
    if space != "tangent" or not modified(obj):
        yield False
        return
    with uv_active(obj.data, uv_map):
        kept = baked_mesh(obj).active_uv == uv_map
    if kept:
        yield False
        return
    with render_mesh_swapped(obj):
        yield True
