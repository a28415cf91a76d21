"""Red team 40b: the Material Output an EEVEE scene renders through.

Round 39 made Add Layer Stack wire the stack into the shader of the output Cycles renders
(a Cycles output before an active All one). In an EEVEE scene (every line's default engine) it
still took the active output whatever its target: beside an active All output, the shader of
an output targeted at EEVEE (the one EEVEE renders, Blender's ntreeShaderOutputNode rule with
the EEVEE target) got nothing, the All one's did, and the EEVEE render (and Material Preview)
did not change; an active output targeted at Cycles got the stack the same way. A material
whose outputs are all targeted at Cycles took the stack in an EEVEE scene, which renders none
of them. Now the scene's engine picks the output by its target, on every line (EEVEE is
BLENDER_EEVEE_NEXT on 4.2 and 4.5, BLENDER_EEVEE from 5.0).

The rule was measured with EEVEE renders of one Emission per output on 5.2 (red into the
first output, green into the second): green, the output expected here, in all three cases.
Not a test here: an EEVEE render takes about a minute on a machine without a GPU.
"""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.operators import SurfgradError  # noqa: E402

pytestmark = pytest.mark.tier("blender")

EEVEE = "BLENDER_EEVEE" if bpy.app.version >= (5, 0, 0) else "BLENDER_EEVEE_NEXT"


def _outputs(*targets, active):
    """A material with one Material Output per target, each fed by its own Diffuse BSDF, the
    one at `active` made active: (material, [BSDF per output])."""
    mat = new_material("Outputs")
    tree = mat.node_tree
    tree.nodes.clear()
    shaders = []
    for target in targets:
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        out.target = target
        bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
        tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
        shaders.append((out, bsdf))
    shaders[active][0].is_active_output = True
    return mat, [bsdf for _, bsdf in shaders]


def _wired(mat, shaders):
    """The indices of the shaders whose Normal the layer stack feeds."""
    resolve = api.add_layer_stack(mat)["resolve"]
    return [i for i, s in enumerate(shaders)
            if s.inputs["Normal"].is_linked and s.inputs["Normal"].links[0].from_node == resolve]


@pytest.mark.parametrize("targets, active, rendered", [
    (("ALL", "EEVEE"), 0, 1),          # EEVEE's own output before an active All one
    (("CYCLES", "ALL"), 0, 1),         # an active Cycles output is not EEVEE's
    (("EEVEE", "EEVEE"), 1, 1),        # within the target, the active one
])
def test_the_layer_stack_goes_into_the_shader_eevee_renders(targets, active, rendered):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.context.scene.render.engine == EEVEE          # the id on this line
    mat, shaders = _outputs(*targets, active=active)
    assert _wired(mat, shaders) == [rendered]
    bpy.context.scene.render.engine = "CYCLES"               # Cycles' rule stays as it was
    mat, shaders = _outputs("ALL", "CYCLES", active=0)
    assert _wired(mat, shaders) == [1]


def test_a_material_eevee_renders_none_of_is_refused_in_an_eevee_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat, shaders = _outputs("CYCLES", active=0)
    nodes = len(mat.node_tree.nodes)
    with pytest.raises(SurfgradError, match=r"targeted at another engine than the scene's "
                                            r"\(EEVEE\): set one's target to All or EEVEE"):
        api.add_layer_stack(mat)
    assert len(mat.node_tree.nodes) == nodes and not shaders[0].inputs["Normal"].is_linked
