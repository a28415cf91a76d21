"""A preview left in a material: Connect to Output (Ctrl+Shift+click in the Shader Editor,
Node Wrangler's preview before 4.2) links the clicked node's output straight to the Material
Output's Surface, a colour or a vector in place of the BSDF, and the BSDF is left unlinked
beside it. Cycles renders that value as an emission: no closure, so a normal-map bake wrote
the surface's own normal wherever the material's stack bent it (a plane whose SG stack leans
up to 36 degrees baked flat, median 20.6 degrees off, exit 0; rt59h). The bake refuses it,
naming the node and the fix; an emission-only material (no shader node left aside) bakes as
before. Node Wrangler before 4.2 (Blender 2.8 to 4.1) previewed through an Emission node it
named "Emission Viewer" into the Surface: a file saved so holds the same trap, a shader this
time (it baked flat as well)."""

from .bake_closures import CARRIERS
from .material_inputs import cycles_output, live_links, renders_nothing, upstream_nodes

KINDS = {"RGBA": "colour", "VECTOR": "vector", "VALUE": "number", "INT": "whole number"}
VIEWER = "Emission Viewer"     # Node Wrangler's preview node before 4.2
# Sockets that make a closure (or carry one, 5.0+) into the Surface: not a preview.
SHADERS = ("SHADER", "CUSTOM") + CARRIERS


def _surface_source(output):
    """The (node, socket) feeding `output`'s Surface through reroutes, or None."""
    links = live_links(output.inputs["Surface"])
    while links:
        node, socket = links[0].from_node, links[0].from_socket
        if node.bl_idname != "NodeReroute":
            return node, socket
        links = live_links(node.inputs[0])
    return None


def previewed(tree, output):
    """The text naming the value `output`'s Surface takes in place of a shader while a shader
    node of `tree` is left unlinked (a preview), or None."""
    source = _surface_source(output) if output is not None else None
    if source is None:
        return None
    node, socket = source
    viewer = node.bl_idname == "ShaderNodeEmission" and node.name.startswith(VIEWER)
    if socket.type in SHADERS and not viewer:
        return None
    # Shader nodes this output does not render: a shader it renders elsewhere (a volume into
    # its Volume) is not left aside, a colour into the Surface beside it no preview; one
    # linked only to another output (EEVEE's) is.
    used = {name for sock in output.inputs for name in upstream_nodes(sock)}
    aside = [n.name for n in tree.nodes if not n.mute and n != node and n.name not in used
             and any(o.type == "SHADER" for o in n.outputs)]
    if not aside:                       # an emission-only material: nothing was left out
        return None
    what = (f"Node Wrangler's preview node {node.name!r} into its Surface (an older "
            f"Blender's Ctrl+Shift+click)" if viewer else
            f"{node.name!r} {socket.name} (a {KINDS.get(socket.type, socket.type.lower())}, not "
            f"a shader) into its Surface, as a preview (Ctrl+Shift+click, Connect to Output) "
            f"leaves it")
    return (f"its Material Output {output.name!r} takes {what}, and "
            f"{', '.join(repr(n) for n in aside[:3])} {'is' if len(aside) == 1 else 'are'} "
            f"left unlinked: link the BSDF back to the Surface (Ctrl+Shift+click it)")


def preview_problem(materials):
    """None, or the bake's refusal for the first of `materials` whose rendered Material Output
    holds a preview (previewed)."""
    for mat in materials:
        tree = getattr(mat, "node_tree", None)
        output = cycles_output(tree) if tree is not None else None
        if output is None or renders_nothing(output):
            continue
        text = previewed(tree, output)
        if text:
            return (f"material {mat.name!r}: Cycles renders no BSDF, so the map would be the "
                    f"surface's own normal; {text}, then bake")
    return None
