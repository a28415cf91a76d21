"""An artist's files over time and across Blender lines (red team 34d).

A group's enumeration is a Menu from 5.0 and an integer on 4.2/4.5, so a rebuild on another
line (or of an older surfgrad's integer) changes its type, and Blender drops the nodes' values
and links with the old socket:
- 5.x file opened on 4.5: 4.5 cannot read a Menu's value in a shader group (it reads '') and
  drops the Menu Switch (the group outputs zero: a wrong look before any rebuild). A rebuild
  set every node back to the first item without a word; now each such node is named in a
  warning. (4.2 cannot open a 5.x file at all: pinned.)
- An older integer choice driven by a link (a Value node) lost the link and fell back to 0 on
  5.x, without a word; now it takes the value the link gave, and a warning names the node.
A refused rebuild (a group of the user's under a helper's name) left the existing group it was
rebuilding half-built (its nodes cleared): every material using it looked different. Now the
build is checked on a scratch group first. Stale groups (an older surfgrad's, another line's)
were rebuilt only when the artist added one; now the sidebar says so and Update surfgrad Groups
rebuilds them all in place, values and links kept.
"""

import os
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.child import ROOT  # noqa: E402
from surfgrad_addon.addon import group_updates as U  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.addon import ui  # noqa: E402
from surfgrad_addon.addon.compat import animated_fcurves, new_material  # noqa: E402
from surfgrad_addon.addon.bake_request import BakeRequest, BakeRequestError, bake  # noqa: E402
from surfgrad_addon.addon.enum_input import set_choice  # noqa: E402
from surfgrad_addon.addon.foreign_nodes import foreign_node_problems  # noqa: E402
from surfgrad_addon.addon.group_names import INSIDE_KEY, LINE_KEY, VERSION_KEY  # noqa: E402
from surfgrad_addon.addon.node_builder import running_line, take_notes  # noqa: E402
from surfgrad_addon.reference import compositing as C  # noqa: E402

pytestmark = pytest.mark.tier("blender")

MENUS = running_line().menu_sockets
SHAPES = ["Box", "Sphere", "Cylinder", "Cone", "Wedge", "Capsule"]


def _as_older_integer(tree, name):
    """The group as an older surfgrad (or line) saved it: `name` an integer, an older stamp."""
    iface = tree.interface
    old = next(it for it in iface.items_tree if it.item_type == "SOCKET" and it.name == name)
    if old.socket_type != "NodeSocketInt":
        iface.remove(old)
        iface.new_socket(name, in_out="INPUT", socket_type="NodeSocketInt")
    tree[VERSION_KEY] = G.VERSION - 1
    del tree[INSIDE_KEY]          # (an older surfgrad took no digest of its inside)


def _older_decal_node():
    """A node of SG Decal as an older surfgrad saved it (an integer Shape) in material Rock."""
    tree = G.decal_group()
    _as_older_integer(tree, "Shape")
    decal = new_material("Rock").node_tree.nodes.new("ShaderNodeGroup")
    decal.node_tree = tree
    return decal, decal.id_data.nodes, decal.id_data.links


def test_a_linked_integer_choice_keeps_what_its_link_gave_and_is_reported(fresh):
    decal, nodes, links = _older_decal_node()
    decal.name = "Driven decal"
    value = nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 3.0          # Cone
    links.new(value.outputs[0], decal.inputs["Shape"])
    take_notes()
    G.decal_group()
    shape = decal.inputs["Shape"]
    notes = take_notes()
    if MENUS:
        # A Menu takes links from menus only: the link goes, its value stays, and it is said.
        assert shape.type == "MENU" and shape.default_value == "Cone"
        assert len(notes) == 1
        assert "'Driven decal'" in notes[0] and "material 'Rock'" in notes[0]
        assert "'Value'" in notes[0] and "'Cone'" in notes[0]
    else:
        # An integer again: the link is kept, nothing to say.
        assert shape.is_linked and shape.links[0].from_node == value
        assert notes == []


