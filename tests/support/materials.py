"""Test materials: a Diffuse BSDF into the Material Output, the skeleton the bake tests hang
their normal inputs on (Cycles' NORMAL bake averages closure normals; a Diffuse one keeps
glossy closures' bump correction out, shared/notes)."""

import bpy

from surfgrad_addon.addon.compat import new_material


def diffuse_material(name):
    """(material, its node tree, the Diffuse BSDF) with nothing else in the tree."""
    mat = new_material(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat, tree, bsdf
