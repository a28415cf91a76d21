"""Muted SG layers that pass a normal off as a surface gradient (docs/artists.md, "Switching a
layer off"). Blender mutes a group node by passing its first input of the output's type
through: for SG layer groups that is Normal (Tangent, Vector), read as a gradient when linked."""

# SG Combine's and SG Height Blend's first vector input is the gradient underneath: right.
_UNDERNEATH = "A"
_GRADIENT_OUTPUTS = ("Surface Gradient", "Gradient")


def wrong_muted_layers(tree):
    """[(node name, group name, input name)] for muted SG group nodes in `tree` whose first
    vector input is linked and whose gradient output therefore carries that vector."""
    found = []
    for node in getattr(tree, "nodes", ()):
        group = getattr(node, "node_tree", None)
        if not node.mute or group is None or not group.name.startswith("SG "):
            continue
        if not any(s.name in _GRADIENT_OUTPUTS for s in node.outputs):
            continue
        first = next((s for s in node.inputs if s.type == "VECTOR"), None)
        if first is not None and first.is_linked and first.name != _UNDERNEATH:
            found.append((node.name, group.name, first.name))
    return found


def muted_layer_warning(tree):
    """The sidebar's warning for wrong_muted_layers(tree), or '' when there are none."""
    found = wrong_muted_layers(tree)
    if not found:
        return ""
    named = ", ".join(f"'{node}' ({inp})" for node, _group, inp in found)
    return (f"Muted SG node passes its linked input as a gradient: {named}. Unmute it and "
            f"set its Strength or Bump Scale to 0 to switch the layer off.")
