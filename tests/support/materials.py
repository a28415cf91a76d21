"""Test materials: a Diffuse BSDF into the Material Output, the skeleton the bake tests hang
their normal inputs on (Cycles' NORMAL bake averages closure normals; a Diffuse one keeps
glossy closures' bump correction out, shared/notes)."""

import bpy

from surfgrad_addon.addon.compat import new_material
from surfgrad_addon.harness.graph import Graph


def diffuse_material(name):
    """(material, its node tree, the Diffuse BSDF) with nothing else in the tree."""
    mat = new_material(name)
    g = Graph(mat.node_tree.nodes, mat.node_tree.links)
    g.nodes.clear()
    out = g.node("ShaderNodeOutputMaterial")
    bsdf = g.node("ShaderNodeBsdfDiffuse")
    g.link(bsdf.outputs[0], out.inputs["Surface"])
    return mat, mat.node_tree, bsdf
