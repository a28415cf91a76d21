"""What a muted SG group node passes to its surface-gradient output, pinned on every line.

Blender mutes a group node by passing, for each output, an input of the same type straight
through (the node's internal links). Every SG group whose output is a surface gradient has a
vector input before its gradient-shaped inputs, so a muted layer outputs that input's value:
zero (a flat layer, as an artist expects) where it is unlinked, but a whole normal or tangent,
read as a gradient, where it is linked (docs/artists.md, "Switching a layer off"). One bake
links a distinct vector into every vector input of every group and reads back which comes out;
another, with nothing linked, checks that the muted layers are flat. The sidebar warns of the
muted layers that pass a linked vector other than the gradient underneath (addon/muted_layers).
"""
import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

pytest.importorskip("bpy")

from support import bake_probe as probe  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.muted_layers import (  # noqa: E402
    muted_layer_warning, wrong_muted_layers)
from surfgrad_addon.addon.node_vocabulary import VMath  # noqa: E402

SIZE = 2
# The input each muted group passes to its gradient output (None: nothing, the output is zero).
PASSED = {"SG Tangent Normal": "Tangent", "SG Combine": "A", "SG Height Blend": "A",
          "SG Noise": "Vector"}
GRADIENT_OUTPUTS = ("Surface Gradient", "Gradient")


def _gradient_groups():
    trees = G.build_all()
    return {name: tree for name, tree in trees.items()
            if any(s.name in GRADIENT_OUTPUTS for s in tree.interface.items_tree
                   if getattr(s, "in_out", None) == "OUTPUT")}


def _passed_inputs(names, linked=True):
    """{name: the vector input whose value a muted group passes to its gradient, or None for
    zero}, from one bake: group k's vector input i carries i + 1 as base-8 digit k % 6 of
    channel k // 6 (exact in float32), and the muted outputs are summed. linked=False: the
    inputs are left unlinked (their default values carry the tags)."""
    probe.new_scene()
    pr = probe.EmissionProbe(probe.add_uv_plane())
    trees = G.build_all()
    total, inputs = None, {}
    for k, name in enumerate(names):
        channel, place = divmod(k, 6)
        node = pr.node("ShaderNodeGroup", node_tree=trees[name])
        inputs[name] = [s for s in node.inputs if s.type == "VECTOR"]
        for i, socket in enumerate(inputs[name]):
            tag = [0.0, 0.0, 0.0]
            tag[channel] = float((i + 1) * 8 ** place)
            if linked:
                pr.link(pr.combine(*tag), socket)
            else:
                socket.default_value = tag
        node.mute = True
        out = next(s for s in node.outputs if s.name in GRADIENT_OUTPUTS)
        total = out if total is None else pr.vmath(VMath.ADD, total, out)
    px = pr.bake(total, SIZE, SIZE)[0, 0, :3].astype(np.int64)
    got = {}
    for k, name in enumerate(names):
        channel, place = divmod(k, 6)
        digit = int(px[channel]) // 8 ** place % 8
        got[name] = None if digit == 0 else inputs[name][digit - 1].name
    return got


def test_muted_layer_passes_its_first_vector_input():
    names = sorted(_gradient_groups())
    assert "SG Volume Gradient" in names and "SG Normal Map" in names and len(names) <= 18
    want = {name: PASSED.get(name, "Normal") for name in names}
    assert _passed_inputs(names) == want


def test_muted_layer_with_nothing_linked_is_flat():
    names = sorted(_gradient_groups())
    assert _passed_inputs(names, linked=False) == {name: None for name in names}


def test_sidebar_warns_of_the_muted_layers_that_pass_a_linked_vector():
    """Every gradient group three times: muted with its vectors linked (warned unless what
    passes is the gradient underneath, per the pinned table), muted with nothing linked and
    linked but not muted (neither warned)."""
    trees = _gradient_groups()
    nt = new_material("muted layers").node_tree
    geometry = nt.nodes.new("ShaderNodeNewGeometry")
    for name, tree in trees.items():
        for case in ("muted linked", "muted", "linked"):
            node = nt.nodes.new("ShaderNodeGroup")
            node.node_tree = tree
            node.name = f"{name} {case}"
            node.mute = case.startswith("muted")
            if case.endswith("linked"):
                for socket in node.inputs:
                    if socket.type == "VECTOR":
                        nt.links.new(geometry.outputs["Normal"], socket)
    want = sorted((f"{name} muted linked", name, PASSED.get(name, "Normal"))
                  for name in trees if PASSED.get(name, "Normal") != "A")
    assert sorted(wrong_muted_layers(nt)) == want
    assert "'SG Volume Gradient muted linked' (Normal)" in muted_layer_warning(nt)
    assert muted_layer_warning(new_material("plain").node_tree) == ""
