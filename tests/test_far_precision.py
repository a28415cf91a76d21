"""Precise Far From Origin (addon/far_precision.py): off by default on the groups that have it
(the precise route then costs nothing, tests/test_render_cost_folding.py), switched on for an
object farther than 64 m by the Add Decal Projector operator, by api.update_precise_far and by
the harness's bakes."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import far_precision as F, groups as G, operators as O  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402
from surfgrad_addon.reference.socket_specs import PRECISE_FAR  # noqa: E402

pytestmark = pytest.mark.tier("blender")

WITH_INPUT = ("SG Triplanar Coordinates", "SG Triplanar (Sampler)", "SG Triplanar Height",
              "SG Triplanar Height (Sampler)", "SG Projector Coordinates", "SG Noise")


@pytest.fixture()
def sphere():
    obj = scenes.new_scene(("Sphere",))["Sphere"]
    yield obj
    obj.location = (0.0, 0.0, 0.0)


def _switches(tree):
    return {n.node_tree.name: n.inputs[PRECISE_FAR.name].default_value for n in tree.nodes
            if n.bl_idname == "ShaderNodeGroup" and PRECISE_FAR.name in n.inputs}


def test_the_input_is_off_by_default_where_it_exists():
    for name in WITH_INPUT:
        if G.unavailable_reason(name):          # the Sampler groups from 5.0
            continue
        entry = G.BY_NAME[name]
        tree = entry.build(image=None) if entry.image_bound else entry.build()
        item = next(i for i in tree.interface.items_tree
                    if getattr(i, "name", None) == PRECISE_FAR.name)
        assert item.in_out == "INPUT" and item.default_value is False, name


@pytest.mark.parametrize("distance,on", [(0.0, False), (50.0, False), (80.0, True),
                                         (10000.0, True)])
def test_api_switches_it_by_the_objects_distance(sphere, distance, on):
    """The Sphere has radius 1: its bounding box reaches distance + sqrt(3) m out."""
    mat = new_material("far precision")
    sphere.data.materials.clear()
    sphere.data.materials.append(mat)
    nodes = mat.node_tree.nodes
    for build in (G.triplanar_coordinates_group, G.projector_coordinates_group, G.noise_group,
                  G.normal_map_group):
        nodes.new("ShaderNodeGroup").node_tree = build()
    sphere.location = (distance / np.sqrt(3),) * 3
    bpy.context.view_layer.update()
    assert F.needs_precise_far(sphere) is on
    assert api.update_precise_far(sphere) == 3          # SG Normal Map has no such input
    assert _switches(mat.node_tree) == {"SG Triplanar Coordinates": on,
                                        "SG Projector Coordinates": on, "SG Noise": on}
    with pytest.raises(ValueError, match="material slots"):
        api.update_precise_far(None)


@pytest.mark.parametrize("distance", [0.0, 1000.0])
def test_the_decal_operator_switches_it_for_the_active_object(sphere, distance):
    mat = new_material("far decal")
    sphere.data.materials.clear()
    sphere.data.materials.append(mat)
    sphere.location = (distance, 0.0, 0.0)
    bpy.context.view_layer.objects.active = sphere
    bpy.context.view_layer.update()
    empty, _ = O.add_decal_projector(bpy.context, mat.node_tree)
    try:
        assert _switches(mat.node_tree) == {"SG Projector Coordinates": distance > 0.0}
    finally:
        bpy.data.objects.remove(empty)
