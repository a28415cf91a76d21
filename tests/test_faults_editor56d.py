"""Red team 56d: the artist in the Shader Editor on what rounds 53d and 54d left: Update surfgrad
Groups on groups the artist renamed, and on SG groups outside materials. Measured on 5.2
before the fix (main at 301e92c):

1. An older surfgrad's SG Resolve (stamp 23) the artist renamed "Resolve (mine)" (a file from
   a previous version, the group renamed in the Outliner): Update surfgrad Groups reported
   "Updated 0 surface-gradient group(s) for Blender 5.2: " (an empty list) and FINISHED, an
   undo step of nothing, with a warning that its build "cannot be told from the group (add
   it again from the menu)"; adding SG Resolve again from the menu makes a new "SG Resolve"
   and leaves the renamed one stale. The sidebar kept saying "1 surface-gradient group(s) were
   built by an older surfgrad ...: Update surfgrad Groups rebuilds them" with the Update
   button, after every Update. Now an Update that updates nothing is refused (CANCELLED, an
   error, nothing changed, no undo step), the renamed group's warning says to rename it back
   to its Add-menu name; the sidebar names the renamed group(s) apart, with that fix, and
   shows the Update button only where it can update something; a renamed group is left as
   it is (the artist's own version, perhaps): renamed back, it updates.
2. SG Decal in the World's nodes (the Add menu offers the World) and in a light's, in a file
   saved on 4.5 (Shape an integer, 2 = Cylinder), opened on 5.2 and updated: the material's
   node and the artist's group's node kept Cylinder, the World's and the light's Shape became
   '' (the group's Menu input with no item), no note: the rebuild carried the choices of
   group nodes in materials and node groups only (node_builder._group_owners; the drivers and
   keyframes it follows too). Now of every tree a group node can be in: Cylinder in all four.
   (5.0+, where the enumeration is a Menu; 4.2/4.5 keep the integer: no retype there.)
3. A current SG Resolve the artist edited inside (a node muted), then renamed "My Resolve"
   as the sidebar asks ("rename each to keep your version, so surfgrad can add its own"):
   the sidebar went on saying "1 surface-gradient group(s) were edited inside ... ('My
   Resolve'): surfgrad will not add or use them as its own; rename each ..." for good, while
   the Add menu and Add Layer Stack made surfgrad's own SG Resolve beside it (FINISHED). Now
   a group renamed away from surfgrad's names is not named there; an edited "SG Resolve" is.

Probed and fine (5.2): every operator (Add menu, Add Layer Stack, Convert, Add Decal
Projector, Update) with older groups in the file, then Ctrl+Z (ed.undo): the groups, the
materials' nodes and the objects exactly as before; a material appended from an older
surfgrad's file beside current groups ("SG Resolve.001", stamp 23): Update rebuilds both
copies, the appended node's values kept; linked from it: named by the sidebar, left alone;
from a newer surfgrad's file: its ".001" copies left as built. Copy/paste of SG nodes from a
file with older (or newer) groups into a file with current ones: 5.2 pastes onto the file's
group of that name.
"""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import group_updates as U  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import INSIDE_KEY, VERSION_KEY  # noqa: E402
from surfgrad_addon.addon.node_builder import running_line, take_notes  # noqa: E402
from test_extension import _shader_editor  # noqa: E402
from test_faults_artist47 import _Sidebar  # noqa: E402

pytestmark = pytest.mark.tier("blender")

OLDER = G.VERSION - 1


@pytest.fixture
def registered(fresh):
    bpy.utils.register_class(U.SURFGRAD_OT_update_groups)
    yield
    bpy.utils.unregister_class(U.SURFGRAD_OT_update_groups)


def _material_using(*groups):
    mat = new_material("Rock")
    for group in groups:
        mat.node_tree.nodes.new("ShaderNodeGroup").node_tree = group
    return mat


def _renamed_older_resolve(name="Resolve (mine)"):
    group = G.resolve_group()
    group[VERSION_KEY] = OLDER
    group.name = name
    return group


def _groups():
    return {g.name: (g.get(VERSION_KEY), len(g.nodes), len(g.links), g.users)
            for g in bpy.data.node_groups}


def _update(mat):
    """Update surfgrad Groups in a Shader Editor on `mat`: its result, or its error's text."""
    override, _ = _shader_editor(bpy, mat.node_tree)
    with bpy.context.temp_override(**override):
        try:
            return bpy.ops.surfgrad.update_groups('EXEC_DEFAULT', True)
        except RuntimeError as err:
            return str(err)


def test_an_update_that_updates_nothing_is_refused_and_changes_nothing(registered):
    mat = _material_using(_renamed_older_resolve())
    before = _groups()
    said = _update(mat)
    assert said != {'FINISHED'}, "FINISHED with 0 groups updated (an undo step of nothing)"
    assert "No surface-gradient group was updated" in said, said
    assert _groups() == before
    assert before["Resolve (mine)"][0] == OLDER


