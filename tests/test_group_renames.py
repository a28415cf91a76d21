"""A saved file keeps its links and values across an add-on update that renames a socket
(SocketSpec.renamed_from) or turns an integer into a Menu (enumerations, addon/enum_input.py),
and set_choice sets an enumeration by item index on every line."""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.enum_input import set_choice  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from surfgrad_addon.reference.group_interfaces import INTERFACES  # noqa: E402

pytestmark = pytest.mark.tier("blender")

MENUS = facts_for(bpy.app.version).menu_sockets


def _as_saved_by_the_old_version(tree, new_name, old_name):
    """The group as the previous add-on saved it: the socket under its old name, an older
    version stamp (so the next use rebuilds it)."""
    item = next(it for it in tree.interface.items_tree
                if it.item_type == "SOCKET" and it.in_out == "INPUT" and it.name == new_name)
    item.name = old_name
    tree["surfgrad_version"] = G.common.VERSION - 1
    return item.identifier


RENAMES = [("SG Volume Gradient", G.volume_gradient_group, "Bump Scale", "Strength", 0.3),
           ("SG Parallax", G.parallax_group, "Depth", "Bump Scale", 0.07),
           ("SG Height Map HQ (Sampler)", G.height_map_sampler_group, "Image Height", "Height",
            512)]


@pytest.mark.parametrize("group,build,new,old,value", RENAMES, ids=[r[0] for r in RENAMES])
def test_a_renamed_socket_keeps_its_link_and_value(fresh, group, build, new, old, value):
    if G.unavailable_reason(group):
        pytest.skip(G.unavailable_reason(group))
    spec = next(s for s in INTERFACES[group].inputs if s.name == new)
    assert old in spec.renamed_from
    tree = build()
    identifier = _as_saved_by_the_old_version(tree, new, old)
    mat = new_material("User")
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    linked, typed = nodes.new("ShaderNodeGroup"), nodes.new("ShaderNodeGroup")
    linked.node_tree = typed.node_tree = tree
    source = nodes.new("ShaderNodeValue")
    links.new(source.outputs[0], linked.inputs[old])
    typed.inputs[old].default_value = value
    assert new not in typed.inputs

    rebuilt = build()
    assert rebuilt == tree and rebuilt["surfgrad_version"] == G.common.VERSION
    assert old not in typed.inputs
    assert typed.inputs[new].identifier == identifier
    assert typed.inputs[new].default_value == pytest.approx(value)
    assert linked.inputs[new].is_linked
    assert linked.inputs[new].links[0].from_node == source
    assert all(link.is_valid for link in links)


def test_set_choice_sets_an_item_by_index_on_every_line(fresh):
    tree = G.blend_normals_group()
    mat = new_material("User")
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    socket = node.inputs["Method"]
    names = INTERFACES["SG Blend Normals"].inputs[-1].item_names()
    assert names == ("Partial Derivative", "Whiteout", "UDN", "RNM")
    assert socket.type == ("MENU" if MENUS else "INT")
    assert socket.default_value == (names[0] if MENUS else 0)
    for index, name in enumerate(names):
        set_choice(socket, index)
        assert socket.default_value == (name if MENUS else index)


ENUMERATIONS = [(G.blend_normals_group, "Method",
                 ["Partial Derivative", "Whiteout", "UDN", "RNM"]),
                (G.decal_group, "Shape", ["Box", "Sphere", "Cylinder", "Cone", "Wedge",
                                          "Capsule"])]


@pytest.mark.skipif(not MENUS, reason="integers stay integers on lines without Menu sockets")
@pytest.mark.parametrize("build,name,items", ENUMERATIONS, ids=["Method", "Shape"])
def test_an_integer_saved_by_the_old_version_becomes_the_item_of_that_index(fresh, build, name,
                                                                           items):
    """A file saved when the enumeration was an integer: its value chooses the same item after
    the rebuild makes it a Menu."""
    tree = build()
    iface = tree.interface
    iface.remove(next(it for it in iface.items_tree
                      if it.item_type == "SOCKET" and it.name == name))
    old = iface.new_socket(name, in_out="INPUT", socket_type="NodeSocketInt")
    tree["surfgrad_version"] = G.common.VERSION - 1
    mat = new_material("User")
    nodes = [mat.node_tree.nodes.new("ShaderNodeGroup") for _ in items]
    for k, node in enumerate(nodes):
        node.node_tree = tree
        node.inputs[name].default_value = k
    assert nodes[0].inputs[name].identifier == old.identifier
    build()
    assert [n.inputs[name].type for n in nodes] == ["MENU"] * len(items)
    assert [n.inputs[name].default_value for n in nodes] == items
