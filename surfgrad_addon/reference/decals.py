"""Decal projector shapes (Section 4.5, Listing 15): the weight each shape gives a point of the
projector's space q (its unit cube [-1, 1]^3; the decal is parallel-projected along -z and
sampled at (x, y)), and Listing 15's surface gradient scaled by it (a bump scale, the paper's
footnote 2). The shader side is SG Decal's Shape input (addon/groups/projection.py).

Falloffs: `falloff` is the distance, in the projector's half-size, over which a shape fades
from 1 to 0 at its boundary (0: a hard edge)."""

import numpy as np

from .listings import surfgrad_from_decal

DECAL_SHAPES = ("box", "sphere", "cylinder", "cone")     # SG Decal's Shape input: 0 .. 3
# Floor of a falloff and of the cone's radius, so a hard edge (0) divides by it, not by zero.
SHAPE_FLOOR = 1e-6


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


WEIGHTS = {"box": decal_weight_box, "sphere": decal_weight_sphere,
           "cylinder": decal_weight_cylinder, "cone": decal_weight_cone}


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
SURFGRAD_FROM_DECAL = {"box": surfgrad_from_decal_box, "sphere": surfgrad_from_decal_sphere,
                       "cylinder": surfgrad_from_decal_cylinder, "cone": surfgrad_from_decal_cone}


def decal_layer(base_sg, decal_sg, weight, overwrite):
    """Add: base + decal (decal_sg already weighted); Overwrite: lerp(base, decal, weight),
    where decal_sg = weight * the decal's own gradient."""
    if not overwrite:
        return base_sg + decal_sg
    return base_sg * (1.0 - weight)[:, None] + decal_sg
