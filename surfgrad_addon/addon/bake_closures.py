"""For a normal-map bake only: each BSDF a material renders stands in as a Diffuse BSDF fed the
same Normal, white.

Cycles' NORMAL bake averages the normals of the closures the shader makes, and every closure
but the diffuse ones changes its normal first: Principled BSDF, Glossy, Metallic, Glass,
Refraction, Translucent and Subsurface bend it (their bump correction, or a side flipped).
Baked as they were, the map of a Principled BSDF (every glTF, FBX or OBJ import) whose normal
map leans 60 degrees from the surface came out 8.3 degrees flatter, a Metallic or Glass BSDF's
15.3, on 4.2 and 5.2 alike, exit 0 (tests/test_faults_assets44.py). A Diffuse closure's normal
is the Normal input as given, but Cycles drops a closure of no weight: a Diffuse BSDF of black
Color (or black texels of its Color) baked the surface's own normal, so it stands in too,
white (tests/test_faults_bake_closures45.py). A hair BSDF (on hair cards) stands in fed the
surface's normal, which it is given: its own closure's normal is neither (mixed at 0.5 with a
BSDF fed a map leaning 60 degrees, a Principled Hair BSDF baked 45 degrees from the map).
Freeze does the same for its stack (freeze.py).

A node group holding a BSDF (at any depth) is baked through a copy of it, stood in the same
way, that its group node uses for the bake: other materials sharing the group are untouched
(before, a Principled BSDF inside a group baked 8.3 degrees flat, a Glass one 15.3). Only
nodes that render: a muted BSDF or group, and links that are muted, stay as they are.

A closure with no normal of its own (Transparent BSDF, Holdout, Ray Portal BSDF) is unlinked
for the bake: added to a BSDF (an Add Shader), a Transparent BSDF or a Holdout made Cycles bake
a zero vector (grey 0.5, not a unit normal) in every texel, with exit 0, where the BSDF renders
its map; so did a Ray Portal on 5.2, and mixed with the BSDF at 0.5 (on 4.2 added too) it
pulled the map halfway to the surface's normal, 30 degrees off
(tests/test_faults_bake_closures47.py). Unlinked, it makes no closure: the other closures'
normals are baked, or the surface's where there are none.
Everything is put back on exit, also when the bake fails.

A Principled BSDF's map is its Normal: a coat (Coat Weight above 0) fed another Coat Normal
renders with that one (unlinked, the surface's), which a single map cannot hold; Cycles' own
bake had averaged the two (27.9 degrees off a map leaning 60 degrees, Coat Normal unlinked).
The bake warns of it (stand_in_warnings; before round 47 it said nothing).

EEVEE's Specular BSDF makes no closure in Cycles (a Cycles bake of it alone gave the surface's
normal, the map fed it lost): it stands in like any BSDF, its Normal baked as EEVEE renders it,
and the bake warns that Cycles renders the material without it (round 48).
"""

from contextlib import contextmanager

NORMAL = "Normal"
DIFFUSE = "ShaderNodeBsdfDiffuse"
GROUP = "ShaderNodeGroup"
HAIR = ("ShaderNodeBsdfHair", "ShaderNodeBsdfHairPrincipled")
WHITE = (1.0, 1.0, 1.0, 1.0)
PRINCIPLED = "ShaderNodeBsdfPrincipled"
EEVEE_SPECULAR = "ShaderNodeEeveeSpecular"     # Cycles renders no closure for it
NO_NORMAL = ("ShaderNodeBsdfTransparent", "ShaderNodeHoldout", "ShaderNodeBsdfRayPortal")


def _stands_in(node):
    """A BSDF node making a closure from a Normal input, or a hair BSDF (no Normal input: on a
    mesh its closure's normal is neither the surface's nor any given one). A group node is not
    one, whatever its sockets: its Normal input may be the base its own nodes bend (an SG
    stack inside), which a stand-in fed that input would drop; its BSDFs stand in inside a
    copy."""
    return (node.bl_idname != GROUP and not node.mute and not _carries(node) and
            ((NORMAL in node.inputs and node.inputs[NORMAL].type == "VECTOR") or
             node.bl_idname in HAIR) and
            any(o.type == "SHADER" for o in node.outputs))


# An Evaluate Closure (5.0+) whose closure takes an argument named Normal looks like a BSDF
# (a Normal input, a Shader output), but its shader is the zone's: stood in, it dropped the
# zone's own normals (a Normal Map inside: the map 60 degrees off what Cycles renders, exit 0;
# rt55a). Like a group's, the BSDFs inside stand in themselves.
CARRIERS = ("CLOSURE", "BUNDLE")


def _carries(node):
    """`node` takes a closure or a bundle: what it outputs is what that carries."""
    return any(s.type in CARRIERS for s in node.inputs)


def _unlinked(node):
    """A closure with no normal of its own, unlinked for the bake."""
    return node.bl_idname in NO_NORMAL and not node.mute


