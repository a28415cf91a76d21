"""Graphs of the methods built on noise and on sums of other methods: volume noise, bump on
SG Displace, the layered stack and post-resolve detail."""

from ...addon import groups as G
from ...reference.method_registry import (BUMP_ON_TOP, LAYER_COMBINE, LAYER_DETAIL,
                                          LAYER_NOISE, NOISE_AMOUNT, NOISE_OCTAVES,
                                          NOISE_SCALE, POST_RESOLVE_STRENGTH)
from ..graph import surface_gradient
from .images import normal_map_graph, procedural_basis_graph
from .projection import triplanar_graph


def volume_noise_graph(inp, g, amount=NOISE_AMOUNT, filtered=False):
    noise = g.group(G.noise_group(), Scale=NOISE_SCALE, Octaves=NOISE_OCTAVES, Turbulence=False,
                    Filter_Footprint=filtered)
    vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"], Bump_Scale=amount)
    return surface_gradient(vg)


def volume_noise_filtered_graph(inp, g):
    """volume-noise with SG Noise's Filter Footprint on."""
    return volume_noise_graph(inp, g, filtered=True)


def displace_bump_graph(inp, g):
    """Gustavson's fragment shader: finer SG Noise at the undisplaced object coordinates,
    through SG Volume Gradient and SG Resolve, on the analytically displaced surface."""
    scale, amount, octaves = BUMP_ON_TOP
    rest = g.group(G.rest_position_group())
    noise = g.group(G.noise_group(), Vector=rest.outputs[0], Scale=scale, Octaves=octaves)
    vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"], Bump_Scale=amount)
    return surface_gradient(vg)


def layered_graph(inp, g):
    """Figure 1: a normal map, detail on the second UV map (SG Combine), noise on top."""
    detail = procedural_basis_graph(inp, g)
    g.set(detail.node, Strength=LAYER_DETAIL)
    scale_a, scale_b, mask_b = LAYER_COMBINE
    combine = g.group(G.combine_group(), A=normal_map_graph(inp, g), B=detail,
                      Scale_A=scale_a, Scale_B=scale_b, Mask_B=mask_b)
    return g.add(combine.outputs[0], volume_noise_graph(inp, g, amount=LAYER_NOISE))


def post_resolve_graph(inp, g):
    """Figure 7(b): a baked normal map resolved first, then triplanar detail on top with the
    resolved normal as the new base normal (weights, projection and second resolve)."""
    first = g.resolve(normal_map_graph(inp, g))
    tri_sg = triplanar_graph(inp, g, image="detail")
    g.set(tri_sg.node, Normal=first, Strength=POST_RESOLVE_STRENGTH)
    final = g.group(G.resolve_group(), Normal=first, Surface_Gradient=tri_sg)
    return final.outputs["Normal"]
