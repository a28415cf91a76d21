"""Graphs of the Sampler groups (Blender 5.0+): the per-image methods with the image given as
a closure, for the same references."""

from ...addon import groups as G
from ...reference.method_registry import HEIGHT_BUMP_SCALE
from ..graph import Graph, surface_gradient
from .images import normal_map_at_parallax


def sampler_socket(nodes, links, image, interpolation="Linear", extension="REPEAT"):
    """A Closure Zone around an Image Texture of `image`: the Sampler a group evaluates."""
    from ...addon.sampler_zone import sampler_zone
    tex = Graph(nodes, links).node("ShaderNodeTexImage", interpolation=interpolation,
                                   extension=extension)
    tex.image = image
    zone, _, _ = sampler_zone(nodes, links, tex)
    return zone.outputs[0]


def _sized(image):
    """A Sampler group's Image Width and Image Height inputs for `image`."""
    return {"Image_Width": image.size[0], "Image_Height": image.size[1]}


def height_map_sampler_graph(inp, g):
    image = inp.bpy_image("height")
    node = g.group(G.height_map_sampler_group(inp.variant), **_sized(image),
                   Sampler=sampler_socket(g.nodes, g.links, image), UV=g.uv(inp.uv_map),
                   Bump_Scale=HEIGHT_BUMP_SCALE)
    return surface_gradient(node)


def triplanar_sampler_graph(inp, g):
    node = g.group(G.triplanar_sampler_group(),
                   Sampler=sampler_socket(g.nodes, g.links, inp.bpy_image("normal")))
    return surface_gradient(node)


def triplanar_height_sampler_graph(inp, g):
    image = inp.bpy_image("height")
    node = g.group(G.triplanar_height_sampler_group(), **_sized(image),
                   Sampler=sampler_socket(g.nodes, g.links, image),
                   Bump_Scale=HEIGHT_BUMP_SCALE)
    return surface_gradient(node)


def parallax_sampler_graph(inp, g):
    sampler = sampler_socket(g.nodes, g.links, inp.bpy_image("height"))
    par = g.group(G.parallax_sampler_group(), Sampler=sampler, UV=g.uv(inp.uv_map))
    return normal_map_at_parallax(inp, g, par)
