"""An artist's file over time (red team 32c): a material appended from a file with older
surface-gradient groups into a file that already has them gets Blender's "SG Decal.001"
copies. Those used to stay at their old version (and old line's interior: an integer Shape on
5.x, the old Bump step) for good, beside the current groups: adding groups rebuilt only the
un-suffixed ones. Now a stale copy is rebuilt in place too, keeping its nodes' links and values.

A material linked (not appended) from such a file brings its groups in as library data. Adding
that group from the Add menu (or api.node_group) rebuilt the library's group in place, an edit
never saved, and gave the artist's new node that library group: reopened, the node had the
library's old version (an integer Shape again, the artist's choice gone) and depended on the
library. Now surfgrad builds and uses its own local group beside the linked one.

A group built for an image (or, up to 4.5, a UV map) whose name is as long as Blender allows
got a name Blender cut to fit: each Add or api.node_group made yet another copy of the group.
Now the name is cut by surfgrad with a hash of the whole, the same for the same image.

Convert to Surface Gradient of a node inside a Frame put the new nodes outside it, at the
node's frame-relative location taken as absolute (far from where the node was, the frame left
empty). Now they are in the node's frame where the node was; likewise Add Layer Stack's nodes
beside a surface shader in a frame, and Freeze's frozen chain beside a shader in a frame.
"""

from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import enum_input  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.harness import scenes as test_scenes  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.addon.groups import VERSION  # noqa: E402
from surfgrad_addon.addon.node_builder import LINE_KEY, VERSION_KEY, running_line  # noqa: E402

pytestmark = pytest.mark.tier("blender")

DEMO = Path(__file__).resolve().parent.parent / "demo.blend"
CONE = "Decal shapes: cone surface gradient"


def _current(tree):
    return tree.get(VERSION_KEY) == VERSION and tree.get(LINE_KEY) == running_line().line


def _group_nodes(mat, prefix):
    return [n for n in mat.node_tree.nodes
            if n.type == "GROUP" and n.node_tree and n.node_tree.name.startswith(prefix)]


def test_an_older_copy_of_a_group_is_rebuilt_with_its_values_kept(fresh):
    api.node_group("SG Decal")
    old = api.node_group("SG Combine").copy()          # "SG Combine.001"
    old[VERSION_KEY] = VERSION - 1
    mat = bpy.data.materials.new("M")
    mat.use_nodes = True
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = old
    node.inputs["Scale B"].default_value = -3.5
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(value.outputs[0], node.inputs["Scale A"])
    api.node_group("SG Combine")
    assert old.name == "SG Combine.001" and _current(old)
    assert node.node_tree == old
    assert node.inputs["Scale B"].default_value == pytest.approx(-3.5)
    assert node.inputs["Scale A"].links[0].from_node == value


def test_a_copy_of_the_current_version_or_a_users_group_is_left_alone(fresh):
    tree = api.node_group("SG Combine")
    same = tree.copy()
    same.nodes.new("ShaderNodeMath").name = "mine"      # an edit of the artist's
    foreign = bpy.data.node_groups.new("SG Combine.002", "ShaderNodeTree")   # not stamped
    api.node_group("SG Combine")
    assert "mine" in same.nodes
    assert VERSION_KEY not in foreign and len(foreign.nodes) == 0


@pytest.mark.skipif(not DEMO.exists(), reason="demo.blend not in this checkout")
def test_a_material_appended_from_an_older_file_is_brought_up_to_date(fresh):
    api.node_group("SG Decal")
    with bpy.data.libraries.load(str(DEMO)) as (_, into):
        into.materials = [CONE]
    mat = bpy.data.materials[CONE]
    (decal,) = _group_nodes(mat, "SG Decal.")
    assert not _current(decal.node_tree)                 # demo.blend: older version, 4.5
    chosen = enum_input.choice_index(decal.inputs["Shape"]) \
        if decal.inputs["Shape"].type == "MENU" else decal.inputs["Shape"].default_value
    assert chosen == 3                                   # Cone
    api.node_group("SG Decal")
    stale = [g.name for g in bpy.data.node_groups
             if g.name.startswith("SG Decal.") and not _current(g)]
    assert not stale
    assert enum_input.choice_index(decal.inputs["Shape"]) == 3
    assert all(lk.is_valid for lk in mat.node_tree.links)


