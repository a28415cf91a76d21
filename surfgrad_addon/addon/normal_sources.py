"""Which nodes of a material can change the normal a normal-map bake writes.

The bake renders each BSDF as a white Diffuse stand-in fed its Normal (bake_closures.py), so
of the shaders reaching the Material Output only their Normal inputs, a Mix Shader's Fac (the
closures' weights, which Cycles' average of their normals uses) and the shaders they take
reach the map; so does the output's Displacement (bump or true displacement bends the
normal). Everything upstream of those sockets counts: through reroutes, muted nodes (the
inputs they pass on), node groups (into a group through the output socket used, of its
active Group Output; out of it through the Group Input socket reached) and SG groups' inputs. An image that feeds only a
Base Color or a Roughness is left out: Cycles does not read it for the bake, so a missing one
cannot change the map (image_checks warns of it, and refuses only those that reach)."""

from .bake_closures import CARRIERS, baked_inputs
from .material_inputs import cycles_output, group_outputs, live_links, renders_nothing

REACHED = ("Surface", "Displacement")     # Material Output inputs the bake's normal reads


def normal_nodes(mat):
    """{(tree pointer, node name)} of every node of `mat` (in its tree and in the node groups
    it uses) whose value can reach the normal the bake writes; empty when Cycles renders
    nothing through its output (material_inputs.renders_nothing)."""
    tree = mat.node_tree
    output = cycles_output(tree) if tree is not None else None
    if output is None or renders_nothing(output):
        return set()
    found, seen = set(), set()
    todo = [(s, ()) for s in output.inputs if s.identifier in REACHED]
    while todo:
        socket, outer = todo.pop()
        key = (socket.as_pointer(), tuple(g.as_pointer() for g in outer))
        if key in seen:
            continue
        seen.add(key)
        for link in live_links(socket):
            todo += _sources(link, outer, found)
    return found


def _sources(link, outer, found):
    """The (input socket, group nodes it lies in) whose values make `link`'s value; the node
    it comes from is added to `found`."""
    node, out = link.from_node, link.from_socket
    if node.mute:                       # passes on only the input its internal link names
        return [(lk.from_socket, outer) for lk in node.internal_links
                if lk.to_socket.identifier == out.identifier]
    if node.bl_idname == "NodeGroupInput":
        if not outer:
            return []
        group = outer[-1]
        return [(s, outer[:-1]) for s in group.inputs if s.identifier == out.identifier]
    found.add((node.id_data.as_pointer(), node.name))
    inner = getattr(node, "node_tree", None) if node.bl_idname == "ShaderNodeGroup" else None
    if inner is not None:
        if any(g.node_tree == inner for g in outer):
            return []                   # a group that holds itself: Blender renders nothing
        return [(s, (*outer, node)) for n in group_outputs(inner)
                for s in n.inputs if s.identifier == out.identifier]
    if node.bl_idname == "ShaderNodeGroup":
        return []
    # A shader out of an Evaluate Closure or a Separate Bundle (5.0+) is the one its Closure or
    # Bundle input carries: baked_inputs (shader sockets only) dropped it, so a missing normal
    # map in a Closure Zone was only warned of and baked magenta (54.7 degrees off, exit 0).
    carried = any(s.type in CARRIERS for s in node.inputs)
    inputs = baked_inputs(node) if out.type == "SHADER" and not carried else list(node.inputs)
    return [(s, outer) for s in inputs]


def reaches_normal(node, reached):
    """True when image node `node` (of a material's tree or a group's) is in `reached`
    (normal_nodes of that material)."""
    return (node.id_data.as_pointer(), node.name) in reached
