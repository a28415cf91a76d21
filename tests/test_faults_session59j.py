"""Red team 59j: a pipeline TD's long-lived bpy session (a service or a Jupyter kernel with
`import bpy`) calling surfgrad's API hundreds of times, file after file, and interrupting it
(Ctrl-C, the kernel's "interrupt": KeyboardInterrupt in the main thread).

1. harness_api.compare interrupted while it made its test images (5.2, a plane, "triplanar",
   32^2; a Timer thread raising KeyboardInterrupt in the main thread at staggered delays,
   3 runs of 8 interrupts): 2 runs of 3 left 128 x 128 packed float images `sg_normal`, and
   `sg_normal` + `sg_detail`, in bpy.data (0 users), one more set per interrupted call; the
   images were removed only by a try that began after the notes were logged, so an
   exception between prepare_inputs and that try (Ctrl-C, a log callback that raises on a
   "note:" line, parallax_depth) left all three (sg_normal, sg_detail, sg_height). Now the
   images are removed on any exception once the first is made (compare.prepare_inputs,
   bpy_float_image, compare_object): none left, and the next compare still finds the
   correct group right.

2. api.bake_normal_map (and compare) interrupted while checking the output folder: the
   writability probe (`.surfgrad-probe-XXXXXXXX`, bake_request.folder_problem) was left in
   the TD's output folder: 3 zero-byte files in /tmp/rt59j after the 24 interrupts above,
   a file the call had no right to write. Now the probe is removed in a finally.

Probed and fine (5.2, measured in a session): 20 bakes and 20 compares after
wm.open_mainfile left every bpy.data collection, app handler list, signal handler (a TD's
own SIGINT handler stays theirs), sys.path, os.environ, cwd, numpy error state, warnings
filters, logging handlers, render/bake/colour settings, frame, selection and active object
as they were, also after a refused call; RSS flat over 60 bakes (367 MB) and 60 compares
(411 -> 415 MB); an image replaced on disk with the same path and size (reload() or a
reopened file) and pixels edited in memory are baked as they are now (the ReadOnce caches
live only inside one call); a KeyboardInterrupt inside a bake left nothing.
"""

import os

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import bake_request  # noqa: E402
from surfgrad_addon.harness import api as harness_api  # noqa: E402
from surfgrad_addon.harness import compare as C  # noqa: E402
from surfgrad_addon.harness import scale_limits  # noqa: E402
from surfgrad_addon.reference import images as RI  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _plane(fresh):
    fresh.ops.mesh.primitive_plane_add()
    return fresh.context.object


def _interrupt(*_args, **_kwargs):
    raise KeyboardInterrupt


def test_compare_interrupted_while_images_are_made_leaves_none(fresh, monkeypatch):
    obj = _plane(fresh)
    monkeypatch.setattr(RI, "wave_height_image", _interrupt)      # after sg_normal, sg_detail
    with pytest.raises(KeyboardInterrupt):
        harness_api.compare(obj, "triplanar", resolution=16)
    assert sorted(i.name for i in bpy.data.images) == []           # before: 2 left


def test_compare_interrupted_after_images_before_bake_leaves_none(fresh, monkeypatch):
    obj = _plane(fresh)
    monkeypatch.setattr(scale_limits, "parallax_depth", _interrupt)
    with pytest.raises(KeyboardInterrupt):
        harness_api.compare(obj, "triplanar", resolution=16)
    assert sorted(i.name for i in bpy.data.images) == []           # before: 3 left


def test_compare_whose_log_raises_on_a_note_leaves_none(fresh, monkeypatch):
    obj = _plane(fresh)
    monkeypatch.setattr(scale_limits, "parallax_depth", lambda o, d: (d, "a depth note"))

    def log(line):
        if line.startswith("note:"):
            raise RuntimeError("the TD's logger failed")
    with pytest.raises(RuntimeError, match="logger failed"):
        C.compare_object(obj, "parallax", 16, log=log)
    assert sorted(i.name for i in bpy.data.images) == []


def test_next_compare_after_interrupts_is_right_and_clean(fresh, monkeypatch):
    obj = _plane(fresh)
    with monkeypatch.context() as m:
        m.setattr(RI, "wave_height_image", _interrupt)
        for _ in range(3):
            with pytest.raises(KeyboardInterrupt):
                harness_api.compare(obj, "triplanar", resolution=16)
    report = harness_api.compare(obj, "triplanar", resolution=16)
    assert report["max_deg"] < 0.05                  # the correct group is called right
    assert report["tilt_mean_deg"] > 10              # (it compared tilted normals)
    assert [i.name for i in bpy.data.images] == []


def test_output_folder_probe_removed_when_interrupted(tmp_path, monkeypatch):
    real_close = os.close

    def close(fd):                      # Ctrl-C landing just after the probe was closed
        real_close(fd)
        raise KeyboardInterrupt
    monkeypatch.setattr(bake_request.os, "close", close)
    with pytest.raises(KeyboardInterrupt):
        bake_request.folder_problem(tmp_path)
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == []        # before: the probe file
