"""Test materials: a Diffuse BSDF into the Material Output, the skeleton the bake tests hang
their normal inputs on (Cycles' NORMAL bake averages closure normals; a Diffuse one keeps
glossy closures' bump correction out, shared/notes); and an image through a Normal Map node into
a Principled BSDF, as Blender's glTF importer builds a normalTexture."""

import bpy
import numpy as np

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


def normal_map_material(name, image, uv_map="UVMap"):
    """(material, its node tree) reading `image` through a tangent-space Normal Map node on
    `uv_map` into a Principled BSDF's Normal."""
    mat = new_material(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    nm = tree.nodes.new("ShaderNodeNormalMap")
    nm.uv_map = uv_map
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tree.links.new(tex.outputs["Color"], nm.inputs["Color"])
    tree.links.new(nm.outputs["Normal"], bsdf.inputs["Normal"])
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat, tree


def packed_normal_image(name, rgb):
    """A packed, Non-Color float image holding `rgb` ((n, n, 3), row 0 at v = 0)."""
    n = rgb.shape[0]
    rgba = np.ones((n, n, 4), np.float32)
    rgba[..., :3] = rgb
    img = bpy.data.images.new(name, n, n, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(rgba.ravel())
    img.pack()
    return img


def plane_with_output(name):
    """A fresh scene's 2 m plane and its material `name`, holding only the Material Output:
    (object, node tree)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2)
    obj = bpy.context.active_object
    mat = new_material(name)
    obj.data.materials.append(mat)
    tree = mat.node_tree
    for node in [n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        tree.nodes.remove(node)
    return obj, tree
