"""Every group's interface (names, types, subtypes, defaults, ranges, tooltips) is the same on
every supported Blender line and is what the socket specs declare: tests/interfaces.json is
written from them (python tools/write_interfaces.py, after changing a spec on purpose), the
groups built here must match it, and it must match what the specs write now (a spec edited
without regenerating fails). The documented differences between lines: a group behind a
feature gate (groups.REQUIRES: SG Displace below 4.5) is absent, and refused with a message;
an enumeration is a Menu socket where the line has them (blender_lines.menu_sockets, 5.0 and
later) and its integer 0..N-1 in the same order on 4.2 and 4.5 (the golden file is the Menu
line's; GI.expected_signatures(menu_sockets=False) the other)."""

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


@pytest.mark.tier("numpy")
def test_lines_without_menus_differ_only_in_the_enumerations():
    """4.2 and 4.5's interfaces: each Menu socket is an integer with the items' order in its
    range and its tooltip; everything else is the golden file."""
    golden, plain = _golden(), json.loads(json.dumps(GI.expected_signatures(menu_sockets=False)))
    assert golden.keys() == plain.keys()
    menus = 0
    for name in golden:
        for g, p in zip(golden[name]["sockets"], plain[name]["sockets"], strict=True):
            if g["type"] != "NodeSocketMenu":
                assert g == p, (name, g, p)
                continue
            menus += 1
            spec = next(s for s in GI.INTERFACES[name].inputs if s.name == g["name"])
            assert g["default_value"] == spec.items[0][0]
            assert (p["type"], p["default_value"], p["min_value"], p["max_value"]) == \
                ("NodeSocketInt", 0, 0, len(spec.items) - 1)
            listed = ", ".join(f"{k} {n}" for k, (n, _) in enumerate(spec.items))
            assert p["description"] == f"{g['description']} ({listed})"
    assert menus >= 1
    blend = {s["name"]: s for s in golden["SG Blend Normals"]["sockets"]}["Method"]
    assert blend["type"] == "NodeSocketMenu"


@pytest.mark.tier("numpy")
def test_a_float_input_name_has_one_range_across_the_groups():
    """One meaning and one range per input name. The one name with two: Strength, the
    converted Blender node's own (0..10, NODE_STRENGTH's tooltip) and the surface-gradient
    multiplier (-100..100); each tooltip says which."""
    ranges = {}
    for iface in GI.INTERFACES.values():
        for s in iface.inputs:
            if s.type in (S.FLOAT, S.INT):
                ranges.setdefault(s.name, set()).add((s.min, s.max))
    assert {n: r for n, r in ranges.items() if len(r) > 1} == \
        {"Strength": {(0.0, 10.0), (-100.0, 100.0)}}
    strengths = {s.tooltip for i in GI.INTERFACES.values() for s in i.inputs
                 if s.name == "Strength" and s.min == 0.0}
    assert all("Strength" in t and "node" in t for t in strengths), strengths
    assert "Normal Map node" in S.STRENGTH.tooltip


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
    from surfgrad_addon.reference.blender_lines import facts_for
    got = _signatures(bpy, G, interface_signature)
    write_report("interfaces", {"groups": got})
    menus = facts_for(bpy.app.version).menu_sockets
    want = _golden() if menus else json.loads(json.dumps(GI.expected_signatures(False)))
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