def test_the_renamed_groups_reason_says_rename_it_back(registered):
    _material_using(_renamed_older_resolve())
    updated, left = U.update_stale_groups()
    assert updated == []
    assert [name for name, _ in left] == ["Resolve (mine)"]
    why = left[0][1]
    assert "renamed" in why and "rename it back to its name in the Add menu" in why, why
    assert "add it again from the menu" not in why        # it made a new one, this one stale
    assert bpy.data.node_groups["Resolve (mine)"][VERSION_KEY] == OLDER


def test_the_sidebar_names_a_renamed_group_without_promising_its_update(registered):
    _material_using(_renamed_older_resolve())
    text = U.stale_text(U.stale_groups())
    assert "'Resolve (mine)'" in text, text
    assert "leaves them as they are" in text, text
    assert "rename it back to its name in the Add menu" in text, text
    assert "Update surfgrad Groups rebuilds them" not in text, text
    sidebar = _Sidebar()
    U.draw_stale_warning(sidebar)
    assert [b.operators for b in sidebar.boxes] == [[]], "the Update button, which cannot"


def test_renamed_back_it_updates(registered):
    group = _renamed_older_resolve()
    mat = _material_using(group)
    group.name = "SG Resolve"                  # the fix the messages give
    assert _update(mat) == {'FINISHED'}
    assert group[VERSION_KEY] == G.VERSION
    assert U.stale_groups() == []


def test_a_renamed_group_beside_one_update_can_rebuild(registered):
    decal = G.decal_group()
    decal[VERSION_KEY] = OLDER
    mat = _material_using(_renamed_older_resolve(), decal)
    text = U.stale_text(U.stale_groups())
    assert text.startswith("1 surface-gradient group(s) were built by an older surfgrad"), text
    assert "1 older surface-gradient group(s) were renamed ('Resolve (mine)')" in text, text
    sidebar = _Sidebar()
    U.draw_stale_warning(sidebar)
    assert [b.operators for b in sidebar.boxes] == [["surfgrad.update_groups"]]
    assert _update(mat) == {'FINISHED'}
    assert decal[VERSION_KEY] == G.VERSION
    assert bpy.data.node_groups["Resolve (mine)"][VERSION_KEY] == OLDER


@pytest.mark.skipif(not running_line().menu_sockets,
                    reason="4.2 and 4.5 keep the enumeration an integer: nothing is retyped")
def test_a_worlds_and_a_lights_decal_keep_their_shape_when_an_integer_becomes_a_menu(fresh):
    decal = G.decal_group()
    iface = decal.interface
    old = next(it for it in iface.items_tree if it.item_type == "SOCKET" and it.name == "Shape")
    position = old.position
    iface.remove(old)                       # as 4.5 saved it: an integer Shape, same place
    iface.move(iface.new_socket("Shape", in_out="INPUT", socket_type="NodeSocketInt"),
               position)
    decal[VERSION_KEY] = OLDER
    del decal[INSIDE_KEY]
    world = bpy.data.worlds.new("Sky")
    light = bpy.data.lights.new("Lamp", "POINT")
    for owner in (world, light):
        if owner.node_tree is None:         # (5.0+ gives each its tree; use_nodes deprecated)
            owner.use_nodes = True
    mine = bpy.data.node_groups.new("My Layer", "ShaderNodeTree")
    trees = {"material": new_material("Rock").node_tree, "world": world.node_tree,
             "light": light.node_tree, "group": mine}
    for tree in trees.values():
        node = tree.nodes.new("ShaderNodeGroup")
        node.name, node.node_tree = "Decal", decal
        node.inputs["Shape"].default_value = 2            # Cylinder (Box, Sphere, Cylinder...)
    take_notes()
    assert U.update_stale_groups() == (["SG Decal"], [])
    shapes = {k: t.nodes["Decal"].inputs["Shape"].default_value for k, t in trees.items()}
    assert shapes == dict.fromkeys(trees, "Cylinder"), shapes      # world, light: ''
    assert take_notes() == []


def test_an_edited_group_renamed_as_asked_is_no_longer_named_edited(fresh):
    G.resolve_group()
    mine = bpy.data.node_groups["SG Resolve"]
    next(n for n in mine.nodes if n.bl_idname == "ShaderNodeVectorMath").mute = True
    _material_using(mine)
    assert "('SG Resolve')" in (U.edited_text() or ""), U.edited_text()
    mine.name = "My Resolve"                   # what the sidebar asked
    assert U.edited_text() is None, U.edited_text()        # was: "... ('My Resolve') ..."
    ours = G.resolve_group()                   # surfgrad's own beside it
    assert ours.name == "SG Resolve" and ours != mine
    assert U.edited_text() is None
