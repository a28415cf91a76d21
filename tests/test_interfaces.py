"""Every group's interface (names, types, subtypes, defaults, ranges, tooltips) is the same on
every supported Blender line and is what the socket specs declare: tests/interfaces.json is
written from them (python tools/write_interfaces.py, after changing a spec on purpose), the
groups built here must match it, and it must match what the specs write now (a spec edited
without regenerating fails). The one documented difference between lines: a group behind a
feature gate (groups.REQUIRES: SG Displace below 4.5) is absent, and refused with a message."""

import json
from pathlib import Path

import pytest

from surfgrad_addon.reference import group_interfaces as GI
from surfgrad_addon.reference import socket_specs as S

pytestmark = pytest.mark.tier("blender")      # the specs' own tests are numpy

GOLDEN = Path(__file__).with_name("interfaces.json")


def _golden():
    return json.loads(GOLDEN.read_text())


@pytest.mark.tier("numpy")
def test_the_golden_file_is_what_the_specs_write():
    want = json.loads(json.dumps(GI.expected_signatures()))
    assert _golden() == want, "tests/interfaces.json is stale: python tools/write_interfaces.py"


@pytest.mark.tier("numpy")
def test_each_socket_kind_is_declared_once_with_a_tooltip():
    kinds = [v for v in vars(S).values() if isinstance(v, S.SocketSpec)]
    assert len(kinds) > 20
    # One Bump Scale and one bump-scale Strength; the groups use them or a variant of them.
    sockets = [(name, s) for name, sig in _golden().items() for s in sig["sockets"]]
    bump = [s for _, s in sockets if s["name"] == "Bump Scale" and s["min_value"] < 0]
    assert len(bump) >= 6 and all(s["min_value"] == S.BUMP_SCALE.min for s in bump)
    strength = [s for _, s in sockets if s["name"] == "Strength"
                and s["description"] == S.STRENGTH.tooltip]
    assert {(s["min_value"], s["max_value"]) for s in strength} == {(-100.0, 100.0)}
    assert len(strength) >= 5
    assert S.STRENGTH.keyword == "strength" and S.BUMP_SCALE.keyword == "bump_scale"
    assert all(s["description"] for _, s in sockets)


@pytest.mark.tier("numpy")
def test_a_spec_edit_changes_what_is_written():
    """The check above can fail: a changed range shows up in the written signature."""
    row = GI.signature_row(S.BUMP_SCALE.but(max=5.0), "INPUT")
    assert row["max_value"] == 5.0 != GI.signature_row(S.BUMP_SCALE, "INPUT")["max_value"]
    assert GI.signature_row(S.SAMPLER, "INPUT") == {
        "name": "Sampler", "in_out": "INPUT", "type": "NodeSocketClosure",
        "description": S.SAMPLER.tooltip, "hide_value": False}


def _signatures(bpy, G, interface_signature):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    G.build_all()
    G.bump_strength_group()          # built by Convert, not by the menu
    G.mikktspace_frame_group()       # built by the bench
    G.height_map_group(variant="one-texel")
    for name, build in G.GEOMETRY_MENU_GROUPS:
        if G.unavailable_reason(name) is None:
            build()
    return {tree.name: interface_signature(tree)
            for tree in sorted(bpy.data.node_groups, key=lambda t: t.name)}


def test_interfaces_are_the_same_on_every_line():
    bpy = pytest.importorskip("bpy")
    from conftest import write_report
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.addon.node_builder import interface_signature
    got = _signatures(bpy, G, interface_signature)
    write_report("interfaces", {"groups": got})
    want = _golden()
    gated = {name for name in want if G.unavailable_reason(name)}
    gated |= {h for name in gated for h in G.GATED_HELPERS.get(name, ())}
    assert sorted(got) == sorted(set(want) - gated), (sorted(got), sorted(want), gated)
    for name in got:
        assert got[name] == want[name], (name, got[name], want[name])
    # Every socket has a tooltip, and the menu groups are all there.
    assert all(s["description"] for sig in got.values() for s in sig["sockets"])
    assert {name for name, _ in G.MENU_GROUPS if G.unavailable_reason(name) is None} <= set(got)


@pytest.mark.tier("numpy")
def test_every_keyword_is_a_parameter_of_the_reference():
    """A spec's keyword names a parameter the reference takes, so a registry can pass one value
    to the socket and to the reference."""
    import inspect
    from surfgrad_addon.reference import height_blend, methods, noise
    params = {p for module in (methods, noise, height_blend)
              for _, fn in inspect.getmembers(module, inspect.isfunction)
              for p in inspect.signature(fn).parameters}
    specs = {s for iface in GI.INTERFACES.values() for s in (*iface.inputs, *iface.outputs)}
    keywords = {s.keyword for s in specs if s.keyword}
    assert {"strength", "bump_scale", "k", "directx", "amount"} <= keywords
    assert keywords <= params, keywords - params
