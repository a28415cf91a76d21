"""Graphs of the methods that read an image through a UV map: SG Normal Map, the procedural
basis, object-space normals, the height maps, the Table 1 blends and parallax. Each is
graph(inp, g) -> a surface-gradient socket, on a harness Graph (the material's nodes)."""

from ...addon import groups as G
from ...addon.node_vocabulary import VMath
from ...reference.method_registry import (BLEND_MODES, HEIGHT_BUMP_SCALE, VIEW_TILT,
                                          parallax_depth)
from ..graph import surface_gradient


def normal_map_graph(inp, g, image="normal"):
    color = g.image(inp.bpy_image(image), g.uv(inp.uv_map))
    return surface_gradient(g.group(G.normal_map_group(inp.uv_map), Color=color))


def procedural_basis_graph(inp, g, image="detail"):
    uv = g.uv(inp.detail_uv)
    basis = g.group(G.procedural_basis_group(), UV=uv)
    tn = g.group(G.tangent_normal_group(), Color=g.image(inp.bpy_image(image), uv),
                 Tangent=basis.outputs["Tangent"], Bitangent=basis.outputs["Bitangent"])
    return surface_gradient(tn)


def object_normal_vector(inp, g):
    """v = (2 c - 1) + 2 N: an arbitrary front-facing world-space normal from an image."""
    color = g.image(inp.bpy_image("normal"), g.uv(inp.uv_map))
    return g.vmath(VMath.ADD, g.decode(color), g.scale(g.geometry("Normal"), 2.0))


def object_normal_graph(inp, g):
    node = g.group(G.object_normal_group(), Perturbed_Normal=object_normal_vector(inp, g))
    return surface_gradient(node)


def height_map_graph(inp, g):
    uv = g.uv(inp.uv_map)
    if inp.variant == "forward":
        height = g.first(g.image(inp.bpy_image("height"), uv))
        node = g.group(G.height_map_forward_group(), Height=height)
    else:
        node = g.group(G.height_map_group(inp.bpy_image("height"), inp.variant), UV=uv)
    g.set(node, Bump_Scale=HEIGHT_BUMP_SCALE)
    return surface_gradient(node)


def blend_graph(mode):
    def graph(inp, g):
        uv = g.uv(inp.uv_map)
        blend = g.group(G.blend_normals_group(), Color_A=g.image(inp.bpy_image("normal"), uv),
                        Color_B=g.image(inp.bpy_image("detail"), uv), Method=BLEND_MODES[mode])
        nm = g.group(G.normal_map_group(inp.uv_map), Color=blend.outputs["Color"])
        return surface_gradient(nm)
    return graph


def parallax_view(g):
    """normalize(N + VIEW_TILT): the comparison's oblique view."""
    return g.vmath(VMath.NORMALIZE, g.vmath(VMath.ADD, g.geometry("Normal"), VIEW_TILT))


def normal_map_at_parallax(inp, g, par):
    """A parallax group's view and scale set, and SG Normal Map read at its offset UV."""
    g.set(par, View=parallax_view(g), Depth=parallax_depth(inp))
    color = g.image(inp.bpy_image("normal"), par.outputs["UV"])
    return surface_gradient(g.group(G.normal_map_group(inp.uv_map), Color=color))


def parallax_graph(inp, g):
    par = g.group(G.parallax_group(inp.bpy_image("height")), UV=g.uv(inp.uv_map))
    return normal_map_at_parallax(inp, g, par)