def test_an_unreadable_or_out_of_range_choice_is_named(fresh):
    tree = G.blend_normals_group()
    _as_older_integer(tree, "Method")
    mat = new_material("Rock")
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    node.inputs["Method"].default_value = 7          # no item has that number
    take_notes()
    G.blend_normals_group()
    notes = take_notes()
    if MENUS:
        assert node.inputs["Method"].default_value == "Partial Derivative"
        assert len(notes) == 1 and "was 7" in notes[0], notes
    else:
        assert notes == []      # still the integer it was: nothing changed


def test_a_refused_rebuild_leaves_the_existing_group_whole(fresh):
    """SG Resolve of an older surfgrad, and a group of the user's under the name of its helper
    .SG Safe Normal: the refusal used to come after SG Resolve's nodes were cleared."""
    resolve = G.resolve_group()
    before = sorted(n.bl_idname for n in resolve.nodes)
    resolve[VERSION_KEY] = G.VERSION - 1
    bpy.data.node_groups.remove(bpy.data.node_groups[".SG Safe Normal"])
    bpy.data.node_groups.new(".SG Safe Normal", "ShaderNodeTree")
    groups_before = sorted(g.name for g in bpy.data.node_groups)
    with pytest.raises(ValueError, match="'.SG Safe Normal' already exists"):
        G.resolve_group()
    assert sorted(n.bl_idname for n in resolve.nodes) == before
    assert all(link.is_valid for link in resolve.links)
    assert resolve[VERSION_KEY] == G.VERSION - 1
    assert sorted(g.name for g in bpy.data.node_groups) == groups_before


def _stale_file():
    """A material using SG Decal (Cone, linked Axis X), SG Normal Map for UV map 'Paint'
    (Strength 0.4) and SG Blend Normals, all three groups left as an older surfgrad built
    them."""
    decal, per_map, blend = G.decal_group(), G.normal_map_group("Paint"), G.blend_normals_group()
    mat = new_material("Rock")
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    made = {}
    for key, tree in (("decal", decal), ("map", per_map), ("blend", blend)):
        made[key] = nodes.new("ShaderNodeGroup")
        made[key].node_tree = tree
        tree[VERSION_KEY] = G.VERSION - 1
    set_choice(made["decal"].inputs["Shape"], 3)
    set_choice(made["blend"].inputs["Method"], 2)
    made["map"].inputs["Strength"].default_value = 0.4
    axis = nodes.new("ShaderNodeCombineXYZ")
    links.new(axis.outputs[0], made["decal"].inputs["Axis X"])
    return mat, made, axis


def test_stale_groups_are_said_and_updated_in_place(fresh):
    mat, made, axis = _stale_file()
    stale = U.stale_groups()
    assert {g.name for g in stale} == {"SG Decal", "SG Normal Map [Paint]", "SG Blend Normals"}
    assert "3 surface-gradient group(s)" in U.stale_text(stale)
    trees = {k: n.node_tree for k, n in made.items()}
    updated, left = U.update_stale_groups()
    assert set(updated) == {"SG Decal", "SG Normal Map [Paint]", "SG Blend Normals"}
    assert left == []
    assert U.stale_groups() == [] and U.stale_text([]) is None
    for key, node in made.items():
        assert node.node_tree == trees[key]                      # in place, same data-block
        assert node.node_tree[VERSION_KEY] == G.VERSION
        assert node.node_tree[LINE_KEY] == running_line().line
    assert made["map"].node_tree.nodes["Normal Map"].uv_map == "Paint"
    assert made["decal"].inputs["Shape"].default_value == ("Cone" if MENUS else 3)
    assert made["blend"].inputs["Method"].default_value == ("UDN" if MENUS else 2)
    assert made["map"].inputs["Strength"].default_value == pytest.approx(0.4)
    assert made["decal"].inputs["Axis X"].links[0].from_node == axis
    assert all(link.is_valid for link in mat.node_tree.links)


