"""Red team 54d: the artist-facing add-on's operators and sidebar, on what round 53 noticed
and left. Measured on 5.2 before the fix (main at abdec51):

1. The Add menu's entries start the move (translate_attach_remove_on_cancel) after the Add;
   Esc removes the new node alone. An Add that rebuilt an existing group (an older surfgrad's
   SG Resolve, stamp 23, that the material's other node uses) left it rebuilt (stamp 24):
   Esc cancelled half the operation. Now an Add that rebuilt, renamed or removed an existing
   group places the node under the mouse without the move and says so (G moves it; Ctrl+Z
   undoes both); an Add that changed no existing group starts the move as before.
2. Add Layer Stack, Add Decal Projector, Freeze and Thaw polled True in a Geometry Nodes
   editor (F3): Add Layer Stack there added 3 nodes (2 -> 5) to the active object's material,
   unseen, FINISHED; in a Shader Editor showing the World or a line style, Freeze and Thaw
   worked on the active object's material. Now their poll refuses both, naming the editor
   and the fix; the 3D Viewport (no node editor) and a Shader Editor on Object still work.
3. The Add menu put SG groups into a Freestyle line style's node tree (3 -> 4 nodes,
   FINISHED; they do nothing there). Now refused by its poll, naming line styles.
4. Add Decal Projector linked its empty (and outline empties) into the Scene Collection with
   the active collection 'Props': outside the artist's set, unlike Blender's Add Object. Now
   in the active collection; the Scene Collection where that one is excluded or linked.
5. The sidebar's check for groups edited inside digested every node of every current group
   each redraw: 39 ms with 27 groups (1,649 nodes), 386 ms with 107 (18,689 nodes: 80
   per-image height groups), and the check for older per-image names walked their nodes
   (20 ms more). Now a redraw digests the groups the editor shows, new or renamed or
   restamped ones, then the least recently checked until 200 nodes (15 ms a redraw at 107
   groups on this machine); per-image groups' Image Texture nodes are looked up by name.
6. Freeze's pose check skipped a pose that shifts the whole rig (root motion, nothing
   turned), right for normals but not for a stack reading object-space positions: the
   layered stack (SG Noise) on the skinned strip, bone A (the root) moved 0.3 m along z,
   froze a map median 29.8 degrees (max 99.6) from the map frozen at rest, no warning. Now
   warned ("bones moved from their rest, none turned"); an object-space bake still is not
   (a shift turns no normal: tests/test_faults_review52b.py).
"""

from types import SimpleNamespace

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import group_updates as U  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import ui  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402
from test_extension import _shader_editor  # noqa: E402
from test_faults_artist47 import _Sidebar  # noqa: E402

pytestmark = pytest.mark.tier("blender")

MATERIAL_OPS = ("add_layer_stack", "add_decal_projector", "freeze_stack", "thaw_stack")


@pytest.fixture
def registered(fresh):
    ui.register()
    yield
    ui.unregister()


def _material_with_plane():
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.object
    mat = new_material("Rock")
    obj.data.materials.append(mat)
    return obj, mat


def _nodes(tree):
    return sorted(n.name for n in tree.nodes)


def _poll(op, override):
    """(poll, the message an exec gets) of bpy.ops.surfgrad.<op> in `override`."""
    with bpy.context.temp_override(**override):
        fn = getattr(bpy.ops.surfgrad, op)
        if fn.poll():
            return True, None
        with pytest.raises(RuntimeError) as err:
            fn()
    return False, str(err.value)


# 1 --------------------------------------------------------------------------------------------

def _invoke_add(override, space, group, monkeypatch):
    """SURFGRAD_OT_add_group.invoke as the Add menu runs it (use_transform), its execute the
    registered operator's; returns (moves started, reports)."""
    moves, reports = [], []
    monkeypatch.setattr(ui, "start_move", lambda: moves.append(group))

    def execute(_context):
        with bpy.context.temp_override(**override):
            return bpy.ops.surfgrad.add_group(group=group)
    op = SimpleNamespace(group=group, use_transform=True, execute=execute,
                         report=lambda kind, text: reports.append((kind, text)))
    context = SimpleNamespace(space_data=space, region=None, area=None)
    return ui.SURFGRAD_OT_add_group.invoke(op, context, None), moves, reports


