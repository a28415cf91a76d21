"""A group made by a newer surfgrad (a colleague's file opened with an older extension) is
not rebuilt down to this version: that dropped from every node using it what the newer
version added (an input, its value and its links), silently. Adding the group is refused with
the fix; the file is left as it was. An older group is still rebuilt in place."""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon.groups import VERSION  # noqa: E402
from surfgrad_addon.addon.node_builder import VERSION_KEY  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _material_using(tree):
    mat = bpy.data.materials.new("M")
    mat.use_nodes = True
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    return mat, node


def test_a_group_from_a_newer_surfgrad_is_refused_not_downgraded(fresh):
    tree = api.node_group("SG Combine")
    tree[VERSION_KEY] = VERSION + 1
    tree.interface.new_socket("Extra", in_out="INPUT", socket_type="NodeSocketFloat")
    mat, node = _material_using(tree)
    node.inputs["Extra"].default_value = 0.25
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(value.outputs[0], node.inputs["Extra"])
    nodes_before = sorted(n.name for n in tree.nodes)
    with pytest.raises(ValueError) as err:
        api.node_group("SG Combine")
    assert (f"node group 'SG Combine' was made by a newer surfgrad (group version "
            f"{VERSION + 1}; this extension makes {VERSION})") in str(err.value)
    assert "update the surfgrad extension" in str(err.value)
    # Nothing changed: the newer input, its value and its link are still there.
    assert tree[VERSION_KEY] == VERSION + 1
    assert sorted(n.name for n in tree.nodes) == nodes_before
    assert node.inputs["Extra"].default_value == pytest.approx(0.25)
    assert node.inputs["Extra"].links[0].from_node == value


def test_an_older_group_is_still_rebuilt_in_place(fresh):
    tree = api.node_group("SG Combine")
    tree[VERSION_KEY] = VERSION - 1
    _, node = _material_using(tree)
    node.inputs["Scale B"].default_value = -2.0
    assert api.node_group("SG Combine") == tree and tree[VERSION_KEY] == VERSION
    assert node.inputs["Scale B"].default_value == pytest.approx(-2.0)
