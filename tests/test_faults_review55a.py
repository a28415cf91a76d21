"""Red team 55a: hostile review of the round 53-54 merges (rt53c, rt54a, rt54c, rt54d, rt54e).

1. normal_sources.py (rt54c) decides which images can reach the baked normal; the others are
   only warned of. It followed a shader output into baked_inputs(node), which keeps shader
   sockets alone, so the shader an Evaluate Closure or a Separate Bundle (Blender 5.0+) hands
   on was dropped with its Closure or Bundle input. An artist's Closure Zone (or a Combine /
   Separate Bundle pair) around a Principled BSDF fed a Normal Map: its image missing (a
   texture folder moved) was warned of as "it feeds no normal the bake reads, so the map is
   baked without it", and the bake went on with Cycles' magenta: every texel 54.7 degrees
   from the surface, where the material's normal is 60 degrees the other way (37.9 degrees
   off; measured on 5.2, the same on 5.0), exit 0, map written; so did a Normal Map given to
   the zone as an Evaluate Closure argument. Before rt54c it was refused.
   input_stamps (the file-changed-during-the-bake check) left the file out alike. Now a node
   with a Closure or Bundle input has all its inputs followed: refused, nothing written; a
   Base Color image inside the zone is still only warned of.
3. bake_closures took an Evaluate Closure (5.0+) whose closure takes an argument named
   "Normal" (the natural name for a reusable layer's base normal) for a BSDF: a Normal input
   and a Shader output. It stood it in as a white Diffuse fed that argument, dropping the
   zone's own shading: a Principled BSDF in the zone fed its own Normal Map 60 degrees off the
   surface baked flat, 60.0 degrees off what Cycles renders (5.0 and 5.2, argument linked or
   not), exit 0, no word; an argument named otherwise baked right (0.00). Now a node with a
   Closure or Bundle input never stands in (the BSDFs in its zone do), nor one whose Normal is
   not a vector: 0.00 degrees.
2. render_mesh's render-mode pass (rt54a gave it a Render Result slot of its own) is a render
   to Blender: every bake, Freeze or compare of an object with a modifier ran the session's
   render handlers, 4 calls a pass (render_init, _pre, _post, _complete; 4.2 and 5.2 alike),
   though the bake itself runs none (measured: only render_stats). An add-on's render
   counter on the scene went up by one a bake (the file changed), a "render done" notice or
   an auto-save of each render (it failed: "Render Result could not be saved") fired for a
   render the artist never made. Now the pass takes them out and puts them back, in order.
"""

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon.bake_request import BakeRequestError  # noqa: E402
from surfgrad_addon.addon.image_checks import image_problems  # noqa: E402
from surfgrad_addon.addon.input_stamps import stamps  # noqa: E402
from surfgrad_addon.addon.sampler_zone import has_closures  # noqa: E402
from support.baked_normals import baked_normals, degrees_between  # noqa: E402
from support.blender import missing_image, new_material  # noqa: E402
from support.materials import plane_with_output  # noqa: E402

pytestmark = pytest.mark.tier("blender")

needs_closures = pytest.mark.skipif(not has_closures(), reason="Closure Zones and Bundles "
                                    "are Blender 5.0+ shader nodes")

RES = 16
CARRIERS = ["closure", "closure argument", "bundle"]
TILT = math.radians(60.0)
NORMAL = np.array([math.sin(TILT), 0.0, math.cos(TILT)])


def _gone(name):
    return missing_image(name, "surfgrad55a")


