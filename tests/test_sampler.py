"""Sampler closures (Blender 5.0+): the Python API the Sampler groups and the Add menu rely on,
pinned; the menu's choice of groups per line; the Sampler zone the menu builds around the active
Image Texture (or empty). The bakes against the reference are test_bake_compare's *-sampler
methods; EEVEE against Cycles is test_eevee's."""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import ui  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.sampler_zone import has_closures  # noqa: E402

pytestmark = pytest.mark.tier("blender")


closures = pytest.mark.skipif(not has_closures(), reason="Closure zones and Evaluate Closure "
                              "exist from Blender 5.0 (docs/versions.md)")
no_closures = pytest.mark.skipif(has_closures(), reason="this line has closures")
SAMPLERS = sorted(G.SAMPLER_GROUPS)


@closures
def test_the_closure_api_we_rely_on(fresh):
    """Zone nodes pair; the Closure Output's items make the zone's sockets; Evaluate Closure
    takes the same items after its Closure socket; a group interface takes a Closure input."""
    tree = bpy.data.node_groups.new("probe", "ShaderNodeTree")
    zin, zout = tree.nodes.new("NodeClosureInput"), tree.nodes.new("NodeClosureOutput")
    assert zin.pair_with_output(zout)
    zout.input_items.new("VECTOR", "Vector")
    zout.output_items.new("RGBA", "Color")
    assert [(s.name, s.type) for s in zin.outputs if s.type != "CUSTOM"] == [("Vector", "VECTOR")]
    assert [(s.name, s.type) for s in zout.inputs if s.type != "CUSTOM"] == [("Color", "RGBA")]
    assert [(s.name, s.type) for s in zout.outputs] == [("Closure", "CLOSURE")]
    ev = tree.nodes.new("NodeEvaluateClosure")
    ev.input_items.new("VECTOR", "Vector")
    ev.output_items.new("RGBA", "Color")
    assert [(s.name, s.type) for s in ev.inputs if s.type != "CUSTOM"] == \
        [("Closure", "CLOSURE"), ("Vector", "VECTOR")]
    assert [(s.name, s.type) for s in ev.outputs if s.type != "CUSTOM"] == [("Color", "RGBA")]
    link = tree.links.new(zout.outputs[0], ev.inputs[0])
    assert link.is_valid
    item = tree.interface.new_socket("Sampler", in_out="INPUT", socket_type="NodeSocketClosure")
    assert item.socket_type == "NodeSocketClosure" and not hasattr(item, "default_value")


@closures
def test_the_menu_offers_the_sampler_groups_instead_of_the_per_image_ones():
    names = ui.menu_group_names()
    assert set(SAMPLERS) <= set(names)
    for per_image in ("SG Height Map HQ", "SG Triplanar Height", "SG Parallax"):
        assert per_image not in names
    assert "SG Triplanar" in names          # three colours: still useful with three images


@no_closures
def test_older_lines_offer_the_per_image_groups_and_refuse_the_sampler_ones(fresh):
    names = ui.menu_group_names()
    assert not set(SAMPLERS) & set(names)
    assert {"SG Height Map HQ", "SG Triplanar Height", "SG Parallax"} <= set(names)
    with pytest.raises(G.FeatureUnavailable, match="needs Blender 5.0 or newer.*Evaluate"):
        G.parallax_sampler_group()
    mat = new_material("M")
    with pytest.raises(ValueError, match="5.0"):
        ui.add_group_node(mat.node_tree, "SG Parallax (Sampler)")


@closures
def test_the_menu_wraps_the_active_image_texture_in_a_sampler_zone(fresh):
    mat = new_material("M")
    tree = mat.node_tree
    img = bpy.data.images.new("rock_height", 64, 32, float_buffer=True)
    uv = tree.nodes.new("ShaderNodeUVMap")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    tree.links.new(uv.outputs[0], tex.inputs["Vector"])
    bsdf = tree.nodes["Principled BSDF"]
    tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])   # another use: kept
    tex.interpolation, tex.extension = "Closest", "EXTEND"
    tree.nodes.active = tex
    node = ui.add_group_node(tree, "SG Height Map HQ (Sampler)")
    zin = next(n for n in tree.nodes if n.bl_idname == "NodeClosureInput")
    zout = next(n for n in tree.nodes if n.bl_idname == "NodeClosureOutput")
    # The texture feeds the Base Color too: it stays with its links, a copy goes in the zone.
    inside = zout.inputs["Color"].links[0].from_node
    assert inside != tex and inside.bl_idname == "ShaderNodeTexImage"
    assert (inside.image, inside.interpolation, inside.extension) == (img, "Closest", "EXTEND")
    assert inside.inputs["Vector"].links[0].from_node == zin
    assert bsdf.inputs["Base Color"].links[0].from_node == tex
    assert tex.inputs["Vector"].links[0].from_node == uv
    assert node.inputs["Sampler"].links[0].from_node == zout
    assert node.inputs["UV"].links[0].from_node == uv
    assert (node.inputs["Image Width"].default_value,
            node.inputs["Image Height"].default_value) == (64, 32)
    assert all(link.is_valid for link in tree.links)
    # One group for every image: a second image reuses it. A texture with no other use is
    # itself wrapped in the zone (no copy).
    tex2 = tree.nodes.new("ShaderNodeTexImage")
    tex2.image = bpy.data.images.new("other", 16, 16)
    tree.nodes.active = tex2
    n_tex = len([n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"])
    node2 = ui.add_group_node(tree, "SG Height Map HQ (Sampler)")
    assert node2.node_tree == node.node_tree
    assert node2.inputs["Sampler"].links[0].from_node.inputs["Color"].links[0].from_node == tex2
    assert len([n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"]) == n_tex
    assert len([g for g in bpy.data.node_groups if g.name.startswith("SG Height Map")]) == 1


@closures
@pytest.mark.parametrize("name", SAMPLERS)
def test_every_sampler_group_gets_an_empty_zone_without_an_image_texture(fresh, name):
    mat = new_material("M")
    tree = mat.node_tree
    tree.nodes.active = tree.nodes["Principled BSDF"]
    node = ui.add_group_node(tree, name)
    zout = node.inputs["Sampler"].links[0].from_node
    assert zout.bl_idname == "NodeClosureOutput" and not zout.inputs["Color"].is_linked
    evaluations = [n for n in node.node_tree.nodes if n.bl_idname == "NodeEvaluateClosure"]
    taps = {"SG Height Map HQ (Sampler)": 16, "SG Height Map One-Texel (Sampler)": 3,
            "SG Triplanar (Sampler)": 3, "SG Triplanar Height (Sampler)": 9,
            "SG Parallax (Sampler)": 1 + 9}[name]
    assert len(evaluations) == taps
    assert not [n for n in node.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage"]
