"""The normals Sculpt Mode leaves in a mesh, and the mesh's own for a comparison.

Sculpt Mode keeps an object's vertex normals its own way (each the normalised sum of its faces'
normals, where Object Mode weights them by the faces' corner angles) in the mesh's normal
cache, and Cycles (4.5 and later) shades and bakes those: while the object is in Sculpt Mode
(in a script's session, or a .blend saved in Sculpt Mode, which opens in it, headless too), and
in Object Mode after it in the same session, until something moves a vertex. The mesh read for
`compare`'s reference has the mesh's own normals, so the two disagreed (red team 59e: a bent 6
x 5 grid, the correct SG Normal Map 0.27 deg p99 wrong, over the 0.1 bar), and a normal-map
bake (Freeze's too) wrote another map than the same mesh's out of Sculpt Mode (2.8 deg p99 on a
bumpy grid), which the file, reopened in Object Mode, does not render with. A comparison and a
bake run with the object out of Sculpt Mode and the normal cache recomputed; Sculpt Mode is
given back after.
"""

from contextlib import contextmanager

import numpy as np


def _refresh_normals(mesh):
    """Recompute mesh's cached normals: its vertex positions written back as they are (which
    tags them changed; Blender then computes the normals anew, Object Mode's way)."""
    if mesh is None or mesh.library is not None or mesh.is_editmode or not len(mesh.vertices):
        return
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    mesh.vertices.foreach_set("co", co)
    mesh.update()


@contextmanager
def own_normals(obj):
    """obj in Object Mode with its mesh's own normals for the block (out of Sculpt Mode, the
    cache Sculpt Mode left recomputed); Sculpt Mode again after where it was in it (leaving it
    writes the sculpt into the mesh, as saving does; nothing is lost)."""
    import bpy
    sculpting = getattr(obj, "mode", "OBJECT") == "SCULPT"
    view_layer = bpy.context.view_layer
    active = view_layer.objects.active

    def switch(mode):
        # An object disabled in viewports (hide_viewport, set in Sculpt Mode) fails
        # mode_set's poll ('Cannot edit hidden object'): shown for the switch alone.
        hidden, obj.hide_viewport = obj.hide_viewport, False
        view_layer.objects.active = obj
        try:
            with bpy.context.temp_override(active_object=obj, object=obj):
                bpy.ops.object.mode_set(mode=mode)
        finally:
            view_layer.objects.active = active
            obj.hide_viewport = hidden

    if sculpting:
        switch("OBJECT")
    try:
        if obj.type == "MESH":
            _refresh_normals(obj.data)
        yield
    finally:
        if sculpting and obj.mode != "SCULPT":
            switch("SCULPT")