def _carried_plane(carrier, source):
    """A plane whose Principled BSDF (Normal from a Normal Map fed by `source`: 'rgb', a
    constant 60 degrees off the surface, or 'missing', an Image Texture of a missing file)
    reaches the Material Output through `carrier`: 'closure' (a Closure Zone with a Shader
    item, evaluated by Evaluate Closure), 'closure argument' (the same, the Normal Map given
    to the zone by the Evaluate Closure's input item) or 'bundle' (Combine Bundle > Separate
    Bundle).
    Returns (obj, tree, bsdf)."""
    obj, tree = plane_with_output("Artist")
    nodes, link = tree.nodes, tree.links.new
    out = nodes["Material Output"]
    bsdf, normal_map = nodes.new("ShaderNodeBsdfPrincipled"), nodes.new("ShaderNodeNormalMap")
    if source == "rgb":
        src = nodes.new("ShaderNodeRGB")
        src.outputs[0].default_value = (*(NORMAL * 0.5 + 0.5), 1.0)
    else:
        src = nodes.new("ShaderNodeTexImage")
        src.name, src.image = "Bumps", _gone("Bumps")
    link(src.outputs[0], normal_map.inputs["Color"])
    if carrier != "closure argument":
        link(normal_map.outputs[0], bsdf.inputs["Normal"])
    if carrier == "closure argument":
        # the Normal given to the closure where it is evaluated (an input item of both)
        zin, zout = nodes.new("NodeClosureInput"), nodes.new("NodeClosureOutput")
        assert zin.pair_with_output(zout)
        zout.input_items.new("VECTOR", "Normal")
        zout.output_items.new("SHADER", "BSDF")
        link(zin.outputs["Normal"], bsdf.inputs["Normal"])
        link(bsdf.outputs[0], zout.inputs["BSDF"])
        evaluate = nodes.new("NodeEvaluateClosure")
        evaluate.input_items.new("VECTOR", "Normal")
        evaluate.output_items.new("SHADER", "BSDF")
        link(zout.outputs[0], evaluate.inputs[0])
        link(normal_map.outputs[0], evaluate.inputs["Normal"])
        link(evaluate.outputs["BSDF"], out.inputs["Surface"])
    elif carrier == "closure":
        zin, zout = nodes.new("NodeClosureInput"), nodes.new("NodeClosureOutput")
        assert zin.pair_with_output(zout)
        zout.output_items.new("SHADER", "BSDF")
        link(bsdf.outputs[0], zout.inputs["BSDF"])
        evaluate = nodes.new("NodeEvaluateClosure")
        evaluate.output_items.new("SHADER", "BSDF")
        link(zout.outputs[0], evaluate.inputs[0])
        link(evaluate.outputs["BSDF"], out.inputs["Surface"])
    else:
        combine, separate = nodes.new("NodeCombineBundle"), nodes.new("NodeSeparateBundle")
        combine.bundle_items.new("SHADER", "Skin")
        separate.bundle_items.new("SHADER", "Skin")
        link(bsdf.outputs[0], combine.inputs["Skin"])
        link(combine.outputs[0], separate.inputs[0])
        link(separate.outputs["Skin"], out.inputs["Surface"])
    return obj, tree, bsdf


@needs_closures
@pytest.mark.tier("bake")
@pytest.mark.parametrize("carrier", CARRIERS)
def test_the_normal_through_a_closure_or_bundle_is_baked(tmp_path, carrier):
    """Finding 1's premise: Cycles bakes the normal a closure or bundle carries (the product
    stands the BSDF in there too): every texel the 60-degree normal fed in."""
    obj, _tree, _bsdf = _carried_plane(carrier, "rgb")
    got = baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
    assert degrees_between(got, NORMAL).max() < 0.05


@needs_closures
@pytest.mark.tier("bake")
@pytest.mark.parametrize("carrier", CARRIERS)
def test_a_missing_normal_map_inside_a_closure_or_bundle_is_refused(tmp_path, carrier):
    """Finding 1: refused, nothing written (before: a map 54.7 degrees off the surface,
    exit 0, and a warning that said the image feeds no normal)."""
    obj, _tree, _bsdf = _carried_plane(carrier, "missing")
    with pytest.raises(BakeRequestError, match="image 'Bumps' reads .*which does not exist: "
                                               "Cycles would bake its magenta"):
        baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
    assert list(tmp_path.iterdir()) == []


@needs_closures
@pytest.mark.parametrize("carrier", CARRIERS)
def test_only_the_normals_image_inside_a_closure_is_refused(carrier):
    """Finding 1: the Normal Map's image is a problem, a Base Color image beside it in the
    same zone still only a warning (the stand-in reads no colour)."""
    obj, tree, bsdf = _carried_plane(carrier, "missing")
    colour = tree.nodes.new("ShaderNodeTexImage")
    colour.name, colour.image = "Albedo", _gone("Albedo")
    tree.links.new(colour.outputs[0], bsdf.inputs["Base Color"])
    warned = []
    problems = image_problems(obj, warnings=warned)
    assert len(problems) == 1 and "image 'Bumps' reads" in problems[0], (problems, warned)
    assert len(warned) == 1 and "image 'Albedo' reads" in warned[0], (problems, warned)


