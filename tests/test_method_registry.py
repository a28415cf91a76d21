"""The registry's parameters (reference/method_registry.py, harness/methods.py): one value drives
a method's group socket and its reference's keyword. Every parameter's keyword is one its
reference function takes and its socket is one its group has (tests/interfaces.json); a value
given to .at() reaches the reference (numpy) and the group socket in the graph (Blender)."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from surfgrad_addon.harness.methods import METHODS
from surfgrad_addon.reference import method_registry as MR
from surfgrad_addon.reference.group_interfaces import INTERFACES
from surfgrad_addon.reference import methods as M

pytestmark = pytest.mark.tier("numpy")

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = json.loads((ROOT / "tests" / "interfaces.json").read_text())
_spec = importlib.util.spec_from_file_location("reference_fixture",
                                               ROOT / "tools" / "reference_fixture.py")
FX = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(FX)

PARAMETERS = [(m.name, p) for m in METHODS.values() for p in m.parameters]


def changed(value):
    """A value other than a parameter's default, inside its socket's range."""
    if isinstance(value, int):
        return 3 if value != 3 else 2
    return value * 0.5 if value else 0.25


def test_the_registry_has_parameters_where_a_socket_feeds_the_reference():
    assert len(METHODS) == 23 and len(PARAMETERS) >= 20
    assert [p.name for p in METHODS["normal-map"].parameters] == ["strength"]
    assert {p.name for p in METHODS["volume-noise"].parameters} == {"scale", "amount", "octaves"}
    assert METHODS["post-resolve"].values == (("strength", 0.5),)


@pytest.mark.parametrize("method,parameter", PARAMETERS,
                         ids=[f"{m}-{p.name}" for m, p in PARAMETERS])
def test_every_parameter_names_a_keyword_and_a_socket_that_exist(method, parameter):
    assert MR.accepts(parameter.function, parameter.reference_keyword), parameter
    for group in parameter.groups:
        inputs = {s["name"]: s for s in GOLDEN[group]["sockets"] if s["in_out"] == "INPUT"}
        assert parameter.socket in inputs, (group, parameter.socket, sorted(inputs))
        socket = inputs[parameter.socket]
        # The default and the changed value the tests below use lie in the socket's range.
        assert socket["min_value"] <= parameter.default <= socket["max_value"], socket
        assert socket["min_value"] <= changed(parameter.default) <= socket["max_value"]


@pytest.mark.parametrize("method,parameter", PARAMETERS,
                         ids=[f"{m}-{p.name}" for m, p in PARAMETERS])
def test_every_parameter_keyword_is_its_socket_specs(method, parameter):
    """The socket a parameter sets is declared (reference/group_interfaces.py) with the
    parameter's reference keyword: a socket and its keyword are named once each."""
    for group in parameter.groups:
        specs = {s.name: s for s in INTERFACES[group].inputs}
        assert specs[parameter.socket].keyword == parameter.reference_keyword, (group, parameter)


def test_unknown_parameters_are_refused_by_name():
    with pytest.raises(ValueError, match="method 'normal-map' has no parameter 'strenght'; "
                                         "its parameters: strength"):
        METHODS["normal-map"].at(strenght=0.3)
    with pytest.raises(ValueError, match="its parameters: none"):
        METHODS["parallax"].at(strength=0.3)


def test_at_sets_the_named_values_and_keeps_the_rest():
    m = METHODS["decal"].at(opacity=0.4).at(strength=2.0)
    assert dict(m.values) == {"strength": 2.0, "falloff": MR.DECAL_FALLOFF, "opacity": 0.4}
    assert METHODS["decal"].values == (("strength", 1.0), ("falloff", 0.2), ("opacity", 1.0))
    assert m.name == "decal" and m.variants == METHODS["decal"].variants


def test_sampler_twins_share_their_reference():
    for m in METHODS.values():
        if m.same_reference_as:
            assert m.reference is METHODS[m.same_reference_as].reference, m.name


@pytest.fixture(scope="module")
def texels():
    mesh, size, facts = FX.rasters()["sphere"]
    import surfgrad_addon.reference as R
    return R.rasterize(mesh, "UVMap", 20, 20, facts=facts)


