"""The operators are all-or-nothing and the artist hears everything (red team 35a).

- Update surfgrad Groups rebuilt each stale group in turn: when one was refused (a helper it
  builds was made by a newer surfgrad), the groups rebuilt before it stayed rebuilt, and the
  operator said only that it was refused. The operators that add groups did the same with the
  groups they need (Add Layer Stack: a stale SG Resolve rebuilt, then SG Combine refused). Now
  every group a request builds is built on scratch groups first (node_builder.checked_first),
  and a refusal anywhere changes no group.
- A stale copy ("SG Combine.001") with no original beside it: the update built the original
  too, and left it in the file unused.
- Freeze: the warnings about the normal maps the stack reads (a grey PNG) were said only after a
  freeze that succeeded; a refused freeze (another mesh uses the material) dropped them.
- Thaw of a material whose freeze record is not one (a hand-edited or foreign custom property
  under its name) raised a raw traceback (JSONDecodeError, KeyError, TypeError).
- An edit that failed after it had linked its nodes into an input (the layer stack into the
  BSDF's Normal) was taken away, but the link it had replaced (the user's Normal Map node into
  Normal) was lost with it, and the nodes' selection changed.
- Convert (of the Normal Map node inside SG Normal Map) and Add Decal Projector (inside SG
  Decal), with the editor showing the inside of one of our groups (Tab), raised a raw
  KeyError: Blender keeps a group out of itself, so the new group node had no sockets. Now
  refused, naming the group and the fix, nothing changed.
- Undo headless: Update surfgrad Groups and Thaw (the operators the child sessions of
  test_operators_ui, test_extension and test_freeze_operators leave out) undo and redo in this
  process on every line, and a refused update adds no undo step.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import freeze_operators as FO  # noqa: E402
from surfgrad_addon.addon import group_updates as U  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402
from surfgrad_addon.harness import scenes as test_scenes  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_extension import _shader_editor  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _groups():
    """Every node group: its stamp, nodes and links (what a rebuild changes)."""
    return {g.name: (g.get(VERSION_KEY), sorted(f"{n.name}:{n.bl_idname}" for n in g.nodes),
                     len(g.links)) for g in bpy.data.node_groups}


@pytest.fixture
def registered():
    """The operator classes a test names, registered for it alone."""
    done = []

    def register(*classes):
        for cls in classes:
            bpy.utils.register_class(cls)
            done.append(cls)
    yield register
    for cls in reversed(done):
        bpy.utils.unregister_class(cls)


def test_an_update_refused_at_one_group_changes_no_group(fresh, registered):
    """SG Blend Normals and SG Resolve stale; SG Resolve's helper .SG Safe Normal made by a
    newer surfgrad. Before: SG Blend Normals rebuilt (stamp VERSION), then the refusal."""
    G.blend_normals_group()[VERSION_KEY] = G.VERSION - 1
    G.resolve_group()[VERSION_KEY] = G.VERSION - 1
    bpy.data.node_groups[".SG Safe Normal"][VERSION_KEY] = G.VERSION + 1
    before = _groups()
    registered(U.SURFGRAD_OT_update_groups)
    with pytest.raises(RuntimeError, match="'.SG Safe Normal' was made by a newer surfgrad"):
        bpy.ops.surfgrad.update_groups()
    assert _groups() == before
    assert bpy.data.node_groups["SG Blend Normals"][VERSION_KEY] == G.VERSION - 1


def test_an_operator_refused_at_its_second_group_leaves_the_first_as_it_was(fresh):
    """Add Layer Stack needs SG Resolve (stale here) and SG Combine (a newer surfgrad's)."""
    bpy.ops.mesh.primitive_plane_add()
    mat, tree, _ = diffuse_material("Rock")
    bpy.context.object.data.materials.append(mat)
    G.resolve_group()[VERSION_KEY] = G.VERSION - 1
    G.combine_group()[VERSION_KEY] = G.VERSION + 1
    before, nodes = _groups(), len(tree.nodes)
    with pytest.raises(ValueError, match="'SG Combine' was made by a newer surfgrad"):
        O.add_layer_stack(tree)
    assert _groups() == before and len(tree.nodes) == nodes


def test_a_stale_copy_alone_is_updated_without_adding_an_unused_original(fresh):
    copy = G.combine_group()
    copy.name = "SG Combine.001"                 # as an append names it beside an original
    copy[VERSION_KEY] = G.VERSION - 1
    node = new_material("Rock").node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = copy
    assert U.update_stale_groups() == (["SG Combine.001"], [])
    assert node.node_tree == copy and copy[VERSION_KEY] == G.VERSION
    assert sorted(g.name for g in bpy.data.node_groups) == ["SG Combine.001"]


def _grey_normal_map_material(tmp_path, obj):
    """obj's material: a 1-channel (grey) PNG into SG Normal Map, SG Resolve, the BSDF."""
    from PIL import Image
    grey = (np.arange(8 * 8).reshape(8, 8) % 200 + 28).astype(np.uint8)
    Image.fromarray(grey, "L").save(tmp_path / "grey.png")
    mat, tree, _ = diffuse_material("Rock")
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    made = O.add_layer_stack(tree)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(tmp_path / "grey.png"))
    tex.image.colorspace_settings.name = "Non-Color"
    tree.links.new(tex.outputs["Color"], made["normal_map"].inputs["Color"])
    return mat


