"""The artist's operators at odd moments (red team 37d).

- Freeze in the interface runs modal, a stage per timer event, and read the record it reports
  from `bpy.context.object` when it finished: an artist who made another object active while
  it ran (in a second window, which the modal handler does not block) got a raw TypeError
  (another object's material has no record; no active object: AttributeError) after the
  freeze had been done, no report, and the progress bar and timer left running. Now the record
  is the one the freeze returned.
- Thaw found the frozen image by the name the freeze gave it: an artist who had renamed it
  ("Rock_frozen_normal.png" to "rock_nrm") was left with the image, unused, after the thaw
  (packed: its pixels saved in the file to no use). Now Thaw takes the image from the freeze's
  Image Texture node, when it is still the one the freeze made (its name, or its file or pack
  path); a map of the artist's own put in that node is kept.
- Freeze and Thaw took the active object's active material whatever the Shader Editor showed:
  with the editor pinned to the object's second material, Freeze froze the first, which the
  artist was not looking at (the other operators act on the shown tree). Now both act on the
  material the editor shows, and one the active object does not use is refused with the fix.
"""

import types

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import freeze_operators as FO  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.harness import scenes as test_scenes  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_extension import _shader_editor  # noqa: E402
from test_faults_operators35 import registered  # noqa: E402,F401 (a fixture)

pytestmark = pytest.mark.tier("bake")

SIZE = 16


def _stacked_plane(name="Rock"):
    """A plane and a sphere; the plane's material a layer stack into a Diffuse BSDF."""
    objs = test_scenes.new_scene(["Plane", "Sphere"])
    mat, tree, _ = diffuse_material(name)
    objs["Plane"].data.materials.clear()
    objs["Plane"].data.materials.append(mat)
    O.add_layer_stack(tree)
    bpy.context.view_layer.objects.active = objs["Plane"]
    return objs, mat


class ModalFreeze:
    """The Freeze operator's own Python methods, run as the window manager runs a modal
    operator: modal() once per timer event (a background Blender has no event loop)."""
    _advance = FO.SURFGRAD_OT_freeze_stack._advance
    _step = FO.SURFGRAD_OT_freeze_stack._step
    _finish = FO.SURFGRAD_OT_freeze_stack._finish
    _report_warnings = FO.SURFGRAD_OT_freeze_stack._report_warnings
    modal = FO.SURFGRAD_OT_freeze_stack.modal

    def __init__(self, obj):
        self.reports, self.ended = [], []
        self._warnings, self._cancel, self._timer = [], False, "timer"
        self._steps = F.freeze_steps(obj, SIZE)
        next(self._steps)                        # the checks, as _start_modal runs them
        self.wm = types.SimpleNamespace(progress_update=lambda _value: None,
                                        event_timer_remove=self.ended.append,
                                        progress_end=lambda: self.ended.append("progress"))

    def report(self, kind, text):
        self.reports.append((sorted(kind), text))

    def run(self, between=lambda: None):
        """Timer events until the operator ends; `between` runs after each."""
        context = types.SimpleNamespace(window_manager=self.wm)
        timer = types.SimpleNamespace(type='TIMER', value='NOTHING')
        for _ in range(len(FO.STAGES) + 1):
            outcome = self.modal(context, timer)
            if outcome != {'RUNNING_MODAL'}:
                return outcome
            between()
        raise AssertionError("the modal freeze did not end")


@pytest.mark.parametrize("active", ["Sphere", None])
def test_a_modal_freeze_reports_the_frozen_object_when_another_is_active(active):
    objs, mat = _stacked_plane()
    run = ModalFreeze(objs["Plane"])
    view_layer = bpy.context.view_layer
    view_layer.objects.active = objs[active] if active else None   # the artist clicks away
    assert run.run() == {'FINISHED'}
    record = F.frozen_record(mat)
    assert record is not None and record["image"] == "Rock_frozen_normal.png"
    assert run.reports == [(["INFO"], "Froze the stack into 'Rock_frozen_normal.png' (packed "
                            "into the .blend); Thaw Surface Gradient Stack brings it back")]
    assert run.ended == ["timer", "progress"]          # the timer and the progress bar end
    assert F.RECORD not in (objs["Sphere"].active_material or {})


@pytest.mark.parametrize("saved", [False, True])
def test_thaw_removes_the_frozen_image_the_artist_renamed(tmp_path, saved):
    objs, mat = _stacked_plane()
    path = tmp_path / "rock_nrm.png"
    F.freeze(objs["Plane"], SIZE, filepath=str(path) if saved else "")
    image = bpy.data.images[F.frozen_record(mat)["image"]]
    image.name = "the artist's name"
    F.thaw(mat)
    assert [i.name for i in bpy.data.images] == []
    assert path.is_file() == saved                     # a saved file is never deleted


def test_thaw_keeps_a_map_of_the_artists_own_put_in_the_frozen_node():
    """The artist swapped the frozen map for one of their own (no other user) in the freeze's
    Image Texture node: the thaw removes that node and the frozen map, and the artist's image
    stays."""
    objs, mat = _stacked_plane()
    F.freeze(objs["Plane"], SIZE)
    record = F.frozen_record(mat)
    tex = next(n for n in mat.node_tree.nodes if n.name in record["added"]
               and n.bl_idname == "ShaderNodeTexImage")
    own = bpy.data.images.new("hand painted", 4, 4)
    own.pixels.foreach_set(np.full(4 * 4 * 4, 0.5, np.float32))
    tex.image = own
    F.thaw(mat)
    assert [i.name for i in bpy.data.images] == ["hand painted"]


def test_freeze_and_thaw_act_on_the_material_the_editor_shows(registered):
    objs, first = _stacked_plane("First")
    second, tree, _ = diffuse_material("Second")
    O.add_layer_stack(tree)
    objs["Plane"].data.materials.append(second)          # slot 2; slot 1 stays active
    registered(*FO.CLASSES)
    override, _ = _shader_editor(bpy, tree)              # pinned to the second material
    with bpy.context.temp_override(**override):
        assert bpy.ops.surfgrad.freeze_stack(resolution=SIZE) == {'FINISHED'}
        assert F.RECORD in second and F.RECORD not in first
        assert bpy.ops.surfgrad.thaw_stack() == {'FINISHED'}
    assert F.RECORD not in second and bpy.data.images.get("Second_frozen_normal.png") is None


def test_freeze_refuses_a_shown_material_the_active_object_does_not_use(registered):
    objs, first = _stacked_plane("First")
    other, tree, _ = diffuse_material("Elsewhere")
    O.add_layer_stack(tree)
    objs["Sphere"].data.materials.clear()
    objs["Sphere"].data.materials.append(other)
    registered(*FO.CLASSES)
    override, _ = _shader_editor(bpy, tree)
    with bpy.context.temp_override(**override), pytest.raises(
            RuntimeError, match="shows material 'Elsewhere', which 'Plane' does not use"):
        bpy.ops.surfgrad.freeze_stack(resolution=SIZE)
    assert F.RECORD not in first and F.RECORD not in other and not bpy.data.images
