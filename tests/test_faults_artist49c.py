"""Red team 49c: what a script's api call and the sidebar say of groups the artist edited.

1. api.node_group and api.add_layer_stack rebuilt an older group the artist had edited inside
   (a node muted) or whose socket they had renamed, and said nothing: node_builder's notes
   reached only the operators' reports (red team 47d), and stayed queued for the next
   operator, which then reported another call's rebuild. Now each call warns on stderr, as
   the api's bakes do ("surfgrad: warning: ..."), of its own rebuilds' notes.
"""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import node_builder as NB  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402

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
