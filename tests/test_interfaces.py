"""Every group's interface (names, types, subtypes, defaults, ranges, tooltips) is the same on
every supported Blender line: built here and compared with tests/interfaces.json, which the
main line wrote (SURFGRAD_WRITE_INTERFACES=1 bash run.sh test -k interfaces, after changing a
group on purpose). The one documented difference: a group behind a feature gate
(groups.REQUIRES: SG Displace below 4.5) is absent, and refused with a message."""

import json
import os
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

from conftest import write_report  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.node_builder import interface_signature  # noqa: E402

pytestmark = pytest.mark.tier("blender")


GOLDEN = Path(__file__).with_name("interfaces.json")


def _signatures():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    G.build_all()
    G.bump_strength_group()          # built by Convert, not by the menu
    for name, build in G.GEOMETRY_MENU_GROUPS:
        if G.unavailable_reason(name) is None:
            build()
    return {tree.name: interface_signature(tree)
            for tree in sorted(bpy.data.node_groups, key=lambda t: t.name)}


def test_interfaces_are_the_same_on_every_line():
    got = _signatures()
    write_report("interfaces", {"groups": got})
    if os.environ.get("SURFGRAD_WRITE_INTERFACES"):
        GOLDEN.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
    want = json.loads(GOLDEN.read_text())
    gated = {name for name in want if G.unavailable_reason(name)}
    gated |= {h for name in gated for h in G.GATED_HELPERS.get(name, ())}
    assert sorted(got) == sorted(set(want) - gated), (sorted(got), sorted(want), gated)
    for name in got:
        assert got[name] == want[name], (name, got[name], want[name])
    # Every socket has a tooltip, and the menu groups are all there.
    assert all(s["description"] for sig in got.values() for s in sig["sockets"])
    assert {name for name, _ in G.MENU_GROUPS if G.unavailable_reason(name) is None} <= set(got)
