"""Graphs of the projected methods: triplanar (normal and height images on three planes) and
the decals (a projector's box, sphere, cylinder, cone, wedge or capsule)."""

import numpy as np

from ...addon import groups as G
from ...reference import methods as M
from ...reference.decals import DECAL_SHAPES
from ...reference.method_registry import DECAL_FALLOFF, HEIGHT_BUMP_SCALE, decal_shape
from ..graph import surface_gradient
from .images import procedural_basis_graph


def triplanar_graph(inp, g, image="normal"):
    coords = g.group(G.triplanar_coordinates_group())
    tri = g.group(G.triplanar_group(), **{
        f"Color {axis}": g.image(inp.bpy_image(image), coords.outputs[f"UV {axis}"])
        for axis in "XYZ"})
    return surface_gradient(tri)


def triplanar_height_graph(inp, g):
    node = g.group(G.triplanar_height_group(inp.bpy_image("height")),
                   Bump_Scale=HEIGHT_BUMP_SCALE)
    return surface_gradient(node)


def projector_coordinates(g, projector):
    """SG Projector Coordinates fed by a Texture Coordinate node of the projector and set to
    its matrix (as the operator's drivers do): its Decal Coordinates output."""
    tc = g.node("ShaderNodeTexCoord", object=projector)
    m = np.array(projector.matrix_world, dtype=np.float64)
    rows = np.linalg.inv(m[:3, :3])
    node = g.group(G.projector_coordinates_group(), Decal_Coordinates=tc.outputs["Object"],
                   Projector_Location=m[:3, 3],
                   **{f"To Projector {axis}": row for axis, row in zip("XYZ", rows)})
    return node.outputs["Decal Coordinates"]


def decal_graph(inp, g, shape=None, base=None, overwrite=False):
    """SG Decal with its chain; `shape` (default: the method's variant, box for plain
    "decal"), `base` a surface-gradient socket underneath, overwrite mode."""
    shape = shape or decal_shape(inp)
    q = projector_coordinates(g, inp.projector)
    coords = g.group(G.decal_coordinates_group(), Decal_Coordinates=q)
    ax, ay, _, _ = M.decal_frame(np.array(inp.projector.matrix_world))
    decal = g.group(G.decal_group(), Decal_Coordinates=q,
                    Color=g.image(inp.bpy_image("normal"), coords.outputs["Decal UV"]),
                    Axis_X=ax, Axis_Y=ay, Falloff=DECAL_FALLOFF,
                    Shape=DECAL_SHAPES.index(shape), Overwrite=overwrite)
    if base is not None:
        g.set(decal, Base_Gradient=base)
    return surface_gradient(decal)


def decal_overwrite_graph(inp, g):
    """A cylinder decal replacing (by its opacity, a parameter) the detail map underneath."""
    return decal_graph(inp, g, shape="cylinder", base=procedural_basis_graph(inp, g),
                       overwrite=True)
