"""The artist operators' work: a layer stack wired into the BSDF, Normal Map and Bump nodes
converted with the same look (measured by bakes), decal projectors with driven axes."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import operators as O
from surfgrad_addon.harness import bake, compare, scenes as test_scenes  # noqa: E402
from surfgrad_addon.harness.graph import Graph  # noqa: E402
from surfgrad_addon.reference import images as T  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402

pytestmark = pytest.mark.tier("blender")


@pytest.fixture()
def sphere():
    return test_scenes.new_scene(["Sphere"])["Sphere"]


def _material(obj, shader="ShaderNodeBsdfPrincipled"):
    mat = new_material("Mat")
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    bsdf = tree.nodes.new(shader)
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    obj.data.materials.append(mat)
    return mat, tree, bsdf


def test_layer_stack_is_wired_into_the_bsdf_normal(sphere):
    _, tree, bsdf = _material(sphere)
    made = O.add_layer_stack(tree)
    assert bsdf.inputs["Normal"].links[0].from_node == made["resolve"]
    assert made["resolve"].inputs["Surface Gradient"].links[0].from_node == made["combine"]
    assert made["combine"].inputs["A"].links[0].from_node == made["normal_map"]
    assert made["normal_map"].node_tree.name == "SG Normal Map" and not made["replaced"]


def test_layer_stack_needs_a_bsdf(sphere):
    _, tree, _ = _material(sphere, "ShaderNodeEmission")
    with pytest.raises(O.SurfgradError, match="no Normal input"):
        O.add_layer_stack(tree)
    tree.links.clear()
    with pytest.raises(O.SurfgradError, match="no shader linked"):
        O.add_layer_stack(tree)


def _bake_converted(obj, make_node, convert):
    """Bake the node's Normal, before or after conversion (a Reroute keeps the link)."""
    def build(nodes, links):
        node = make_node(nodes, links)
        reroute = nodes.new("NodeReroute")
        links.new(node.outputs["Normal"], reroute.inputs[0])
        if convert:
            O.convert_node(node.id_data, node)
        return reroute.outputs[0]
    px, cov, _ = bake.bake_vector(obj, build, 48, 48, "UVMap")
    return px[cov]


def _image_color(nodes, links, img):
    """An Image Texture of `img` on the UV map "UVMap": its Color."""
    g = Graph(nodes, links)
    return g.image(img, g.uv("UVMap"))


def _normal_map_node(img, strength):
    def make(nodes, links):
        color = _image_color(nodes, links, img)
        nm = nodes.new("ShaderNodeNormalMap")
        nm.uv_map = "UVMap"
        nm.inputs["Strength"].default_value = strength
        links.new(color, nm.inputs["Color"])
        return nm
    return make


@pytest.mark.tier("bake")
@pytest.mark.parametrize("strength", [0.0, 0.25, 0.5, 1.0, 1.5, 2.0])
def test_normal_map_conversion_keeps_the_look(sphere, strength):
    """Cycles' Normal Map node scales x, y by Strength and blends z toward 1; SG Normal Map hands
    its Strength to the same node, so the look is kept over the whole range."""
    img = compare.bpy_float_image("nm", T.hemisphere_tile_image(64))
    make = _normal_map_node(img, strength)
    before = _bake_converted(sphere, make, False)
    after = _bake_converted(sphere, make, True)
    err = compare.angle_deg(before, after)
    assert err.max() <= 0.05, err.max()
    # The map really bends the normals (and more with Strength): not two flat results.
    spread = compare.angle_deg(before, before * 0 + [0, 0, 1.0]).std()
    assert spread > (10 if strength >= 0.5 else 1 if strength > 0 else 0), spread


def _bump_node(img, strength, distance, invert=False):
    def make(nodes, links):
        color = _image_color(nodes, links, img)
        sep = nodes.new("ShaderNodeSeparateXYZ")
        links.new(color, sep.inputs[0])
        bump = nodes.new("ShaderNodeBump")
        bump.inputs["Distance"].default_value = distance
        bump.inputs["Strength"].default_value = strength
        bump.invert = invert
        links.new(sep.outputs[0], bump.inputs["Height"])
        return bump
    return make