def test_a_refused_freeze_still_says_what_bends_its_normal_map(fresh, registered, tmp_path,
                                                               capfd):
    objs = test_scenes.new_scene(["Sphere", "Plane"])
    mat = _grey_normal_map_material(tmp_path, objs["Sphere"])
    objs["Plane"].data.materials.clear()
    objs["Plane"].data.materials.append(mat)             # the refusal: another mesh uses it
    bpy.context.view_layer.objects.active = objs["Sphere"]
    registered(*FO.CLASSES)
    capfd.readouterr()
    with pytest.raises(RuntimeError, match="also used by 'Plane'"):
        bpy.ops.surfgrad.freeze_stack(resolution=16)
    said = capfd.readouterr()
    lines = (said.out + said.err).splitlines()
    warned = [i for i, line in enumerate(lines) if line.startswith("Warning")
              and "image 'grey.png'" in line and "1 channel in its file" in line]
    refused = [i for i, line in enumerate(lines) if line.startswith("Error")
               and "also used by 'Plane'" in line]
    assert len(warned) == 1 and refused and warned[0] < refused[0], lines   # the refusal last
    assert F.RECORD not in mat


@pytest.mark.parametrize("record", ["{not json", "{}", 3, '{"image": "x.png", "links": 1}'])
def test_thaw_of_an_unreadable_record_is_refused_with_the_fix(fresh, registered, record):
    bpy.ops.mesh.primitive_plane_add()
    mat, tree, _ = diffuse_material("Rock")
    bpy.context.object.data.materials.append(mat)
    O.add_layer_stack(tree)
    mat[F.RECORD] = record
    nodes, links = len(tree.nodes), len(tree.links)
    registered(*FO.CLASSES)
    with pytest.raises(RuntimeError, match="not a freeze record.*remove the property") as said:
        bpy.ops.surfgrad.thaw_stack()
    assert "Traceback" not in str(said.value)
    assert (len(tree.nodes), len(tree.links)) == (nodes, links) and mat[F.RECORD] == record


def test_a_failed_edit_gives_back_the_link_it_replaced(fresh, registered, monkeypatch):
    """A failure no check foresees (here the last step of Add Layer Stack, putting its nodes in
    the shader's frame) after the stack was linked into the BSDF's Normal: before, the new
    nodes went and the user's Normal Map link into Normal went with them."""
    bpy.ops.mesh.primitive_plane_add()
    mat, tree, bsdf = diffuse_material("Rock")
    bpy.context.object.data.materials.append(mat)
    users = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(users.outputs["Normal"], bsdf.inputs["Normal"])
    for node in tree.nodes:
        node.select = node == users
    tree.nodes.active = users

    def fails(*_):
        raise RuntimeError("an unforeseen failure")
    monkeypatch.setattr(O, "_into_frame", fails)
    registered(*O.CLASSES)
    with pytest.raises(RuntimeError, match="an unforeseen failure"):
        bpy.ops.surfgrad.add_layer_stack()
    assert bsdf.inputs["Normal"].links[0].from_node == users
    assert sorted(n.name for n in tree.nodes) == ["Diffuse BSDF", "Material Output",
                                                  "Normal Map"]
    assert [n.name for n in tree.nodes if n.select] == ["Normal Map"]
    assert tree.nodes.active == users