def test_an_add_that_rebuilds_an_older_group_does_not_start_the_cancellable_move(
        registered, monkeypatch):
    _obj, mat = _material_with_plane()
    old = mat.node_tree.nodes.new("ShaderNodeGroup")
    old.node_tree = G.resolve_group()
    old.node_tree[VERSION_KEY] = G.VERSION - 1            # a file from an older surfgrad
    override, space = _shader_editor(bpy, mat.node_tree)
    result, moves, reports = _invoke_add(override, space, "SG Resolve", monkeypatch)
    assert result == {'FINISHED'} and bpy.data.node_groups["SG Resolve"][VERSION_KEY] == G.VERSION
    assert moves == []                   # Esc would have kept the rebuild: no move to cancel
    [(kind, text)] = reports
    assert kind == {'INFO'} and "'SG Resolve'" in text and "Ctrl+Z" in text, text
    assert len([n for n in mat.node_tree.nodes if n.type == "GROUP"]) == 2
    # Nothing rebuilt (current groups, one new): the move starts as Blender's Add does.
    result, moves, reports = _invoke_add(override, space, "SG Combine", monkeypatch)
    assert result == {'FINISHED'} and moves == ["SG Combine"] and reports == []


# 2, 3 -----------------------------------------------------------------------------------------

def test_material_operators_are_refused_in_other_node_editors(registered):
    obj, mat = _material_with_plane()
    before = _nodes(mat.node_tree)
    override, _space = _shader_editor(bpy, mat.node_tree)
    assert all(_poll(op, override)[0] for op in MATERIAL_OPS)      # a Shader Editor: fine
    area = override["area"]
    area.ui_type = "GeometryNodeTree"
    geometry = bpy.data.node_groups.new("Geo", "GeometryNodeTree")
    obj.modifiers.new("GN", "NODES").node_group = geometry
    space = area.spaces.active
    space.pin, space.node_tree = True, geometry
    for op in MATERIAL_OPS:
        ok, said = _poll(op, override)
        assert not ok and "run it from a Shader Editor" in said, (op, said)
    assert _nodes(mat.node_tree) == before                # (3 nodes were added before)


@pytest.mark.parametrize("kind", ["WORLD", "LINESTYLE"])
def test_material_operators_are_refused_on_world_or_line_style_nodes(registered, kind):
    _obj, mat = _material_with_plane()
    scene = bpy.context.scene
    scene.world = scene.world or bpy.data.worlds.new("World")
    style = bpy.data.linestyles.new("Style")
    for owner in (scene.world, style):
        owner.use_nodes = True
    shown = scene.world.node_tree if kind == "WORLD" else style.node_tree
    override, space = _shader_editor(bpy, shown)
    space.shader_type = kind
    for op in MATERIAL_OPS:
        ok, said = _poll(op, override)
        what = "the World's" if kind == "WORLD" else "a line style's"
        assert not ok and f"shows {what} nodes" in said and "switch the" in said, (op, said)


def test_the_add_menu_refuses_a_line_style_tree(registered):
    style = bpy.data.linestyles.new("Style")
    style.use_nodes = True
    before = _nodes(style.node_tree)
    override, space = _shader_editor(bpy, style.node_tree)
    space.shader_type = "LINESTYLE"
    ok, said = _poll("add_group", override)
    assert not ok and "line style's nodes" in said, said
    assert _nodes(style.node_tree) == before              # (an SG Resolve was added before)
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    override, space = _shader_editor(bpy, world.node_tree)
    space.shader_type = "WORLD"
    assert _poll("add_group", override) == (True, None)   # the World still takes them


# 4 --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("excluded", [False, True])
def test_the_decal_projector_goes_in_the_active_collection(registered, excluded):
    _obj, mat = _material_with_plane()
    props = bpy.data.collections.new("Props")
    bpy.context.scene.collection.children.link(props)
    layer = bpy.context.view_layer.layer_collection.children["Props"]
    bpy.context.view_layer.active_layer_collection = layer
    layer.exclude = excluded
    bpy.context.view_layer.active_layer_collection = layer
    override, _space = _shader_editor(bpy, mat.node_tree)
    with bpy.context.temp_override(**override):
        assert bpy.ops.surfgrad.add_decal_projector(shape="cylinder") == {'FINISHED'}
    made = [o for o in bpy.data.objects if o.name.startswith("SG Decal Projector")]
    assert len(made) == 3                                 # the projector and two outlines
    want = "Scene Collection" if excluded else "Props"
    assert all([c.name for c in o.users_collection] == [want] for o in made), \
        [(o.name, [c.name for c in o.users_collection]) for o in made]


