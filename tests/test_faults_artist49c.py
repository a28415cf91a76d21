"""Red team 49c: what a script's api call and the sidebar say of groups the artist edited.

1. api.node_group and api.add_layer_stack rebuilt an older group the artist had edited inside
   (a node muted) or whose socket they had renamed, and said nothing: node_builder's notes
   reached only the operators' reports (red team 47d), and stayed queued for the next
   operator, which then reported another call's rebuild. Now each call warns on stderr, as
   the api's bakes do ("surfgrad: warning: ..."), of its own rebuilds' notes.
2. The sidebar listed the file's older groups (and a library's) but not a current group the
   artist edited inside, which every Add and api call then refuses (red team 47d): the artist
   learnt of it only when an Add failed. Now the sidebar names them and the fix (rename).
"""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import group_updates as U  # noqa: E402
from surfgrad_addon.addon import node_builder as NB  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402
from test_faults_artist47 import _Sidebar  # noqa: E402

pytestmark = pytest.mark.tier("blender")

EDITED = ("surfgrad: warning: node group 'SG Resolve' was edited inside after surfgrad made "
          "it (a node or link added, removed, muted or set otherwise), and its rebuild for "
          "this version replaced that edit: to keep it, undo (Ctrl+Z) and rename the group\n")


def _older_edited_resolve():
    group = G.resolve_group()
    next(n for n in group.nodes if n.bl_idname == "ShaderNodeVectorMath").mute = True
    group[VERSION_KEY] = G.VERSION - 1
    return group


@pytest.mark.parametrize("call", ["node_group", "add_layer_stack"])
def test_an_api_call_warns_of_the_edit_its_rebuild_replaced(fresh, capfd, call):
    group = _older_edited_resolve()
    NB._NOTES.append("an earlier caller's note")
    capfd.readouterr()
    if call == "node_group":
        assert api.node_group("SG Resolve") == group
    else:
        api.add_layer_stack(new_material("Rock"))
    err = capfd.readouterr().err
    assert not any(n.mute for n in group.nodes) and group[VERSION_KEY] == G.VERSION
    assert err == EDITED, err
    assert NB.take_notes() == []                 # not reported again by the next operator


def test_the_sidebar_names_current_groups_edited_inside(fresh):
    sidebar = _Sidebar()
    G.combine_group()
    G.blend_normals_group()
    U.draw_stale_warning(sidebar)
    assert sidebar.boxes == []                   # current and as built: nothing to say
    for name in ("SG Resolve", "SG Combine"):
        group = G.resolve_group() if name == "SG Resolve" else bpy.data.node_groups[name]
        next(n for n in group.nodes if n.bl_idname == "ShaderNodeVectorMath").mute = True
    U.draw_stale_warning(sidebar)
    [box] = sidebar.boxes
    assert " ".join(box.labels) == (
        "2 surface-gradient group(s) were edited inside after surfgrad made them ('SG "
        "Combine', 'SG Resolve'): surfgrad will not add or use them as its own; rename each "
        "to keep your version, so surfgrad can add its own"), box.labels
    assert box.operators == []                   # (Update would replace the edit)
