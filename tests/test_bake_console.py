"""Blender's "Info: Baking map saved to internal image, save it externally or pack it", printed
by its C code on every bake, is kept out of what a user reads (issue 22): quiet_bake holds
file descriptor 1 for one bake and passes every other line on, in order."""

import os

import pytest

from support.child import run_python
from surfgrad_addon.addon.bake_console import NOISE, quiet_bake

pytestmark = pytest.mark.tier("numpy")

INFO = "Info: Baking map saved to internal image, save it externally or pack it\n"


def test_only_the_internal_image_note_is_dropped_and_the_rest_kept_in_order(capfd):
    with quiet_bake():
        os.write(1, b"before\n")
        os.write(1, INFO.encode())
        os.write(1, b"Info: something else\n")
    os.write(1, b"after\n")
    out = capfd.readouterr().out
    assert out == "before\nInfo: something else\nafter\n"
    assert INFO.startswith(NOISE)


def test_lines_are_passed_on_when_the_bake_raises(capfd):
    with pytest.raises(KeyboardInterrupt):
        with quiet_bake():
            os.write(1, b"half a bake\n" + INFO.encode())
            raise KeyboardInterrupt
    os.write(1, b"then the handler\n")
    assert capfd.readouterr().out == "half a bake\nthen the handler\n"


@pytest.mark.tier("child")
def test_a_real_bake_prints_its_progress_but_not_the_note(tmp_path):
    pytest.importorskip("bpy")
    blend = tmp_path / "asset.blend"
    made = run_python(["-c", (
        "import bpy\n"
        "from support.materials import diffuse_material\n"
        "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
        "bpy.ops.mesh.primitive_plane_add()\n"
        "o = bpy.context.active_object; o.name = 'Obj'\n"
        "o.data.materials.append(diffuse_material('M')[0])\n"
        f"bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})\n")])
    assert made.returncode == 0, made.stderr
    out = run_python(["-m", "surfgrad_addon", "bake-normal-map", "--blend", blend, "--object",
                      "Obj", "--output", tmp_path / "n.png", "--resolution", 16,
                      "--samples", 1])
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "n.png").stat().st_size > 0
    assert "baking with Cycles" in out.stdout + out.stderr       # our progress is still shown
    assert "Baking map saved to internal image" not in out.stdout + out.stderr