def test_the_update_operator_reports_and_refuses_a_users_group(fresh):
    _stale_file()
    bpy.data.node_groups.new("SG Combine", "ShaderNodeTree")      # the user's own group
    stale = {g.name: g.get(VERSION_KEY) for g in U.stale_groups()}
    with pytest.raises(ValueError, match="'SG Combine'.*rename them"):
        U.update_stale_groups()
    assert {g.name: g.get(VERSION_KEY) for g in U.stale_groups()} == stale   # nothing changed
    bpy.data.node_groups["SG Combine"].name = "My Combine"
    bpy.utils.register_class(U.SURFGRAD_OT_update_groups)
    try:
        assert bpy.ops.surfgrad.update_groups() == {'FINISHED'}
        assert U.stale_groups() == []
        assert bpy.ops.surfgrad.update_groups() == {'CANCELLED'}     # up to date: no undo step
    finally:
        bpy.utils.unregister_class(U.SURFGRAD_OT_update_groups)


def _open_saved_on_52(tmp_path, code):
    """Run `code` (which saves the file named by its argument) on the 5.2 line in a child, open
    the file here; False on 4.2, which cannot read a file written by 5.x (pinned here)."""
    python = ROOT / ".venv" / "bin" / "python"
    assert python.exists(), f"{python}: the 5.2 line's venv (bash run.sh test makes it)"
    path = tmp_path / "saved_on_52.blend"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    made = subprocess.run([str(python), "-c", code, str(path)], cwd=str(ROOT), env=env,
                          capture_output=True, text=True, timeout=300)
    assert made.returncode == 0 and path.exists(), made.stderr[-2000:]
    if running_line().line == "4.2":
        with pytest.raises(RuntimeError, match="not a blend file"):
            bpy.ops.wm.open_mainfile(filepath=str(path))
        return False
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return True


SAVE_ON_52 = """
import sys, bpy
from surfgrad_addon.addon import groups as G
from surfgrad_addon.addon.compat import new_material
from surfgrad_addon.addon.enum_input import set_choice
bpy.ops.wm.read_factory_settings(use_empty=True)
mat = new_material("Rock")
mat.use_fake_user = True
for name, tree, item in (("Cone decal", G.decal_group(), 3), ("RNM blend", G.blend_normals_group(), 3)):
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree, node.name = tree, name
    set_choice(node.inputs["Shape" if "decal" in name else "Method"], item)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
"""


@pytest.mark.tier("child")
def test_a_menu_choice_made_on_52_is_kept_or_named_on_this_line(fresh, tmp_path):
    """A file saved on 5.2 (the main line, in a child) with a Cone decal and an RNM blend."""
    if not _open_saved_on_52(tmp_path, SAVE_ON_52):
        return
    nodes = bpy.data.materials["Rock"].node_tree.nodes
    decal, blend = nodes["Cone decal"], nodes["RNM blend"]
    take_notes()
    if MENUS:                          # 5.0 and 5.2 read the menus
        assert decal.inputs["Shape"].default_value == "Cone"
        assert blend.inputs["Method"].default_value == "RNM"
        U.update_stale_groups()
        assert decal.inputs["Shape"].default_value == "Cone"
        assert blend.inputs["Method"].default_value == "RNM"
        assert take_notes() == []
        return
    # 4.5: the value is there in the file but reads '' (4.5 knows no Menu in a shader group),
    # and the groups are stale (built for 5.2).
    assert decal.inputs["Shape"].default_value == ""
    assert {"SG Decal", "SG Blend Normals"} <= {g.name for g in U.stale_groups()}
    assert "Blender 5.2" in U.stale_text(U.stale_groups())
    U.update_stale_groups()
    notes = take_notes()
    assert decal.inputs["Shape"].default_value == 0 and blend.inputs["Method"].default_value == 0
    assert len(notes) == 2, notes
    assert any("'Cone decal'" in n and "Shape menu" in n and "'Box'" in n for n in notes), notes
    assert any("'RNM blend'" in n and "Method menu" in n for n in notes), notes