@pytest.mark.parametrize("method,parameter", PARAMETERS,
                         ids=[f"{m}-{p.name}" for m, p in PARAMETERS])
def test_a_value_given_to_at_reaches_the_reference(texels, method, parameter):
    m = METHODS[method]
    if method == "volume-noise-filtered":
        # At 20 texels the footprint fades every octave past the first: the octave count
        # could not show. At 160 the fourth octave is still in the fade (f F < 1/2).
        import surfgrad_addon.reference as R
        mesh, _, facts = FX.rasters()["sphere"]
        texels = R.rasterize(mesh, "UVMap", 160, 160, facts=facts)
    inp = FX.inputs(m.variants[0])
    plain = M.resolve(m.reference(inp, texels))
    same = M.resolve(m.at(**{parameter.name: parameter.default}).reference(inp, texels))
    other = M.resolve(m.at(**{parameter.name: changed(parameter.default)}).reference(inp,
                                                                                       texels))
    np.testing.assert_array_equal(same, plain)
    assert np.abs(other - plain).max() > 1e-4, (method, parameter.name)


def test_the_strength_keyword_is_the_reference_functions_own():
    """normal-map at strength 0 is flat in the reference: the keyword really arrives."""
    mesh, _, facts = FX.rasters()["sphere"]
    import surfgrad_addon.reference as R
    td = R.rasterize(mesh, "UVMap", 16, 16, facts=facts)
    n, sg = METHODS["normal-map"].at(strength=0.0).reference(FX.inputs(), td)
    np.testing.assert_allclose(M.resolve((n, sg)), n, atol=1e-12)


@pytest.mark.tier("blender")
def test_the_parallax_groups_steps_are_the_registrys():
    pytest.importorskip("bpy")
    from surfgrad_addon.addon import groups as G
    assert G.POM_STEPS == MR.POM_STEPS


@pytest.mark.tier("blender")
def test_a_value_given_to_at_reaches_every_group_socket_it_names():
    """Each method's graph at changed values (every variant) has them on every node of the
    parameter's groups; at its defaults, the defaults."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.addon.compat import new_material
    from surfgrad_addon.harness import compare as C
    from surfgrad_addon.harness import scenes
    from surfgrad_addon.harness.methods import _group_interface
    obj = scenes.new_scene(["Sphere"])["Sphere"]
    checked = 0
    for m in METHODS.values():
        if m.unavailable_reason() or not m.parameters:
            continue
        for variant in m.variants:
            for values in (dict(m.values), {p.name: changed(p.default) for p in m.parameters}):
                inp = C.prepare_inputs(obj, variant=variant)
                material = new_material("registry probe")
                try:
                    with m.scene(obj, inp):
                        nodes, links = material.node_tree.nodes, material.node_tree.links
                        m.at(**values).graph(inp, nodes, links)
                        for p in m.parameters:
                            found = [n.inputs[p.socket].default_value for n in nodes
                                     if getattr(n, "node_tree", None) is not None
                                     and _group_interface(n.node_tree.name) in p.groups]
                            assert found, (m.name, variant, p.name)
                            assert found == pytest.approx([values[p.name]] * len(found),
                                                          rel=1e-6), (m.name, p.name)
                            checked += 1
                finally:
                    bpy.data.materials.remove(material)
                    for _, img in inp.images.values():
                        bpy.data.images.remove(img)
    assert checked >= 2 * len([p for m in METHODS.values() if m.unavailable_reason() is None
                               for p in m.parameters])


@pytest.mark.tier("blender")
def test_a_parameter_whose_group_is_missing_is_a_build_error():
    pytest.importorskip("bpy")
    import bpy
    from surfgrad_addon.addon.compat import new_material
    from surfgrad_addon.addon.node_builder import BuildError
    from surfgrad_addon.harness.graph import Graph
    from surfgrad_addon.harness.methods import set_parameter
    material = new_material("registry probe")
    try:
        g = Graph(material.node_tree.nodes, material.node_tree.links)
        with pytest.raises(BuildError, match="sets 'Strength' of SG Normal Map, which its "
                                             "graph does not have"):
            set_parameter(g, "normal-map", METHODS["normal-map"].parameters[0], 0.5)
    finally:
        bpy.data.materials.remove(material)
