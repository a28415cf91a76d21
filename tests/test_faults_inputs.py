"""Fault injection for inputs the red team found (issue 20): a .blend's own Python never runs,
whatever the user's Preferences say; inputs that would bake Cycles' magenta, a flat map or a
garbage map with exit 0 are refused before baking, naming the thing and the fix; bad option
values are refused up front. Each refusal: the message, the exit code, no file written, the
.blend byte for byte as it was."""

import hashlib
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _listing(folder):
    return sorted(p.name for p in Path(folder).iterdir()) if Path(folder).exists() else []


def _plane(name="Plane", uvs=None):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [], [(0, 1, 2, 3)])
    layer = mesh.uv_layers.new(name="UVMap")
    layer.data.foreach_set("uv", np.asarray(uvs or [(0, 0), (1, 0), (1, 1), (0, 1)],
                                            np.float32).ravel())
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _save(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return path


# 1. a .blend's driver and registered text block never run -----------------------------------

def _scripted_blend(tmp_path):
    """A .blend whose Python driver and registered text block would each write a file."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = _plane()
    driver_mark, text_mark = tmp_path / "DRIVER_RAN", tmp_path / "TEXT_RAN"
    fc = obj.driver_add("location", 0)
    fc.driver.type = "SCRIPTED"
    fc.driver.expression = (f"__import__('pathlib').Path({str(driver_mark)!r})"
                            ".write_text('x') or 0.0")
    text = bpy.data.texts.new("autorun.py")
    text.write(f"import pathlib\npathlib.Path({str(text_mark)!r}).write_text('x')\n")
    text.use_module = True
    blend = _save(tmp_path / "scripted.blend")
    return blend, driver_mark, text_mark


@pytest.fixture
def auto_run_on():
    """The user's Preference "Auto Run Python Scripts" on (what `blender -c` loads)."""
    prefs = bpy.context.preferences.filepaths
    was = prefs.use_scripts_auto_execute
    prefs.use_scripts_auto_execute = True
    yield
    prefs.use_scripts_auto_execute = was


def test_a_blend_scripts_do_not_run_with_auto_run_on(tmp_path, auto_run_on):
    blend, driver_mark, text_mark = _scripted_blend(tmp_path)
    before = _sha(blend)
    out = tmp_path / "maps"
    # the command opens the file, then refuses the unknown object: nothing baked
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Nope",
                           "--output", str(out / "n.png"), "--resolution", "32"])
    assert rc == exit_codes.BAD_REQUEST
    assert bpy.data.filepath == str(blend)                   # it was opened
    bpy.context.view_layer.update()                          # drivers would evaluate here
    assert not driver_mark.exists() and not text_mark.exists()
    assert bpy.app.driver_namespace.get("__import__") is None
    from surfgrad_addon.addon import batch
    batch._OPENED[0] = None
    batch.open_blend(blend)
    bpy.context.view_layer.update()
    assert not driver_mark.exists() and not text_mark.exists()
    from surfgrad_addon.harness import compare
    with pytest.raises(compare.CompareError, match="no object named 'Nope'"):
        compare.run(blend, "Nope", "normal-map", 32, tmp_path / "c.json")
    bpy.context.view_layer.update()
    assert not driver_mark.exists() and not text_mark.exists()
    assert _listing(out) == [] and not (tmp_path / "c.json").exists()
    assert _sha(blend) == before