def baked_inputs(node):
    """The inputs of shader node `node` (a shader output of it reached from the Material
    Output) whose values the normal bake reads once the stand-ins are in: a stand-in's Normal
    alone (its colour is white), none of a hair BSDF's or of a closure unlinked for the bake,
    a Mix Shader's Fac (it weighs the closures' normals: Cycles averages them so) and every
    shader input. Other closures (Emission, volumes) add no normal. A script node's outputs
    are unknown here: all its inputs."""
    if node.bl_idname == "ShaderNodeScript":
        return list(node.inputs)
    if _stands_in(node):
        return [node.inputs[NORMAL]] if NORMAL in node.inputs else []
    if _unlinked(node):
        return []
    return [s for s in node.inputs
            if s.type == "SHADER" or (node.bl_idname == "ShaderNodeMixShader" and
                                      s.identifier == "Fac")]


def holds_stand_ins(tree):
    """The tree, or a group it uses, has a node that stands in or is unlinked for the bake."""
    return any(_stands_in(n) or _unlinked(n) or _group_with_bsdf(n) for n in tree.nodes)


def _group_with_bsdf(node):
    return (node.bl_idname == GROUP and not node.mute and node.node_tree is not None and
            holds_stand_ins(node.node_tree))


def _stand_in(tree, made, swapped):
    for node in [n for n in tree.nodes if _group_with_bsdf(n)]:
        copy = node.node_tree.copy()
        swapped.append((node, node.node_tree, copy))
        node.node_tree = copy
        _stand_in(copy, made, swapped)
    for node in [n for n in tree.nodes if _unlinked(n)]:
        out = next(o for o in node.outputs if o.type == "SHADER")
        relinked = [(out, link.to_socket, link.is_muted) for link in out.links]
        made.append((tree, None, relinked))
        for link in list(out.links):
            tree.links.remove(link)
    for node in [n for n in tree.nodes if _stands_in(n)]:
        out = next(o for o in node.outputs if o.type == "SHADER")
        if not out.links:
            continue
        diffuse = tree.nodes.new(DIFFUSE)
        diffuse.inputs["Color"].default_value = WHITE
        relinked = []
        made.append((tree, diffuse, relinked))
        for link in node.inputs[NORMAL].links if NORMAL in node.inputs else ():
            if not link.is_muted:
                tree.links.new(link.from_socket, diffuse.inputs[NORMAL])
        for link in list(out.links):
            to, muted = link.to_socket, link.is_muted
            relinked.append((out, to, muted))
            tree.links.new(diffuse.outputs[0], to).is_muted = muted


def _source(socket):
    """The socket linked into `socket` (not through a muted link), else None."""
    return next((link.from_socket for link in socket.links if not link.is_muted), None)


def _baked(tree, seen):
    """The nodes of tree, and of the groups it uses, that stand in with links out."""
    for node in tree.nodes:
        if _group_with_bsdf(node) and node.node_tree not in seen:
            seen.add(node.node_tree)
            yield from _baked(node.node_tree, seen)
        elif _stands_in(node) and any(o.links for o in node.outputs):
            yield node


def _other_coat(node):
    """A Principled BSDF rendering a coat whose Coat Normal is not its Normal."""
    if node.bl_idname != PRINCIPLED:
        return False
    weight = node.inputs["Coat Weight"]
    return (weight.links or weight.default_value > 0) and \
        _source(node.inputs["Coat Normal"]) != _source(node.inputs[NORMAL])


COAT = ("has a coat (Coat Weight) fed another Coat Normal than its Normal (unlinked: the "
        "surface's); the map holds its Normal, not the coat's")
EEVEE_ONLY = ("is EEVEE's alone: Cycles renders no closure for it, so the map holds its Normal "
              "as EEVEE renders it, which Cycles does not; use a Glossy or Principled BSDF "
              "where the map is for Cycles")


def _warned(mat, node, what):
    where = "" if node.id_data == mat.node_tree else f" in group {node.id_data.name!r}"
    return f"material {mat.name!r}: {node.bl_label} {node.name!r}{where} {what}"


def stand_in_warnings(materials):
    """A warning per BSDF of `materials` whose map is not the normal Cycles renders it with:
    a Principled BSDF's coat fed another normal, an EEVEE-only Specular BSDF."""
    return [_warned(mat, node, COAT if _other_coat(node) else EEVEE_ONLY)
            for mat in materials if mat.node_tree is not None
            for node in _baked(mat.node_tree, set())
            if _other_coat(node) or node.bl_idname == EEVEE_SPECULAR]


@contextmanager
def diffuse_stand_ins(trees):
    """For the duration: in each tree (and in copies of the groups it uses), every BSDF's links
    out come from a white Diffuse BSDF fed its Normal (the same link, or the shading normal
    where it has none), and every closure with no normal of its own has no links out."""
    made = []           # (tree, diffuse or None, [(closure output, to_socket, muted)])
    swapped = []        # (group node, its group, the copy it uses for the bake)
    try:
        for tree in dict.fromkeys(trees):
            _stand_in(tree, made, swapped)
        yield
    finally:
        for tree, diffuse, relinked in reversed(made):
            for out, to, muted in relinked:
                tree.links.new(out, to).is_muted = muted
            if diffuse is not None:
                tree.nodes.remove(diffuse)
        if swapped:
            import bpy
            for node, group, copy in reversed(swapped):
                node.node_tree = group
                bpy.data.node_groups.remove(copy)