COLOURS = {"Color A": (0.85, 0.5, 0.65, 1.0), "Color B": (0.5, 0.85, 0.65, 1.0)}
RENDER_SCENE = f"""
COLOURS = {COLOURS!r}
import sys, bpy
from surfgrad_addon.addon import groups as G
from surfgrad_addon.addon.compat import new_material
from surfgrad_addon.addon.enum_input import set_choice
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_plane_add(size=4)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
cam.data.type, cam.data.ortho_scale, cam.location = "ORTHO", 2.0, (0, 0, 3)
bpy.context.scene.collection.objects.link(cam)
bpy.context.scene.camera = cam
mat = new_material("Blend")
nodes, links = mat.node_tree.nodes, mat.node_tree.links
nodes.clear()
out, emit = nodes.new("ShaderNodeOutputMaterial"), nodes.new("ShaderNodeEmission")
blend = nodes.new("ShaderNodeGroup")
blend.node_tree, blend.name = G.blend_normals_group(), "RNM blend"
for key, colour in COLOURS.items():
    blend.inputs[key].default_value = colour
set_choice(blend.inputs["Method"], 3)
links.new(blend.outputs[0], emit.inputs["Color"])
links.new(emit.outputs[0], out.inputs["Surface"])
bpy.context.object.data.materials.append(mat)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
"""


def _render_centre(tmp_path):
    """The centre pixel (scene linear RGB) of a 4 x 4, 1-sample Cycles render of the scene."""
    scene = bpy.context.scene
    scene.world = None
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.device = 1, "CPU"
    scene.render.resolution_x = scene.render.resolution_y = 4
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(tmp_path / f"render_{len(list(tmp_path.iterdir()))}.exr")
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(scene.render.filepath)
    pixel = [round(v, 4) for v in image.pixels[(2 * 4 + 2) * 4:(2 * 4 + 2) * 4 + 3]]
    bpy.data.images.remove(image)
    return pixel


def _rendered_as(tmp_path, colour):
    """The render of an Emission of `colour` (an RGB node) in place of the group's: what the
    group must render to (the same colour management and film)."""
    tree = bpy.data.materials["Blend"].node_tree
    emit = tree.nodes["Emission"]
    group_out = emit.inputs["Color"].links[0].from_socket
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (*colour, 1.0)
    tree.links.new(rgb.outputs[0], emit.inputs["Color"])
    try:
        return _render_centre(tmp_path)
    finally:
        tree.nodes.remove(rgb)
        tree.links.new(group_out, emit.inputs["Color"])


def _blend_colour(method):
    """What SG Blend Normals returns for the scene's colours: 0.5 n + 0.5, n the reference's
    blend of the decoded normals (reference/compositing.py)."""
    a, b = (2 * np.array(COLOURS[k][:3]) - 1 for k in ("Color A", "Color B"))
    return list(0.5 * method(a, b) + 0.5)


