"""Coordinator, round 50: an image wired straight into a normal input, with no Normal Map node.

A beginner's slip and an importer's (a normal map's Color linked to the Principled BSDF's
Normal): Blender reads the colour, 0..1 per axis, as a world-space direction. Every normal
then leans toward (1, 1, 1); a flat normal map (0.5, 0.5, 1) tilts the plane by
atan(|(0.5, 0.5)| / 1) = 35.26 degrees. bake-normal-map bakes what Cycles renders, so the map
came out 35 degrees off with exit 0 and no word, on every line; Freeze the same. Now the bake
(bake_request), the api and Freeze warn, naming the image, the input, the node and the fix
(normal_map_checks.raw_image_normal_warnings); a decode between (Vector Math, a Normal Map
node) is meant and not warned about.
"""

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon.normal_map_checks import raw_image_normal_warnings  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_materials39 import _cycles_plane  # noqa: E402

pytestmark = pytest.mark.tier("bake")

FLAT = (0.5, 0.5, 1.0, 1.0)       # a normal map's flat texel


def _plane_reading(shader="ShaderNodeBsdfPrincipled"):
    """A plane whose `shader` reads a flat-normal-map image's Color in its Normal input."""
    obj = _cycles_plane()
    mat, tree, diffuse = diffuse_material("Imported")
    bsdf = tree.nodes.new(shader)
    tree.links.new(bsdf.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    tree.nodes.remove(diffuse)
    obj.data.materials.append(mat)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.name = "Normal Texture"
    tex.image = bpy.data.images.new("Flat Normals", 4, 4, float_buffer=True)
    tex.image.generated_color = FLAT
    tex.image.colorspace_settings.is_data = True
    return obj, mat, tree, bsdf, tex


def test_a_bake_of_an_image_in_the_normal_input_is_warned_about(tmp_path, capfd):
    obj, mat, tree, bsdf, tex = _plane_reading()
    tree.links.new(tex.outputs["Color"], bsdf.inputs["Normal"])
    res = 8
    out = tmp_path / "n.exr"
    api.bake_normal_map(obj, str(out), resolution=res, margin=0, log=None)
    said = capfd.readouterr().err
    assert "image 'Flat Normals' is wired straight into the Normal input of node " \
           "'Principled BSDF' (material 'Imported')" in said, said
    assert "put a Normal Map node between them" in said
    # What it warns of: the baked map holds the colour as a direction, 35.26 degrees off the
    # flat map the image is (tangent space on the default plane: T = +X, B = +Y).
    img = bpy.data.images.load(str(out))
    px = np.array(img.pixels[:]).reshape(res, res, 4)[..., :3] * 2.0 - 1.0
    px /= np.linalg.norm(px, axis=-1, keepdims=True)
    expect = np.array(FLAT[:3]) / np.linalg.norm(FLAT[:3])
    assert np.degrees(np.arccos(np.clip(px @ expect, -1, 1))).max() < 0.05
    assert math.degrees(math.acos(expect[2])) == pytest.approx(35.26, abs=0.01)
    # The same with a Normal Map node between: no such warning, and the flat map bakes flat.
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    api.bake_normal_map(obj, str(out), resolution=res, margin=0, overwrite=True, log=None)
    assert "wired straight into" not in capfd.readouterr().err


def test_each_normal_input_and_path_is_followed():
    """Through a reroute into a user's group whose inside feeds a BSDF's Coat Normal; a Bump
    node's Normal; an SG group's base Normal. Not through a decode (Vector Math)."""
    obj, mat, tree, bsdf, tex = _plane_reading()
    assert raw_image_normal_warnings(obj) == []
    # Nodes that read a normal for a value (Fresnel, Layer Weight into Roughness) bend no
    # normal the bake takes: not warned (red team 52b).
    for kind in ("ShaderNodeFresnel", "ShaderNodeLayerWeight"):
        reader = tree.nodes.new(kind)
        tree.links.new(tex.outputs["Color"], reader.inputs["Normal"])
        tree.links.new(reader.outputs[0], bsdf.inputs["Roughness"])
        assert raw_image_normal_warnings(obj) == [], kind
        tree.nodes.remove(reader)
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(tex.outputs["Color"], reroute.inputs[0])
    group = bpy.data.node_groups.new("Artist Coat", "ShaderNodeTree")
    group.interface.new_socket("Coat", in_out="INPUT", socket_type="NodeSocketVector")
    group.interface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    g_in, g_out = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    inner = group.nodes.new("ShaderNodeBsdfPrincipled")
    coat = "Coat Normal" if "Coat Normal" in inner.inputs else "Clearcoat Normal"
    group.links.new(g_in.outputs[0], inner.inputs[coat])
    group.links.new(inner.outputs[0], g_out.inputs[0])
    user = tree.nodes.new("ShaderNodeGroup")
    user.node_tree = group
    tree.links.new(reroute.outputs[0], user.inputs[0])
    tree.links.new(user.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    (warning,) = raw_image_normal_warnings(obj)
    assert f"into the {coat} input of node 'Group > Principled BSDF'" in warning, warning
    # A decode between (2 c - 1, an object-space workflow's) is meant: not warned.
    decode = tree.nodes.new("ShaderNodeVectorMath")
    decode.operation = "MULTIPLY_ADD"
    decode.inputs[1].default_value = (2.0, 2.0, 2.0)
    decode.inputs[2].default_value = (-1.0, -1.0, -1.0)
    tree.links.new(reroute.outputs[0], decode.inputs[0])
    tree.links.new(decode.outputs[0], user.inputs[0])
    assert raw_image_normal_warnings(obj) == []
    # A Bump node's Normal.
    bump = tree.nodes.new("ShaderNodeBump")
    tree.links.new(tex.outputs["Color"], bump.inputs["Normal"])
    tree.links.new(bump.outputs[0], bsdf.inputs["Normal"])
    tree.links.new(bsdf.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    (warning,) = raw_image_normal_warnings(obj)
    assert "into the Normal input of node 'Bump'" in warning, warning
    # An SG group's base normal.
    sg = tree.nodes.new("ShaderNodeGroup")
    sg.node_tree = api.node_group("SG Resolve")
    tree.links.new(tex.outputs["Color"], sg.inputs["Normal"])
    tree.links.new(sg.outputs[0], bsdf.inputs["Normal"])
    (warning,) = raw_image_normal_warnings(obj)
    assert f"into the Normal input of node {sg.name!r}" in warning, warning
    assert sum("wired straight into" in w for w in F.freeze_warnings(obj, mat)) == 1
