"""Read an object exactly as Cycles evaluates it for a render (and a bake): the RENDER depsgraph.

Blender's bake builds its own depsgraph in render mode (object_bake_api.cc: DEG_graph_new(...,
DAG_EVAL_RENDER)), so modifiers run at their render settings: Subdivision's Render levels,
Multires' Render level, modifiers shown in renders only, a Geometry Nodes "Is Viewport" switch
set to false. Python's evaluated_depsgraph_get() is the viewport's, and Python cannot build a
render one; but a render engine's render(depsgraph) receives it. So `read_in_render_mode`
registers a tiny temporary RenderEngine that does nothing but call `read(depsgraph)`, renders
one frame of the context's view layer at 16 x 16 with it (no file written), and puts back
everything it touched: the render settings, the view layer's Use for Rendering, the scene
camera, the "Render Result" image if there was none (or the user's render in it: the pass
renders into a slot of its own), and the engine class. The scene's camera
is kept where it has one (hidden, excluded or in no collection, it still renders): a Geometry
Nodes setup reading the Active Camera (camera culling, distance LODs) evaluates as in the bake
(before, a stand-in camera at the origin bent such a mesh otherwise: a correct group compared
44 deg wrong). Only a scene without a camera gets a temporary one (Blender refuses to render
without), at the origin and scaled to nothing, as Object Info reads no camera. The session's
render and frame-change handlers (add-ons', a pipeline's) are taken out for the pass and put
back: the bake runs none of them, and the pass is no render of the artist's (RENDER_HANDLERS).
"""

from contextlib import ExitStack

from .bake_target import visible_for_bake
from .scene_state import restored


class RenderMeshError(RuntimeError):
    """The render-mode evaluation could not run; the message names why."""


_JOB = {}
# Render settings the probe render changes (put back after it).
_SETTINGS = ("render.engine", "render.resolution_x", "render.resolution_y",
             "render.resolution_percentage", "render.use_single_layer", "render.use_compositing",
             "render.use_sequencer", "render.use_freestyle", "render.use_border",
             "render.use_motion_blur")
ENGINE_ID = "SURFGRAD_RENDER_MESH"
# The probe's size: the smallest Blender renders where the scene's output is a movie format
# (FFmpeg: RE_InitState refuses under 16 pixels a side, "Image too small"). At 4 x 4, every
# object with a modifier in such a scene (tps-demo's red_robot.blend: its output is FFmpeg
# video) was refused by bake-normal-map and compare (red team 53b). The engine draws nothing.
PROBE_SIZE = 16


def _engine_class():
    import bpy

    class SurfgradRenderMesh(bpy.types.RenderEngine):
        """Does not draw: hands the render depsgraph of the probed view layer to the job."""
        bl_idname = ENGINE_ID
        bl_label = "surfgrad render-mode mesh (temporary)"
        bl_use_preview = False

        def render(self, depsgraph):
            job = _JOB.get("job")
            if job is None or job.get("done") or depsgraph.view_layer.name != job["layer"]:
                return
            job["done"] = True
            job["mode"] = depsgraph.mode
            try:
                job["result"] = job["read"](depsgraph)
            except BaseException as err:        # re-raised in the caller, not lost in C
                job["error"] = err

    return SurfgradRenderMesh