@pytest.mark.tier("child")
def test_a_52_group_renders_wrong_on_45_until_updated_and_its_choice_set(fresh, tmp_path):
    """The stale groups are wrong, not only old: 4.5 drops a 5.x group's Menu Switch, so SG
    Blend Normals (RNM, saved on 5.2) renders no blend there (grey: a zero vector); updated,
    it renders Partial Derivative (the first item, with a warning naming the node), and set to
    RNM again what 5.2 renders."""
    if not _open_saved_on_52(tmp_path, RENDER_SCENE):
        return
    node = bpy.data.materials["Blend"].node_tree.nodes["RNM blend"]
    rnm = _rendered_as(tmp_path, _blend_colour(C.blend_rnm))
    pd = _rendered_as(tmp_path, _blend_colour(C.blend_pd))
    assert max(abs(x - y) for x, y in zip(rnm, pd)) > 0.05       # the two looks differ
    if MENUS:
        assert _render_centre(tmp_path) == pytest.approx(rnm, abs=2e-3)
        return
    # 4.5 drops the Menu Switch: the blend is a zero vector, the colour 0.5 grey.
    assert _render_centre(tmp_path) == pytest.approx(_rendered_as(tmp_path, (0.5, 0.5, 0.5)),
                                                     abs=2e-3)
    take_notes()
    U.update_stale_groups()
    assert any("'RNM blend'" in n for n in take_notes())
    assert _render_centre(tmp_path) == pytest.approx(pd, abs=2e-3)
    set_choice(node.inputs["Method"], 3)
    assert _render_centre(tmp_path) == pytest.approx(rnm, abs=2e-3)


@pytest.mark.tier("child")
def test_a_bake_of_a_52_group_on_45_is_refused_not_baked_as_zero(fresh, tmp_path):
    """The headless bake would have baked the 4.5 look above (no blend) and exited 0."""
    if not _open_saved_on_52(tmp_path, RENDER_SCENE):
        return
    plane = bpy.data.objects["Plane"]
    problems = foreign_node_problems(plane)
    if MENUS:
        assert problems == []
        return
    assert len(problems) == 1
    assert "material 'Blend'" in problems[0] and "'Menu Switch' in node group " \
        "'SG Blend Normals'" in problems[0] and "Update surfgrad Groups" in problems[0]
    output = tmp_path / "plane_nrm.png"
    with pytest.raises(BakeRequestError) as refused:
        bake(BakeRequest.from_settings("Plane", str(output), {"resolution": 16}))
    assert problems[0] in str(refused.value)
    assert not output.exists()
    U.update_stale_groups()                      # updated here: nothing left to refuse
    assert foreign_node_problems(plane) == []


