"""The graph of height-blend: rock (SG Height Map HQ) and sand (SG Noise through SG Volume
Gradient), each with the height its bump comes from, through SG Height Blend."""

from ...addon import groups as G
from ...reference.method_registry import (HEIGHT_BUMP_SCALE, NOISE_AMOUNT, NOISE_OCTAVES,
                                          NOISE_SCALE, SAND_LEVEL, relief)
from ..graph import surface_gradient


def height_blend_graph(inp, g):
    uv = g.uv(inp.uv_map)
    image, r = inp.bpy_image("height"), relief(inp)
    rock = g.group(G.height_map_group(image, "hq"), UV=uv, Bump_Scale=HEIGHT_BUMP_SCALE * r)
    noise = g.group(G.noise_group(), Scale=NOISE_SCALE, Octaves=NOISE_OCTAVES,
                    Turbulence=False)
    sand = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                   Bump_Scale=NOISE_AMOUNT * r)
    blend = g.group(G.height_blend_group(), A=surface_gradient(rock),
                    Height_A=g.first(g.image(image, uv)), B=surface_gradient(sand),
                    Height_B=noise.outputs["Value"], Offset_B=SAND_LEVEL)
    return surface_gradient(blend)