def read_in_render_mode(obj, read, context=None):
    """read(depsgraph) called with the RENDER depsgraph of the context's scene and view layer,
    obj made visible for it as for a bake (visible_for_bake). Returns what read returns;
    re-raises what it raises. Changes nothing in the file."""
    import bpy

    context = context or bpy.context
    scene, view_layer = context.scene, context.view_layer
    settings = tuple(p for p in _SETTINGS if _has(scene, p))
    images_before = set(bpy.data.images)
    engine = _engine_class()
    job = {"layer": view_layer.name, "read": read}
    with ExitStack() as stack:
        bpy.utils.register_class(engine)
        stack.callback(bpy.utils.unregister_class, engine)
        stack.callback(_remove_new_render_result, images_before)
        _probe_slot(stack)
        _quiet_render_handlers(stack)
        stack.enter_context(restored(scene, settings))
        stack.enter_context(visible_for_bake(obj, view_layer))
        # A view layer off for renders ("Use for Rendering") renders nothing, though a bake
        # takes it as it is: on for the pass (before, every modified object of such a file
        # was refused, "the render-mode pass did not reach view layer").
        stack.enter_context(restored(view_layer, ("use",)))
        view_layer.use = True
        if scene.camera is None:
            data = bpy.data.cameras.new(".surfgrad_render_mesh")
            camera = bpy.data.objects.new(".surfgrad_render_mesh", data)
            # Scaled to nothing at the origin: an Active Camera read through Object Info
            # gives the zeros the bake's missing camera gives (at scale 1, a Transform by
            # the camera's scale compared 4.6 deg wrong).
            camera.scale = (0.0, 0.0, 0.0)
            scene.collection.objects.link(camera)
            stack.callback(_remove_camera, camera, data, view_layer)
            stack.enter_context(restored(scene, ("camera",)))
            scene.camera = camera
        r = scene.render
        r.engine = ENGINE_ID
        r.resolution_x = r.resolution_y = PROBE_SIZE
        r.resolution_percentage = 100
        for name in ("use_single_layer", "use_compositing", "use_sequencer",
                     "use_freestyle", "use_border", "use_motion_blur"):
            if hasattr(r, name):
                setattr(r, name, name == "use_single_layer")
        _JOB["job"] = job
        try:
            outcome = bpy.ops.render.render(write_still=False)
        except RuntimeError as err:
            raise RenderMeshError(f"could not evaluate {obj.name!r} as Cycles renders it "
                                  f"(a {PROBE_SIZE} x {PROBE_SIZE} render-mode pass failed: {err})") from err
        finally:
            _JOB.pop("job", None)
    if "error" in job:
        raise job["error"]
    if not job.get("done") or outcome != {"FINISHED"}:
        raise RenderMeshError(f"could not evaluate {obj.name!r} as Cycles renders it: the "
                              f"render-mode pass did not reach view layer {view_layer.name!r}")
    if job["mode"] != "RENDER":
        raise RenderMeshError(f"the render-mode pass got a {job['mode']} depsgraph")
    return job.get("result")


def _has(root, path):
    for part in path.split("."):
        if not hasattr(root, part):
            return False
        root = getattr(root, part)
    return True


def _remove_camera(camera, data, view_layer):
    import bpy
    bpy.data.objects.remove(camera)
    bpy.data.cameras.remove(data)
    view_layer.update()     # else its objects list the camera's stale base as None


# A render writes into the Render Result's active slot. Measured (rt54a,
# tests/test_faults_review54a.py): an artist's unsaved F11 render in that slot was replaced by
# the probe's empty 16 x 16 one (Image > Save As: "could not be saved"), lost, on every bake,
# Freeze or compare of a modified object. Blender's Python has no way to remove a slot, so the
# probe keeps one of its own, made once, left empty.
PROBE_SLOT = "surfgrad probe (empty)"


def _probe_slot(stack):
    """Where a Render Result exists, make its probe slot the active one for the pass (and
    empty it and make the artist's slot active again after)."""
    import bpy
    result = next((i for i in bpy.data.images if i.type == "RENDER_RESULT"), None)
    if result is None:
        return
    slots = result.render_slots
    active = slots.active_index
    index = next((i for i, s in enumerate(slots) if s.name == PROBE_SLOT), None)
    if index is None:
        slots.new(name=PROBE_SLOT)
        index = len(slots) - 1

    def back():
        slots[index].clear(None)
        slots.active_index = active
    stack.callback(back)
    slots.active_index = index


# The pass is a render to Blender: it ran every render handler of the session (render_init,
# _pre, _post, _complete: 4 calls a pass, measured on 4.2 and 5.2, rt55a), which the bake
# itself never runs. An add-on's or pipeline's handler (a render counter or log, a "render
# done" notice, an auto-save of each render, a render-time proxy swap) took each bake, Freeze
# or compare of a modified object for a render of the artist's, and changed what it keeps.
# They are taken out for the pass and put back, in their order.
# The pass's frame set (render pipeline) runs frame_change_pre and _post too, twice a pass
# (measured on 5.2, rt56a), which neither the bake nor the artist's scene would have run: a
# handler that steps a simulation, counts frames or re-runs a node tree (Animation Nodes,
# Sverchok auto-execution) on each frame change was stepped by every bake, Freeze or compare
# of a modified object.
RENDER_HANDLERS = ("render_init", "render_pre", "render_post", "render_complete",
                   "render_cancel", "render_write", "frame_change_pre", "frame_change_post")


def _quiet_render_handlers(stack):
    import bpy
    for name in RENDER_HANDLERS:
        handlers = getattr(bpy.app.handlers, name, None)
        if handlers is None or not len(handlers):
            continue
        kept = list(handlers)
        handlers.clear()
        stack.callback(_put_back, handlers, kept)


def _put_back(handlers, kept):
    handlers[0:0] = [h for h in kept if h not in handlers]


def _remove_new_render_result(images_before):
    """The render made a "Render Result" image where the file had none: remove it."""
    import bpy
    for img in list(bpy.data.images):
        if img not in images_before and img.type == "RENDER_RESULT":
            bpy.data.images.remove(img)