def test_a_per_image_group_is_updated_for_its_image_and_its_copy_joins_it(fresh):
    """Until round 39 the copy was left, said ("add the group again"); now its users move to
    the group of its image and extension (tests/test_faults_leftovers39.py) and it is gone."""
    image = bpy.data.images.new("Heights", 8, 4)
    tree = G.height_map_group(image, "hq", "EXTEND")
    copy = tree.copy()                               # "... [Heights].001", as an append makes
    copy_name = copy.name
    for group in (tree, copy):
        group[VERSION_KEY] = G.VERSION - 1
    updated, left = U.update_stale_groups()
    assert updated == [tree.name, f"{copy_name} (now {tree.name})"]
    assert tree[VERSION_KEY] == G.VERSION
    taps = [n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"]
    assert taps and all(t.image == image and t.extension == "EXTEND" for t in taps)
    assert left == [] and copy_name not in bpy.data.node_groups


def test_drivers_follow_their_inputs_when_a_rebuild_moves_them(fresh):
    """A decal projector's drivers name SG Decal's Axis X and Axis Y by index (keyframes name
    inputs so too). A group saved before an input was added ahead of them (here DirectX) had
    them one place earlier: after the rebuild their paths named DirectX and Axis X, so the
    decal's axes were driven wrong."""
    tree = G.decal_group()
    iface = tree.interface
    iface.remove(next(it for it in iface.items_tree
                      if it.item_type == "SOCKET" and it.name == "DirectX"))
    tree[VERSION_KEY] = G.VERSION - 1
    del tree[INSIDE_KEY]
    mat = new_material("Rock")
    decal = mat.node_tree.nodes.new("ShaderNodeGroup")
    decal.node_tree, decal.name = tree, 'Decal "A"'       # a name the path escapes
    empty = bpy.data.objects.new("Projector", None)
    for axis, column in (("Axis X", 0), ("Axis Y", 1)):
        O.drive_axis(decal.inputs[axis], empty, column)
    decal.inputs["Strength"].keyframe_insert("default_value", frame=1)    # keyed: the same
    take_notes()
    G.decal_group()
    assert "DirectX" in decal.inputs
    wanted = {decal.inputs[axis].path_from_id("default_value") for axis in ("Axis X", "Axis Y")}
    anim = mat.node_tree.animation_data
    assert {fc.data_path for fc in anim.drivers} == wanted
    assert {fc.data_path for fc in animated_fcurves(anim)} - wanted == \
        {decal.inputs["Strength"].path_from_id("default_value")}
    assert take_notes() == []


def _override_material(tmp_path):
    """A material of a library file (SG groups in it) made a library override here, on a
    plane; returns (override, plane)."""
    library = tmp_path / "library.blend"
    bpy.ops.mesh.primitive_plane_add()
    mat = new_material("Library Rock")
    bpy.context.object.data.materials.append(mat)
    O.add_layer_stack(mat.node_tree)
    bpy.ops.wm.save_as_mainfile(filepath=str(library))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with bpy.data.libraries.load(str(library), link=True) as (_, into):
        into.materials = ["Library Rock"]
    override = bpy.data.materials["Library Rock"].override_create(remap_local_usages=True)
    bpy.ops.mesh.primitive_plane_add()
    bpy.context.object.data.materials.append(override)
    return override, bpy.context.object


def test_nodes_added_to_a_library_overrides_tree_are_not_saved(fresh, tmp_path):
    """The Blender fact behind the refusal below, on every line: the override's tree says it is
    editable and takes a node, and the saved file drops it."""
    override, _ = _override_material(tmp_path)
    count = len(override.node_tree.nodes)
    assert override.is_editable and override.node_tree.is_editable
    override.node_tree.nodes.new("ShaderNodeValue")
    saved = tmp_path / "user.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(saved))
    bpy.ops.wm.open_mainfile(filepath=str(saved))
    reopened = next(m for m in bpy.data.materials if m.override_library is not None)
    assert len(reopened.node_tree.nodes) == count


def test_the_operators_refuse_a_library_overrides_material(fresh, tmp_path):
    """Add Layer Stack, Add Decal Projector, Convert and the Add menu edited an override's
    nodes and reported success; the saved file lost the edit."""
    override, plane = _override_material(tmp_path)
    tree = override.node_tree
    count = len(tree.nodes)
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup")
    with pytest.raises(O.SurfgradError, match="override data"):
        O.add_layer_stack(tree)
    with pytest.raises(O.SurfgradError, match="override data"):
        O.add_decal_projector(bpy.context, tree)
    with pytest.raises(O.SurfgradError, match="override data"):
        O.convert_node(tree, node)
    context = SimpleNamespace(object=plane, space_data=None)
    with pytest.raises(O.SurfgradError, match="override data"):
        O.shown_tree(context)
    editor = SimpleNamespace(type="NODE_EDITOR", tree_type="ShaderNodeTree", edit_tree=tree)
    assert "override" in ui.shader_tree_problem(SimpleNamespace(space_data=editor))
    assert len(tree.nodes) == count


def test_a_choice_linked_from_a_computed_value_keeps_the_value_typed_under_it(fresh):
    """A link from a node whose value is not known here (a Math node): the integer typed under
    the link (4, Wedge) is kept, and the dropped link named."""
    decal, nodes, links = _older_decal_node()
    decal.inputs["Shape"].default_value = 4
    math = nodes.new("ShaderNodeMath")
    links.new(math.outputs[0], decal.inputs["Shape"])
    take_notes()
    G.decal_group()
    notes = take_notes()
    if not MENUS:
        assert decal.inputs["Shape"].links[0].from_node == math and notes == []
        return
    assert decal.inputs["Shape"].default_value == "Wedge"
    assert len(notes) == 1 and "'Math'" in notes[0] and "'Wedge'" in notes[0], notes