@pytest.mark.tier("bake")
@pytest.mark.parametrize("strength,distance,invert", [
    (1.0, 0.1, False), (0.0, 0.1, False), (0.2, 0.1, False), (0.5, 1.0, False),
    (1.0, 1.0, True), (0.7, 0.05, True), (2.0, 0.1, False)])
def test_bump_conversion_keeps_the_look(sphere, strength, distance, invert):
    """The converted group steps the Bump node's own Filter Width (the inverted Bump and the
    resolve give back the same normal); Strength != 1 is the node's blend of normals, kept by
    .SG Bump Strength."""
    img = compare.bpy_float_image("h", T.wave_height_image(64, (3.0, 2.0)))
    make = _bump_node(img, strength, distance, invert)
    before = _bake_converted(sphere, make, False)
    after = _bake_converted(sphere, make, True)
    err = compare.angle_deg(before, after)
    assert err.max() <= 0.05, err.max()
    if strength > 0:
        tilt = compare.angle_deg(before, after * 0 + [0, 0, 1.0])
        assert tilt.std() > 10


@pytest.mark.tier("bake")
def test_converted_bump_with_strength_uses_the_blend_helper(sphere):
    _, tree, bsdf = _material(sphere)
    img = compare.bpy_float_image("h", T.wave_height_image(16, (3.0, 2.0)))
    bump = _bump_node(img, 0.4, 0.2)(tree.nodes, tree.links)
    tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    resolve = O.convert_node(tree, bump)
    blend = resolve.inputs["Surface Gradient"].links[0].from_node
    assert blend.node_tree.name == ".SG Bump Strength"
    assert blend.inputs["Strength"].default_value == pytest.approx(0.4)
    forward = blend.inputs["Surface Gradient"].links[0].from_node
    assert forward.inputs["Bump Scale"].default_value == pytest.approx(0.2)
    assert bsdf.inputs["Normal"].links[0].from_node == resolve


def test_convert_refuses_other_nodes(sphere):
    _, tree, bsdf = _material(sphere)
    with pytest.raises(O.SurfgradError, match="select a Normal Map or a Bump node"):
        O.convert_node(tree, bsdf)
    nm = tree.nodes.new("ShaderNodeNormalMap")
    nm.space = "OBJECT"
    with pytest.raises(O.SurfgradError, match="SG Object Normal"):
        O.convert_node(tree, nm)


def test_decal_projector_axes_follow_the_empty(sphere):
    _, tree, _ = _material(sphere)
    empty, decal = O.add_decal_projector(bpy.context, tree)
    empty.rotation_euler = (0.3, -0.5, 1.2)
    empty.scale = (2.0, 0.5, 1.0)
    bpy.context.view_layer.update()
    bpy.context.scene.frame_set(bpy.context.scene.frame_current)   # evaluate the drivers
    m = np.array(empty.matrix_world)[:3, :3]
    for socket, column in (("Axis X", 0), ("Axis Y", 1)):
        got = np.array(decal.inputs[socket].default_value)
        np.testing.assert_allclose(got, m[:, column] / np.linalg.norm(m[:, column]), atol=1e-5)
    # SG Projector Coordinates: the empty's location and world-to-local rows, driven.
    empty.location = (9000.25, -4000.5, 120.0)
    bpy.context.view_layer.update()
    bpy.context.scene.frame_set(bpy.context.scene.frame_current)
    pc = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"
              and n.node_tree.name == "SG Projector Coordinates")
    full = np.array(empty.matrix_world)
    np.testing.assert_array_equal(np.array(pc.inputs["Projector Location"].default_value),
                                  np.float32(full[:3, 3]))
    inverse = np.linalg.inv(full[:3, :3])
    for axis, row in zip("XYZ", inverse):
        np.testing.assert_allclose(np.array(pc.inputs[f"To Projector {axis}"].default_value),
                                   row, rtol=1e-5, atol=1e-6)
    assert pc.inputs["Decal Coordinates"].links[0].from_node.object == empty
    assert pc.outputs["Decal Coordinates"].links[0].to_node.node_tree.name in (
        "SG Decal Coordinates", "SG Decal")
