"""The Freeze and Thaw operators (the work is in freeze.py).

Freeze runs modal when invoked from the interface (sidebar, Add menu: a dialog for its
options first): a timer steps freeze.freeze_steps one stage at a time
(checked, baked, wired) with the window's progress shown, and Esc cancels at the next stage
boundary (a Cycles bake is one blocking call; an Esc pressed during it is seen when it
returns, and the material is put back). From scripts, a redo and in the background it runs to
the end in execute. Both are undoable and report what they did or why not.
"""

import bpy
from bpy.props import BoolProperty, IntProperty, StringProperty

from . import freeze as F
from .operators import material_poll, tree_owner

STAGES = ("checked", "baked", "wired")


def shown_material(context):
    """The material the Shader Editor shows (pinned, or another slot's; also with a group of
    it entered), else None: Freeze and Thaw then take the active object's active material."""
    space = getattr(context, "space_data", None)
    if getattr(space, "type", None) != 'NODE_EDITOR' or \
            getattr(space, "tree_type", None) != "ShaderNodeTree" or space.node_tree is None:
        return None
    return tree_owner(space.node_tree)


class SURFGRAD_OT_freeze_stack(bpy.types.Operator):
    """Bake the active material's surface-gradient stack into a tangent-space normal map and \
wire it through a Normal Map node into the BSDF; the live stack stays in the material, \
unlinked, in a frame (Thaw brings it back)"""
    bl_idname = "surfgrad.freeze_stack"
    bl_label = "Freeze Surface Gradient Stack"
    bl_options = {'REGISTER', 'UNDO'}

    resolution: IntProperty(name="Resolution", description="Texels per side of the normal map",
                            default=F.NB.DEFAULT_RESOLUTION, min=F.NB.RESOLUTION_RANGE[0],
                            max=F.NB.RESOLUTION_RANGE[1])
    uv_map: StringProperty(name="UV Map", description="UV map to bake on and to sample the map "
                           "with (empty: the active render UV map)", default="")
    filepath: StringProperty(name="Save As", description="PNG (16-bit) or OpenEXR file to save "
                             "the map to (empty: pack it into the .blend)", default="",
                             subtype='FILE_PATH')
    overwrite: BoolProperty(name="Overwrite", description="Replace an existing file",
                            default=False)
    samples: IntProperty(name="Samples", description="Cycles samples per texel (more "
                         "anti-alias detail finer than a texel)", default=1, min=1, max=4096)

    # Set by invoke, cleared when the modal run ends: a redo (Adjust Last Operation) or a
    # script runs execute to the end instead of starting a modal run.
    interactive: BoolProperty(default=False, options={'HIDDEN', 'SKIP_SAVE'})

    poll = classmethod(material_poll)

    def invoke(self, context, _event):
        self.interactive = True
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        # What bends the normal maps the stack reads: reported once the freeze is done.
        obj = context.object
        mat = shown_material(context) or getattr(obj, "active_material", None)
        self._warnings = F.freeze_warnings(obj, mat) \
            if mat is not None and obj is not None else []
        self._steps = F.freeze_steps(obj, self.resolution, self.uv_map, self.filepath,
                                     self.overwrite, self.samples, mat=shown_material(context),
                                     warn=lambda w: self._warnings.append(w))
        if not self.interactive or context.window is None or bpy.app.background:
            self.interactive = False
            return self._finish(self._run_all)
        self.interactive = False
        return self._finish(self._start_modal, context)

    def _advance(self):
        """The freeze's next stage, or None once it is done (its record kept: the active
        object may be another by then, in a modal run)."""
        try:
            return next(self._steps)
        except StopIteration as done:
            self._record = done.value
            return None

    def _run_all(self):
        while self._advance() is not None:
            pass
        return {'FINISHED'}

    def _start_modal(self, context):
        next(self._steps)                                   # the checks: refused at once
        wm = context.window_manager
        wm.progress_begin(0, len(STAGES))
        self._timer = wm.event_timer_add(0.05, window=context.window)
        self._cancel = False
        wm.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        if event.type == 'ESC' and event.value == 'PRESS':
            self._cancel = True
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}
        wm = context.window_manager
        if self._cancel:
            outcome = self._finish(self._steps.throw, F.FreezeCancelled(
                "Freeze cancelled: the material is as it was"))
        else:
            outcome = self._finish(self._step, wm)
        if outcome != {'RUNNING_MODAL'}:
            wm.event_timer_remove(self._timer)
            wm.progress_end()
        return outcome

    def _step(self, wm):
        stage = self._advance()
        if stage is None:
            return {'FINISHED'}
        wm.progress_update(STAGES.index(stage) + 1)
        return {'RUNNING_MODAL'}

    def _finish(self, step, *args):
        try:
            outcome = step(*args)
        except F.FreezeCancelled as err:
            self._report_warnings()
            self.report({'WARNING'}, str(err))
            return {'CANCELLED'}
        except (ValueError, RuntimeError) as err:      # FreezeError, BakeFailed, a bad file
            self._report_warnings()                 # to fix too; the refusal last, seen
            self.report({'ERROR'}, str(err))
            return {'CANCELLED'}
        if outcome == {'FINISHED'}:
            record = self._record
            where = record["file"] or "packed into the .blend"
            self.report({'INFO'}, f"Froze the stack into {record['image']!r} ({where}); "
                                  f"Thaw Surface Gradient Stack brings it back")
            self._report_warnings()             # last: the status bar shows the warning
        return outcome

    def _report_warnings(self):
        """What bends the normal maps the stack reads, each said once."""
        for warning in self._warnings:
            self.report({'WARNING'}, warning)
        self._warnings = []


class SURFGRAD_OT_thaw_stack(bpy.types.Operator):
    """Relink the active material's frozen surface-gradient stack exactly as it was and \
remove the normal map nodes (and image, if the freeze made it and nothing else uses it)"""
    bl_idname = "surfgrad.thaw_stack"
    bl_label = "Thaw Surface Gradient Stack"
    bl_options = {'REGISTER', 'UNDO'}

    poll = classmethod(material_poll)

    def execute(self, context):
        obj = context.object
        try:
            record = F.thaw(shown_material(context) or
                            (obj.active_material if obj is not None else None))
        except F.FreezeError as err:
            self.report({'ERROR'}, str(err))
            return {'CANCELLED'}
        note = f"; the file {record['file']!r} is kept" if record["file"] else ""
        self.report({'INFO'}, f"Thawed: the live stack is linked again{note}")
        return {'FINISHED'}


CLASSES = (SURFGRAD_OT_freeze_stack, SURFGRAD_OT_thaw_stack)
