"""For a normal-map bake only: each BSDF a material renders stands in as a Diffuse BSDF fed the
same Normal.

Cycles' NORMAL bake averages the normals of the closures the shader makes, and every closure
but the diffuse ones changes its normal first: Principled BSDF, Glossy, Metallic, Glass,
Refraction, Translucent and Subsurface bend it (their bump correction, or a side flipped).
Baked as they were, the map of a Principled BSDF (every glTF, FBX or OBJ import) whose normal
map leans 60 degrees from the surface came out 8.3 degrees flatter, a Metallic or Glass BSDF's
15.3, on 4.2 and 5.2 alike, exit 0 (tests/test_faults_assets44.py). A Diffuse closure's normal
is the Normal input as given. Freeze does the same for its stack (freeze.py).

Only the material's own tree is changed (a BSDF inside a node group, which other materials
may share, is left as it is), and only nodes that render: a muted BSDF, and links that are
muted, stay as they are. Everything is put back on exit, also when the bake fails.
"""

from contextlib import contextmanager

NORMAL = "Normal"
DIFFUSE = "ShaderNodeBsdfDiffuse"
GROUP = "ShaderNodeGroup"


def _stands_in(node):
    """A BSDF node making a closure from a Normal input, other than a Diffuse BSDF. A node
    group is not one, whatever its sockets: its Normal input may be the base its own nodes
    bend (an SG stack inside), which a stand-in fed that input would drop."""
    return (node.bl_idname not in (DIFFUSE, GROUP) and not node.mute and
            NORMAL in node.inputs and any(o.type == "SHADER" for o in node.outputs))


@contextmanager
def diffuse_stand_ins(trees):
    """For the duration: in each tree, every BSDF's links out come from a Diffuse BSDF fed
    its Normal (the same link, or the shading normal where it has none)."""
    made = []           # (tree, diffuse, [(bsdf output, to_socket, muted)])
    try:
        for tree in dict.fromkeys(trees):
            for node in [n for n in tree.nodes if _stands_in(n)]:
                out = next(o for o in node.outputs if o.type == "SHADER")
                if not out.links:
                    continue
                diffuse = tree.nodes.new(DIFFUSE)
                diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
                relinked = []
                made.append((tree, diffuse, relinked))
                for link in node.inputs[NORMAL].links:
                    if not link.is_muted:
                        tree.links.new(link.from_socket, diffuse.inputs[NORMAL])
                for link in list(out.links):
                    to, muted = link.to_socket, link.is_muted
                    relinked.append((out, to, muted))
                    tree.links.new(diffuse.outputs[0], to).is_muted = muted
        yield
    finally:
        for tree, diffuse, relinked in reversed(made):
            for out, to, muted in relinked:
                tree.links.new(out, to).is_muted = muted
            tree.nodes.remove(diffuse)
