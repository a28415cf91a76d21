"""surfgrad.freeze_stack and surfgrad.thaw_stack through bpy.ops, as the sidebar and the Add menu
run them: registered by the extension's entry point, undoable (undo brings back the live
material and drops the image; redo freezes again), refusing misuse with the fix and CANCELLED.

Runs in a child session (this file as a script, tests/support/operator_session.py): nothing
is registered in the pytest process. In the background the freeze runs to the end in execute
(the interface's modal stepping needs an event loop)."""

import sys

import pytest

from support.operator_session import run_session, write_report  # noqa: E402

pytestmark = pytest.mark.tier("child")

MARKER = "SG_FREEZE_OPERATORS_DONE"


def session(work):
    import bpy

    import surfgrad_addon
    from support.freeze_scene import layered_material
    from support.material_dump import material_dump
    from surfgrad_addon.addon import freeze as F
    from surfgrad_addon.harness import scenes as test_scenes

    report = {}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    surfgrad_addon.register()
    ops = ("freeze_stack", "thaw_stack")
    report["registered"] = [op in dir(bpy.ops.surfgrad) for op in ops]
    report["bl_options"] = [sorted(getattr(bpy.types, f"SURFGRAD_OT_{op}").bl_options)
                            for op in ops]
    obj = test_scenes.build(["Sphere"])["Sphere"]
    bpy.context.view_layer.objects.active = obj

    def call(op, **kw):
        try:
            return sorted(getattr(bpy.ops.surfgrad, op)('EXEC_DEFAULT', True, **kw)), None
        except RuntimeError as err:
            return None, str(err)
    report["no_material"] = call("freeze_stack", resolution=32)
    report["thaw_no_material"] = call("thaw_stack")
    mat, _ = layered_material(obj)
    name = mat.name                      # IDs are fetched again by name after undo/redo
    report["thaw_not_frozen"] = call("thaw_stack")
    bpy.ops.ed.undo_push(message="start")
    before = material_dump(mat)
    report["freeze"] = call("freeze_stack", resolution=32, filepath=str(work / "n.png"))
    mat = bpy.data.materials[name]
    record = F.frozen_record(mat)
    report["frozen_image"] = record["image"] in bpy.data.images if record else None
    report["file"] = (work / "n.png").is_file()
    report["again"] = call("freeze_stack", resolution=32)
    bpy.ops.ed.undo()
    mat = bpy.data.materials[name]
    report["undo_equal"] = material_dump(mat) == before
    report["undo_image_gone"] = record["image"] not in bpy.data.images
    bpy.ops.ed.redo()
    mat = bpy.data.materials[name]
    report["redo_frozen"] = F.frozen_record(mat) is not None
    report["thaw"] = call("thaw_stack")
    mat = bpy.data.materials[name]
    report["thaw_equal"] = material_dump(mat) == before
    report["file_kept"] = (work / "n.png").is_file()
    surfgrad_addon.unregister()
    report["unregistered"] = [op in dir(bpy.ops.surfgrad) for op in ops]
    write_report(work, report, MARKER)


@pytest.fixture(scope="module")
def r(tmp_path_factory):
    return run_session(__file__, tmp_path_factory, "freeze_operators", MARKER)


def test_registered_undoable_and_unregistered(r):
    assert r["registered"] == [True, True] and r["unregistered"] == [False, False]
    assert r["bl_options"] == [["REGISTER", "UNDO"]] * 2


def test_misuse_is_refused_with_the_fix(r):
    assert r["no_material"][0] is None and "add a material" in r["no_material"][1]
    assert r["thaw_no_material"][0] is None and "no active material" in \
        r["thaw_no_material"][1]
    assert r["thaw_not_frozen"][0] is None and "nothing to thaw" in r["thaw_not_frozen"][1]
    assert r["again"][0] is None and "thaw it first" in r["again"][1]


def test_freeze_undo_redo_thaw(r):
    assert r["freeze"] == [["FINISHED"], None]
    assert r["frozen_image"] and r["file"]
    assert r["undo_equal"] and r["undo_image_gone"]
    assert r["redo_frozen"]
    assert r["thaw"] == [["FINISHED"], None]
    assert r["thaw_equal"] and r["file_kept"]


if __name__ == "__main__":
    from pathlib import Path
    sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1])]
    session(Path(sys.argv[1]))
