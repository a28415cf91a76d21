"""Fault injection, red team 30b: the Freeze operator baked a stack that reads a bent normal
map (a grey PNG, an sRGB one) without a word, where bake-normal-map warns. Now its report
carries the same warnings, after the line that says what it froze. Runs in a child session
(tests/support/operator_session.py), as the operator tests do."""

import sys

import pytest

from support.operator_session import run_session, write_report  # noqa: E402

pytestmark = pytest.mark.tier("child")

MARKER = "SG_FREEZE_WARNINGS_DONE"


def session(work):
    import bpy
    import numpy as np
    from PIL import Image

    import surfgrad_addon
    from support.materials import diffuse_material
    from surfgrad_addon import api
    from surfgrad_addon.harness import scenes as test_scenes

    bpy.ops.wm.read_factory_settings(use_empty=True)
    surfgrad_addon.register()
    obj = test_scenes.build(["Sphere"])["Sphere"]
    bpy.context.view_layer.objects.active = obj
    grey = (np.arange(16 * 16).reshape(16, 16) % 200 + 28).astype(np.uint8)
    Image.fromarray(grey, "L").save(work / "grey.png")
    Image.fromarray(np.dstack([grey] * 3), "RGB").save(work / "rgb.png")
    report = {}
    for name in ("grey", "rgb"):
        mat, tree, bsdf = diffuse_material(name)
        tex = tree.nodes.new("ShaderNodeTexImage")
        tex.image = bpy.data.images.load(str(work / f"{name}.png"))
        tex.image.colorspace_settings.name = "Non-Color"
        sg = tree.nodes.new("ShaderNodeGroup")
        sg.node_tree = api.node_group("SG Normal Map")
        resolve = tree.nodes.new("ShaderNodeGroup")
        resolve.node_tree = api.node_group("SG Resolve")
        tree.links.new(tex.outputs["Color"], sg.inputs["Color"])
        tree.links.new(sg.outputs["Surface Gradient"], resolve.inputs["Surface Gradient"])
        tree.links.new(resolve.outputs["Normal"], bsdf.inputs["Normal"])
        obj.data.materials.clear()
        obj.data.materials.append(mat)
        obj.active_material_index = 0
        print(f"== freeze {name}", flush=True)
        report[name] = sorted(bpy.ops.surfgrad.freeze_stack('EXEC_DEFAULT', True,
                                                            resolution=16))
        sys.stdout.flush()
    surfgrad_addon.unregister()
    write_report(work, report, MARKER)


@pytest.fixture(scope="module")
def r(tmp_path_factory):
    return run_session(__file__, tmp_path_factory, "freeze_warnings", MARKER)


def test_the_freeze_operator_reports_what_bends_the_normal_map_it_reads(r):
    """Before: 'Froze the stack into ...' alone. Now a grey PNG in the stack is reported as
    bake-normal-map warns of it; the same grey saved as RGB is not."""
    assert r["grey"] == ["FINISHED"] and r["rgb"] == ["FINISHED"]
    text = r["stdout"] + r["stderr"]
    grey = text.split("== freeze grey")[1].split("== freeze rgb")[0]
    rgb = text.split("== freeze rgb")[1]
    assert "Froze the stack into" in grey and "Froze the stack into" in rgb, text[-3000:]
    said = ("image 'grey.png', read by SG Normal Map node 'Group' (material 'grey'), holds 1 "
            "channel in its file (grey.png: grey PNG)")
    assert [line for line in grey.splitlines() if "Warning" in line and said in line], grey
    # (its grey ramp as RGB puts 153 texels' normals into the surface: red team 59f warns of
    # that, test_faults_pixels59f.py; no channel warning)
    assert not [line for line in rgb.splitlines() if "arning" in line and
                "153 of its 256 texels with blue at or below 0.5" not in line], rgb


if __name__ == "__main__":
    from pathlib import Path
    sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1])]
    session(Path(sys.argv[1]))