@needs_closures
def test_the_normals_file_inside_a_closure_is_stamped():
    """Finding 1: the file-changed-during-the-bake check stamps the normal's file (before:
    left out, so a normal map re-saved mid-bake was never noticed)."""
    obj, _tree, _bsdf = _carried_plane("closure", "missing")
    assert list(stamps(obj)) == ["/nonexistent/surfgrad55a/Bumps.png"]


# 2 --------------------------------------------------------------------------------------------

@pytest.mark.tier("bake")
def test_a_bake_of_a_modified_object_runs_no_render_handler(tmp_path):
    """Finding 2: a render counter (render_pre) and a "render done" notice (render_complete)
    of the session are not run by the bake's render-mode pass, and stay registered, in order
    (before: 4 handler calls a bake, the scene's counter at 1)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    calls = []

    def count(scene, *_):
        calls.append("pre")
        scene["renders"] = scene.get("renders", 0) + 1

    def notice(*_):
        calls.append("complete")

    def other(*_):
        calls.append("other")
    handlers = bpy.app.handlers
    lists = (handlers.render_init, handlers.render_pre, handlers.render_post,
             handlers.render_complete)
    before = [list(h) for h in lists]
    handlers.render_pre.append(count)
    handlers.render_pre.append(other)
    handlers.render_complete.append(notice)
    handlers.render_init.append(other)
    handlers.render_post.append(other)
    try:
        bpy.ops.mesh.primitive_plane_add(size=2)
        obj = bpy.context.active_object
        obj.modifiers.new("Smooth", "SUBSURF")          # a modifier: the render-mode pass runs
        obj.data.materials.append(new_material("Artist"))
        got = baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
        assert degrees_between(got, np.array([0.0, 0.0, 1.0])).max() < 0.05
        assert calls == [], calls
        assert "renders" not in bpy.context.scene
        assert list(handlers.render_pre)[-2:] == [count, other]
        assert list(handlers.render_complete)[-1] is notice
        assert list(handlers.render_init)[-1] is other and list(handlers.render_post)[-1] is other
    finally:
        for h, was in zip(lists, before):
            h[:] = was


# 3 --------------------------------------------------------------------------------------------

def _zone_with_a_normal_argument(linked):
    """A plane whose Material Output takes an Evaluate Closure of a Closure Zone that has an
    argument named Normal (unused inside, or fed the Geometry's Normal when `linked`) and
    returns a Principled BSDF fed its own Normal Map, 60 degrees off the surface."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2)
    obj = bpy.context.active_object
    mat = new_material("Layer")
    obj.data.materials.append(mat)
    nodes, link = mat.node_tree.nodes, mat.node_tree.links.new
    for node in [n for n in nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        nodes.remove(node)
    zin, zout = nodes.new("NodeClosureInput"), nodes.new("NodeClosureOutput")
    assert zin.pair_with_output(zout)
    zout.input_items.new("VECTOR", "Normal")
    zout.output_items.new("SHADER", "BSDF")
    bsdf, normal_map = nodes.new("ShaderNodeBsdfPrincipled"), nodes.new("ShaderNodeNormalMap")
    rgb = nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (*(NORMAL * 0.5 + 0.5), 1.0)
    link(rgb.outputs[0], normal_map.inputs["Color"])
    link(normal_map.outputs[0], bsdf.inputs["Normal"])
    link(bsdf.outputs[0], zout.inputs["BSDF"])
    evaluate = nodes.new("NodeEvaluateClosure")
    evaluate.input_items.new("VECTOR", "Normal")
    evaluate.output_items.new("SHADER", "BSDF")
    link(zout.outputs[0], evaluate.inputs[0])
    if linked:
        link(nodes.new("ShaderNodeNewGeometry").outputs["Normal"], evaluate.inputs["Normal"])
    link(evaluate.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])
    return obj, mat


@needs_closures
@pytest.mark.tier("bake")
@pytest.mark.parametrize("linked", [False, True])
def test_an_evaluate_closure_with_a_normal_argument_is_not_stood_in(tmp_path, linked):
    """Finding 3: the map is the zone's BSDF normal, every texel (before: 60.0 degrees off,
    the surface's own normal)."""
    obj, mat = _zone_with_a_normal_argument(linked)
    before = sorted((n.name, n.bl_idname) for n in mat.node_tree.nodes)
    got = baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
    assert degrees_between(got, NORMAL).max() < 0.05
    assert sorted((n.name, n.bl_idname) for n in mat.node_tree.nodes) == before