def test_a_group_linked_from_a_library_is_neither_edited_nor_used(fresh, tmp_path):
    old = api.node_group("SG Combine")
    old[VERSION_KEY] = VERSION - 1
    lib_mat = bpy.data.materials.new("Library")
    lib_mat.use_nodes = True
    lib_mat.node_tree.nodes.new("ShaderNodeGroup").node_tree = old
    library = tmp_path / "library.blend"
    bpy.data.libraries.write(str(library), {lib_mat}, fake_user=True)
    bpy.data.materials.remove(lib_mat)
    bpy.data.node_groups.remove(old)
    with bpy.data.libraries.load(str(library), link=True) as (_, into):
        into.materials = ["Library"]
    (linked,) = [g for g in bpy.data.node_groups if g.library is not None]
    nodes = sorted(n.name for n in linked.nodes)
    tree = api.node_group("SG Combine")
    assert tree.library is None and tree.name == "SG Combine" and _current(tree)
    assert linked.get(VERSION_KEY) == VERSION - 1
    assert sorted(n.name for n in linked.nodes) == nodes


def test_a_group_for_a_long_image_name_is_built_once(fresh):
    limit = bpy.types.ID.bl_rna.properties["name"].length_max - 1
    one, two = (bpy.data.images.new("H" * (limit - 1) + c, 4, 4) for c in "AB")
    assert len(one.name.encode()) == limit
    first = api.node_group("SG Height Map HQ", image=one)
    assert api.node_group("SG Height Map HQ", image=one) == first
    other = api.node_group("SG Height Map HQ", image=two)
    assert other != first
    trees = [g for g in bpy.data.node_groups if g.name.startswith("SG Height Map HQ")]
    assert len(trees) == 2
    for tree, image in ((first, one), (other, two)):
        assert {n.image for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"} == {image}


@pytest.mark.parametrize("kind", ["ShaderNodeNormalMap", "ShaderNodeBump"])
def test_convert_keeps_the_new_nodes_in_the_nodes_frame(fresh, kind):
    mat = bpy.data.materials.new("M")
    mat.use_nodes = True
    tree = mat.node_tree
    shader = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    frame = tree.nodes.new("NodeFrame")
    frame.location = (-2000.0, 800.0)
    node = tree.nodes.new(kind)
    node.parent = frame
    node.location = (-300.0, 100.0)              # relative to the frame
    if kind == "ShaderNodeBump":
        node.inputs["Strength"].default_value = 0.5      # adds the strength helper too
        value = tree.nodes.new("ShaderNodeValue")
        tree.links.new(value.outputs[0], node.inputs["Distance"])
        node.invert = True                              # adds a Math node
    tree.links.new(node.outputs["Normal"], shader.inputs["Normal"])
    before = set(tree.nodes)
    resolve = O.convert_node(tree, node)
    added = [n for n in tree.nodes if n not in before]
    assert len(added) == (2 if kind == "ShaderNodeNormalMap" else 4)
    assert all(n.parent == frame for n in added)
    sg = resolve.inputs["Surface Gradient"].links[0].from_node
    assert tuple(resolve.location) == pytest.approx((-80.0, 100.0))
    assert tuple(sg.location)[1] == pytest.approx(100.0 - (160.0 if kind == "ShaderNodeBump" else 0))


def test_the_layer_stack_goes_in_the_shaders_frame(fresh):
    mat = bpy.data.materials.new("M")
    mat.use_nodes = True
    tree = mat.node_tree
    shader = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    frame = tree.nodes.new("NodeFrame")
    frame.location = (3000.0, -900.0)
    shader.parent = frame
    shader.location = (0.0, 0.0)
    made = api.add_layer_stack(mat)
    assert made["resolve"].parent == frame
    assert tuple(made["resolve"].location) == pytest.approx((-260.0, -420.0))
    assert {made[k].parent for k in ("combine", "normal_map")} == {frame}


@pytest.mark.tier("bake")
def test_the_frozen_chain_is_drawn_beside_a_shader_in_a_frame():
    obj = test_scenes.new_scene(["Plane"])["Plane"]
    mat, bsdf = layered_material(obj)
    frame = mat.node_tree.nodes.new("NodeFrame")
    frame.location = (3000.0, -900.0)
    bsdf.parent = frame
    bsdf.location = (0.0, 0.0)                          # drawn at (3000, -900)
    record = F.freeze(obj, 16, log=lambda *_: None)
    nodes = mat.node_tree.nodes
    added = [nodes[n] for n in record["added"] if nodes[n].bl_idname != "NodeFrame"]
    assert [tuple(n.location) for n in added] == [
        pytest.approx((3000.0 - 760 + 260 * i, -900.0 - 420)) for i in range(3)]
    assert all(n.parent is None for n in added)
