"""Red team 34c: `bake-normal-map` and `compare` on objects as people outside the project set
them up, built here.

1. Objects Cycles leaves out of the render, which its bake left out too: every ray visibility
   off (Object > Visibility > Ray Visibility: a proxy or a mesh kept for its light only), and
   Show Instancer for Render off on an object that instances (a hair scalp or scatter
   emitter, vertex instancing). Before, bake-normal-map wrote the background, a grey map of
   zero-length normals (every texel (0.5, 0.5, 0.5) in a PNG), with exit 0, and compare said
   "no texel could be compared ...; raise --resolution" (exit 2). Now the bake turns on the
   camera ray (only when every ray is off) and the instancer for its duration, as it lifts
   hiding and holdout (addon/bake_target.visible_for_bake), and puts them back.
"""

import hashlib
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import exit_codes  # noqa: E402
from surfgrad_addon.addon.cycles_geometry import RAYS  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from test_faults_scene_settings import _bake, _pixels, _scene, plain  # noqa: E402,F401
from test_faults_unseen_meshes31 import RES, _within_bar, empty_file  # noqa: E402,F401
from test_faults_unseen_meshes32 import _grid, _object  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _rays_off(obj):
    for ray in RAYS:
        setattr(obj, ray, False)
    return lambda o: tuple(getattr(o, ray) for ray in RAYS)


def _vertex_instancer(obj):
    """Vertex instancing of a small child mesh (outside the UV square's texels: it has no
    faces), the instancer not shown in renders."""
    child = bpy.data.objects.new("Instanced", bpy.data.meshes.new("Instanced"))
    bpy.context.scene.collection.objects.link(child)
    child.parent = obj
    obj.instance_type = "VERTS"
    obj.show_instancer_for_render = False
    return lambda o: (o.instance_type, o.show_instancer_for_render)


def _hair_scalp(obj):
    """A hair particle system (strands of the object's own material), emitter not rendered:
    a scalp as groomers leave it."""
    settings = obj.modifiers.new("Hair", "PARTICLE_SYSTEM").particle_system.settings
    settings.type, settings.count, settings.hair_length = "HAIR", 20, 0.05
    obj.show_instancer_for_render = False
    return lambda o: o.show_instancer_for_render


# fault -> (what adds it to an object and returns how to read its flags, the flags as set)
FAULTS = {"rays_off": (_rays_off, (False,) * len(RAYS)),
          "vertex_instancer_hidden": (_vertex_instancer, ("VERTS", False)),
          "hair_scalp_hidden": (_hair_scalp, False)}


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_objects_cycles_leaves_out_are_baked(tmp_path, capsys, plain, fault):
    """The map of the faulted file is the plain file's, texel for texel; the flags are back
    and the file unchanged. Before: rc 0 and every texel 0.5 grey (ptp 0 in every channel)."""
    _scene(tmp_path)                          # the plain file, open: the fault added to it
    make, kept = FAULTS[fault]
    flags = make(bpy.data.objects["Plane"])
    blend = tmp_path / f"{fault}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    before = _sha(blend)
    rc, err = _bake(capsys, blend, tmp_path / "n.png")
    assert rc == exit_codes.OK, err[-2000:]
    assert np.abs(_pixels(tmp_path / "n.png") - plain).max() <= 1.5 / 255
    assert flags(bpy.data.objects["Plane"]) == kept      # the open file as it was
    assert _sha(blend) == before


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_compare_bakes_objects_cycles_leaves_out(empty_file, fault):
    """compare on a bumped grid with the fault: every texel compared, within the bar (before:
    CompareError "no texel ... could be compared", all 1521 texels outside the bake)."""
    obj = _object("Left out", [_grid()])
    make, kept = FAULTS[fault]
    flags = make(obj)
    report = compare.compare(obj, "normal-map", RES)
    _within_bar(report, 1500)
    assert report["excluded"]["outside"] == 0, report
    assert flags(obj) == kept
