"""Decal projector shapes (Section 4.5, Listing 15): the weight each shape gives a point of the
projector's space q (its unit cube [-1, 1]^3; the decal is parallel-projected along -z and
sampled at (x, y)), and Listing 15's surface gradient scaled by it (a bump scale, the paper's
footnote 2). The shader side is SG Decal's Shape input (addon/groups/projection.py).

Falloffs: `falloff` is the distance, in the projector's half-size, over which a shape fades
from 1 to 0 at its boundary (0: a hard edge)."""

import numpy as np

from .listings import surfgrad_from_decal

# SG Decal's Shape input: 0 .. 5 (new shapes are appended, so saved files keep their meaning)
DECAL_SHAPES = ("box", "sphere", "cylinder", "cone", "wedge", "capsule")
# Floor of a falloff and of the cone's radius, so a hard edge (0) divides by it, not by zero.
SHAPE_FLOOR = 1e-6
# Half the capsule's axis segment: its round ends begin at mid-depth, where a surface that
# crosses the projector meets them (a segment to the cube's ends would make it the cylinder
# there).
CAPSULE_HALF_LENGTH = 0.5


def _ramp(distance, falloff):
    return np.clip(distance / max(falloff, SHAPE_FLOOR), 0.0, 1.0)


def decal_weight_box(q, falloff):
    """Inside |x|, |y| <= 1 (the image's square), faded toward the near and far faces."""
    inside = np.all(np.abs(q[:, :2]) <= 1.0, axis=-1)
    return inside * _ramp(1.0 - np.abs(q[:, 2]), falloff)


def decal_weight_sphere(q, falloff):
    """The unit ball, faded toward its surface."""
    return _ramp(1.0 - np.linalg.norm(q, axis=-1), falloff)


def decal_weight_cylinder(q, falloff):
    """The unit cylinder around the projection axis, faded toward its side and its ends."""
    rho = np.linalg.norm(q[:, :2], axis=-1)
    return _ramp(1.0 - rho, falloff) * _ramp(1.0 - np.abs(q[:, 2]), falloff)


def decal_weight_cone(q, falloff):
    """A cone with its apex at the projector (z = +1) and radius 1 at the far end (z = -1):
    radius (1 - z) / 2, faded toward its side and its ends."""
    rho = np.linalg.norm(q[:, :2], axis=-1)
    radius = np.maximum((1.0 - q[:, 2]) * 0.5, SHAPE_FLOOR)
    return _ramp(1.0 - rho / radius, falloff) * _ramp(1.0 - np.abs(q[:, 2]), falloff)


def decal_weight_wedge(q, falloff):
    """A triangular prism along the projection axis: its cross-section (the decal's footprint)
    the triangle with apex (0, 1) and base y = -1 from x = -1 to 1, so half-width (1 - y) / 2
    at height y (the cone's profile, in x against y). Faded toward its two sloped faces, in
    their half-width as the cone is in its radius, and toward its ends; a hard edge at the
    base, the image square's edge, as the box has."""
    half = np.maximum((1.0 - q[:, 1]) * 0.5, SHAPE_FLOOR)
    inside = q[:, 1] >= -1.0
    return (inside * _ramp(1.0 - np.abs(q[:, 0]) / half, falloff)
            * _ramp(1.0 - np.abs(q[:, 2]), falloff))


def decal_weight_capsule(q, falloff):
    """The unit-radius capsule around the projection axis: the points within 1 of the segment
    |z| <= CAPSULE_HALF_LENGTH on it (a cylinder of radius 1 whose hemispherical caps begin
    inside the cube and reach z = +-1.5), faded toward its surface by the distance to that
    segment."""
    along = np.maximum(np.abs(q[:, 2]) - CAPSULE_HALF_LENGTH, 0.0)
    distance = np.sqrt(q[:, 0] ** 2 + q[:, 1] ** 2 + along ** 2)
    return _ramp(1.0 - distance, falloff)


WEIGHTS = {"box": decal_weight_box, "sphere": decal_weight_sphere,
           "cylinder": decal_weight_cylinder, "cone": decal_weight_cone,
           "wedge": decal_weight_wedge, "capsule": decal_weight_capsule}


def _shaped(shape):
    def surfgrad_from_decal_shape(n, deriv, axis_x, axis_y, q, falloff):
        return WEIGHTS[shape](q, falloff)[:, None] * surfgrad_from_decal(n, deriv, axis_x,
                                                                        axis_y)
    surfgrad_from_decal_shape.__name__ = f"surfgrad_from_decal_{shape}"
    surfgrad_from_decal_shape.__doc__ = (f"Listing 15 (SurfgradFromDecal) inside a {shape} "
                                         f"projector: decal_weight_{shape} times its result.")
    return surfgrad_from_decal_shape


surfgrad_from_decal_box = _shaped("box")
surfgrad_from_decal_sphere = _shaped("sphere")
surfgrad_from_decal_cylinder = _shaped("cylinder")
surfgrad_from_decal_cone = _shaped("cone")
surfgrad_from_decal_wedge = _shaped("wedge")
surfgrad_from_decal_capsule = _shaped("capsule")
SURFGRAD_FROM_DECAL = {"box": surfgrad_from_decal_box, "sphere": surfgrad_from_decal_sphere,
                       "cylinder": surfgrad_from_decal_cylinder, "cone": surfgrad_from_decal_cone,
                       "wedge": surfgrad_from_decal_wedge, "capsule": surfgrad_from_decal_capsule}


def decal_layer(base_sg, decal_sg, weight, overwrite):
    """Add: base + decal (decal_sg already weighted); Overwrite: lerp(base, decal, weight),
    where decal_sg = weight * the decal's own gradient."""
    if not overwrite:
        return base_sg + decal_sg
    return base_sg * (1.0 - weight)[:, None] + decal_sg