def test_the_update_undoes_and_redoes_and_a_refusal_adds_no_step(fresh, registered):
    """Undo works headless (bpy as a module, in this process) on every line."""
    G.decal_group()[VERSION_KEY] = G.VERSION - 1
    registered(U.SURFGRAD_OT_update_groups)
    bpy.ops.ed.undo_push(message="start")
    assert bpy.ops.surfgrad.update_groups('EXEC_DEFAULT', True) == {'FINISHED'}
    assert bpy.data.node_groups["SG Decal"][VERSION_KEY] == G.VERSION
    bpy.data.node_groups.new("SG Combine", "ShaderNodeTree")     # the user's: refused
    bpy.data.node_groups["SG Decal"][VERSION_KEY] = G.VERSION - 1
    bpy.ops.ed.undo_push(message="edits")
    with pytest.raises(RuntimeError, match="'SG Combine'.*rename them"):
        bpy.ops.surfgrad.update_groups('EXEC_DEFAULT', True)
    bpy.ops.ed.undo()                 # to the update's step: the refusal pushed none
    assert "SG Combine" not in bpy.data.node_groups
    assert bpy.data.node_groups["SG Decal"][VERSION_KEY] == G.VERSION
    bpy.ops.ed.undo()                 # before the update (IDs fetched again: undo reloads)
    assert bpy.data.node_groups["SG Decal"][VERSION_KEY] == G.VERSION - 1
    bpy.ops.ed.redo()
    assert bpy.data.node_groups["SG Decal"][VERSION_KEY] == G.VERSION


@pytest.mark.parametrize("group, op_id", [("SG Normal Map", "convert_node"),
                                          ("SG Decal", "add_decal_projector")])
def test_an_edit_inside_the_group_it_adds_is_refused(fresh, registered, group, op_id):
    tree = G.normal_map_group("") if group == "SG Normal Map" else G.decal_group()
    if op_id == "convert_node":
        tree.nodes.active = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeNormalMap")
    before = (_groups(), sorted(o.name for o in bpy.data.objects))
    registered(*O.CLASSES)
    override, _ = _shader_editor(bpy, tree)
    with bpy.context.temp_override(**override):
        with pytest.raises(RuntimeError) as said:
            getattr(bpy.ops.surfgrad, op_id)()
    assert str(said.value).startswith(f"Error: The editor shows the inside of node group "
                                      f"{group!r}, and this edit adds {group!r} nodes"), \
        str(said.value)
    assert "leave the group (Tab)" in str(said.value)
    assert (_groups(), sorted(o.name for o in bpy.data.objects)) == before


@pytest.mark.tier("bake")
def test_thaw_undoes_and_redoes(fresh, registered):
    """Thaw's undo, headless in this process: the frozen chain and its record come back."""
    bpy.ops.mesh.primitive_plane_add()
    mat, tree, bsdf = diffuse_material("Rock")
    bpy.context.object.data.materials.append(mat)
    O.add_layer_stack(tree)
    F.freeze(bpy.context.object, 16, log=lambda *_: None)

    def state():
        tree = bpy.data.materials["Rock"].node_tree        # fetched again: undo reloads IDs
        normal = tree.nodes["Diffuse BSDF"].inputs["Normal"].links[0].from_node
        return normal.bl_idname, F.RECORD in bpy.data.materials["Rock"], len(tree.nodes)
    frozen = state()
    assert frozen[:2] == ("ShaderNodeNormalMap", True)
    registered(*FO.CLASSES)
    bpy.ops.ed.undo_push(message="frozen")
    assert bpy.ops.surfgrad.thaw_stack('EXEC_DEFAULT', True) == {'FINISHED'}
    thawed = state()
    assert thawed[:2] == ("ShaderNodeGroup", False) and thawed[2] == frozen[2] - 4
    bpy.ops.ed.undo()
    assert state() == frozen
    bpy.ops.ed.redo()
    assert state() == thawed


def test_the_layer_stack_reaches_a_bsdf_behind_a_reroute(fresh):
    """A reroute between the BSDF and the Material Output: before, refused ("'Reroute' has no
    Normal input: link a BSDF")."""
    mat, tree, bsdf = diffuse_material("Rock")
    output = tree.nodes["Material Output"]
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(bsdf.outputs[0], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], output.inputs["Surface"])
    made = O.add_layer_stack(tree)
    assert bsdf.inputs["Normal"].links[0].from_node == made["resolve"]
    assert output.inputs["Surface"].links[0].from_node == reroute
