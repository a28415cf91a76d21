"""The freeze tests' material: a layered surface-gradient stack (SG Normal Map of a tiled
hemisphere map + SG Noise through SG Volume Gradient, added by SG Combine, resolved by SG
Resolve) into a Diffuse BSDF's Normal (Cycles' NORMAL bake averages closure normals; a Diffuse
one keeps glossy closures' bump correction out)."""

from surfgrad_addon.addon import groups as G
from surfgrad_addon.harness import compare
from surfgrad_addon.harness.graph import Graph
from surfgrad_addon.reference import images as T
from support.materials import diffuse_material


def layered_material(obj, name="Layered"):
    """The material on obj (its only slot, active); returns (material, Diffuse BSDF)."""
    mat, tree, bsdf = diffuse_material(name)
    g = Graph(tree.nodes, tree.links)
    source = compare.bpy_float_image(f"{name}_source", T.hemisphere_tile_image(64, tiles=4))
    nm = g.group(G.normal_map_group("UVMap"), Color=g.image(source, g.uv("UVMap")))
    noise = g.group(G.noise_group())
    noise.inputs["Scale"].default_value = 3.0
    volume = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"])
    volume.inputs["Bump Scale"].default_value = 0.15
    combine = g.group(G.combine_group(), A=nm.outputs[0], B=volume.outputs[0])
    g.link(g.resolve(combine.outputs[0]), bsdf.inputs["Normal"])
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    obj.active_material_index = 0
    return mat, bsdf
