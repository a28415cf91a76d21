"""Muted SG groups that pass a vector off as what they output (docs/artists.md, "Switching a
layer off"). Blender mutes a group node by passing one input straight to each output: a
linked one before an unlinked one (passed_input), so a layer whose Normal is unlinked passes
whatever later input is linked (SG Volume Gradient: its Gradient, unprojected), and a muted
SG Resolve passes its Surface Gradient as the normal."""

# What a muted group may pass on unwarned: SG Combine's and SG Height Blend's gradient
# underneath (A), SG Resolve's base normal.
_LIKE_FOR_LIKE = {"Surface Gradient": "A", "Gradient": "A", "Normal": "Normal"}
# Blender's find_internally_linked_input (node.cc): the inputs of a type a vector output can
# take, by how close the type is; of those, in order, one replaces the one chosen when its
# type is closer or it is linked and that one is not. Pinned by bakes on every line
# (tests/test_faults_leftovers42a.py): 4.2 and 4.5 show no group node's internal links to
# Python (5.0 and later do, and agree).
_VECTOR_PRIORITY = {"VECTOR": 4, "VALUE": 3, "INT": 2, "BOOLEAN": 1}


def passed_input(node, output):
    """The input muted `node` passes to its vector output `output` (None: none): its internal
    links, where Blender has made them (a tree no object's material has used yet has none)."""
    if node.internal_links:
        return next((lk.from_socket for lk in node.internal_links
                     if lk.to_socket.identifier == output.identifier), None)
    return blender_rule_input(node)


def blender_rule_input(node):
    """The input Blender's rule picks for a muted node's vector output (_VECTOR_PRIORITY)."""
    chosen, priority, linked = None, -1, False
    for socket in node.inputs:
        p = _VECTOR_PRIORITY.get(socket.type, -1) if socket.enabled else -1
        if p >= 0 and (p > priority or socket.is_linked and not linked):
            chosen, priority, linked = socket, p, socket.is_linked
    return chosen


def wrong_muted_layers(tree):
    """[(node name, group name, input name)] for muted SG group nodes in `tree` whose gradient
    output (SG Resolve's normal) carries a linked input other than its like (the gradient
    underneath, the base normal)."""
    found = []
    for node in getattr(tree, "nodes", ()):
        group = getattr(node, "node_tree", None)
        if not node.mute or group is None or not group.name.startswith("SG "):
            continue
        for output in node.outputs:
            like = _LIKE_FOR_LIKE.get(output.name)
            passed = passed_input(node, output) if like and output.type == "VECTOR" else None
            if passed is not None and passed.is_linked and passed.name != like:
                found.append((node.name, group.name, passed.name))
                break
    return found


def muted_layer_warning(tree):
    """The sidebar's warning for wrong_muted_layers(tree), or '' when there are none."""
    found = wrong_muted_layers(tree)
    if not found:
        return ""
    named = ", ".join(f"'{node}' ({inp})" for node, _group, inp in found)
    return (f"Muted SG node passes its linked input on as what it outputs: {named}. Unmute "
            f"it and set its Strength or Bump Scale to 0 to switch the layer off.")