# 5 --------------------------------------------------------------------------------------------

def test_a_sidebar_redraw_digests_a_bounded_number_of_nodes(fresh, monkeypatch):
    for name in ui.menu_group_names():
        ui.add_group_node(bpy.data.node_groups.get("Host") or
                          bpy.data.node_groups.new("Host", "ShaderNodeTree"), name)
    ours = [g for g in bpy.data.node_groups if VERSION_KEY in g]
    total = sum(len(g.nodes) for g in ours)
    assert len(ours) >= 20 and total > 1000, (len(ours), total)     # (24 groups on 4.x)
    digested = []
    real = U.edited_inside
    monkeypatch.setattr(U, "edited_inside", lambda g: digested.append(len(g.nodes)) or real(g))
    sidebar = _Sidebar()
    U.draw_stale_warning(sidebar)
    assert sum(digested) == total and sidebar.boxes == []     # first redraw: all of them
    largest = max(len(g.nodes) for g in ours)
    for _ in range(3):
        digested.clear()
        U.draw_stale_warning(sidebar)
        assert 0 < sum(digested) <= U.EDITED_NODE_BUDGET + largest, sum(digested)
    # An edit inside a group the editor shows is said on the next redraw ...
    shown = bpy.data.node_groups["SG Combine"]
    next(n for n in shown.nodes if n.bl_idname == "ShaderNodeVectorMath").mute = True
    assert U.edited_text(shown=[shown]).startswith("1 surface-gradient group(s) were edited")
    # ... one elsewhere (a script's) within a sweep of the budget.
    other = bpy.data.node_groups["SG Resolve"]
    next(n for n in other.nodes if n.bl_idname == "ShaderNodeVectorMath").mute = True
    sweeps = -(-total // U.EDITED_NODE_BUDGET) + 1
    said = [U.edited_text() for _ in range(sweeps)]
    assert said[-1].startswith("2 surface-gradient group(s) were edited"), said[-1]


def test_a_per_image_group_is_renamed_when_its_image_is(fresh):
    """The kept Image Texture node names keep no image: a renamed or removed image is read
    anew on the next look."""
    image = bpy.data.images.new("Rock", 4, 4)
    group = G.height_map_group(image=image)
    assert U.stale_groups() == [] and U.renamed_target(group, any_name=True) is None
    image.name = "Stone"
    assert U.renamed_target(group, any_name=True) == "SG Height Map HQ [Stone]"
    bpy.data.images.remove(image)
    assert U.stale_groups() == [] and U.renamed_target(group, any_name=True) is None


# 6 --------------------------------------------------------------------------------------------

@pytest.mark.tier("bake")
def test_freezing_an_object_space_stack_after_a_root_shift_warns():
    from test_faults_deform51a import _deg, _frozen, _skinned_strip
    obj, _arm = _skinned_strip()
    rest, quiet = _frozen(obj)
    assert quiet == []
    obj, arm = _skinned_strip()
    arm.pose.bones["A"].location = (0.0, 0.0, 0.3)        # the root: B, its child, follows
    bpy.context.view_layer.update()
    dg = bpy.context.evaluated_depsgraph_get()
    zs = [v.co.z for v in obj.evaluated_get(dg).data.vertices]
    assert zs == pytest.approx([0.3] * 6, abs=1e-5)      # a rigid shift: nothing turned
    shifted, said = _frozen(obj)
    off = _deg(shifted, rest)
    assert np.median(off) > 10.0, np.median(off)          # the noise moved (29.8 degrees)
    (text,) = [w for w in said if "armature" in w]
    assert "bones moved from their rest, none turned" in text and "(SG Noise)" in text, text
    assert "Rest Position" in text, text
