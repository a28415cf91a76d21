"""Section 4.1-4.2: triplanar projection (Listings 13 and 14, Eq. 19) and decal projectors
(Listing 15) as volume bump maps."""

from ..enum_input import menu_switch
from ..node_vocabulary import Math, VMath
from ...reference import socket_specs as S
from ...reference.decals import CAPSULE_HALF_LENGTH, DECAL_SHAPES, SHAPE_FLOOR  # noqa: F401
from ...reference.vecmath import DIVIDE_FLOOR
from . import common
from .common import (SamplerTaps, by_strength, decode_tangent_normal, directx_input, ensure,
                     normal_input, object_position, require, scaled_position_inputs)


def triplanar_blend_inputs(b):
    """Sharpness and Strength, the triplanar normal-map groups' last two inputs."""
    return b.input(S.SHARPNESS), b.input(S.STRENGTH)


def triplanar_weights(b, n, k):
    """Listing 14: w = max(|n| - 0.2, 0)^k, normalised; returns the three weight sockets."""
    with b.frame("Listing 14: w = max(|n| - 0.2, 0)^k, normalised"):
        base = b.separate(b.vmath(VMath.MAXIMUM, b.vmath(VMath.SUBTRACT, b.vmath(VMath.ABSOLUTE, n),
                                                      (0.2, 0.2, 0.2)), (0.0, 0.0, 0.0)))
        wx, wy, wz = (b.math(Math.POWER, c, k) for c in base)
        total = b.math(Math.MAXIMUM, b.math(Math.ADD, b.math(Math.ADD, wx, wy), wz), DIVIDE_FLOOR)
        return tuple(b.math(Math.DIVIDE, c, total) for c in (wx, wy, wz))


def triplanar_surface_gradient(b, n, weighted, negated=False):
    """Listing 13: the volume gradient of Eq. 19 from the planes' derivatives (sampled at
    (z, y), (x, z), (x, y)), each already times its plane's weight, projected by Listing 8.
    `negated`: the derivatives came negated (decode_tangent_normal with a weight); Listing 8 is
    linear, so swapping its subtraction's operands gives the gradient, exactly."""
    (dxx, dxy), (dyx, dyy), (dzx, dzy) = weighted
    with b.frame("Listing 13: volume gradient of Eq. 19, then Listing 8"):
        grad = b.combine(b.math(Math.ADD, dzx, dyx), b.math(Math.ADD, dzy, dxy),
                         b.math(Math.ADD, dxx, dyy))
        along_n = b.scale(n, b.dot(n, grad))
        return b.sub(along_n, grad) if negated else b.sub(grad, along_n)


def weighted_derivatives(b, weights, derivs):
    """Each plane's derivative (du, dv) times its Listing 14 weight."""
    return [(b.math(Math.MULTIPLY, w, du), b.math(Math.MULTIPLY, w, dv))
            for w, (du, dv) in zip(weights, derivs)]


def triplanar_coordinates_group():
    def build(b):
        p, _ = scaled_position_inputs(b)
        with b.frame("Eq. 19 planes: X samples (z, y), Y (x, z), Z (x, y)"):
            for axis, uv in zip("XYZ", plane_coordinates(b, p)):
                b.output(f"UV {axis}", uv)
    return ensure("SG Triplanar Coordinates", build)


def plane_coordinates(b, p):
    """Eq. 19's planes: X samples (z, y), Y (x, z), Z (x, y)."""
    x, y, z = b.separate(p)
    return b.combine(z, y), b.combine(x, z), b.combine(x, y)


def triplanar_outputs(b, n, weights, negated_derivs, strength):
    """Listing 13 on the planes' weighted, negated derivatives (decode_tangent_normal with each
    plane's weight), scaled by strength, and the blend weights."""
    sg = triplanar_surface_gradient(b, n, negated_derivs, negated=True)
    b.output(S.SURFACE_GRADIENT_OUT, by_strength(b, sg, strength))
    b.output(S.WEIGHTS_OUT, b.combine(*weights))


def plane_derivatives(b, colors, directx, weights):
    """Listing 2 per plane, each times -(its weight): one division per plane for both."""
    return [decode_tangent_normal(b, c, directx, w) for c, w in zip(colors, weights)]


def triplanar_group():
    def build(b):
        n = normal_input(b)
        colors = [b.input(f"Color {a}") for a in "XYZ"]
        directx = directx_input(b)
        k, strength = triplanar_blend_inputs(b)
        weights = triplanar_weights(b, n, k)
        with b.frame("Listing 2 per plane, times its weight"):
            derivs = plane_derivatives(b, colors, directx, weights)
        triplanar_outputs(b, n, weights, derivs, strength)
    return ensure("SG Triplanar", build)


def triplanar_sampler_group():
    """SG Triplanar (Sampler), Blender 5.0+: SG Triplanar Coordinates and SG Triplanar in one,
    the tangent-space normal map given as a Sampler closure evaluated on the three planes."""
    name = "SG Triplanar (Sampler)"
    require(name)

    def build(b):
        n = normal_input(b)
        p, _ = scaled_position_inputs(b)
        taps = SamplerTaps(b)
        directx = directx_input(b)
        k, strength = triplanar_blend_inputs(b)
        weights = triplanar_weights(b, n, k)
        with b.frame("Eq. 19 planes: X samples (z, y), Y (x, z), Z (x, y); Listing 2 each"):
            colors = [taps.color(uv) for uv in plane_coordinates(b, p)]
            derivs = plane_derivatives(b, colors, directx, weights)
        triplanar_outputs(b, n, weights, derivs, strength)
    return ensure(name, build)


def projector_coordinates_group():
    def build(b):
        near_q = b.input(S.DECAL_COORDINATES)
        location = b.input("Projector Location")
        rows = [b.input(f"To Projector {a}") for a in "XYZ"]

        def precise():
            with b.frame("Offset from the projector in world axes, from precise parts: "
                         "(object origin - projector) + object-space position turned to world"):
                origin = b.node("ShaderNodeObjectInfo").outputs["Location"]
                turn = b.node("ShaderNodeVectorTransform", vector_type="VECTOR",
                              convert_from="OBJECT", convert_to="WORLD")
                b.link(object_position(b), turn.inputs[0])
                offset = b.add(b.sub(origin, location), turn.outputs[0])
            with b.frame("To the projector's space: one row per axis"):
                parts = b.combine(*(b.dot(row, offset) for row in rows))
            with b.frame(f"Near the origin (< {common.FAR_METRES:g} m) the linked Texture "
                         "Coordinate, as it always was; far out or unlinked, the precise route"):
                ox, oy, oz = b.separate(b.vmath(VMath.ABSOLUTE, origin))
                reach = b.math(Math.MAXIMUM, b.math(Math.MAXIMUM, ox, oy), oz)
                use = b.math(Math.MAXIMUM, b.math(Math.GREATER_THAN, reach, common.FAR_METRES),
                             b.is_zero(near_q))
                return common.select(b, use, near_q, parts)
        with b.frame("Precise Far From Origin off: the linked Texture Coordinate as given"):
            q = common.precise_far_route(b, near_q, precise)
        b.output(S.DECAL_COORDINATES, q)
    return ensure("SG Projector Coordinates", build)


def decal_coordinates_group():
    def build(b):
        q = b.input(S.DECAL_COORDINATES)
        with b.frame("[-1, 1]^2 of the projector to [0, 1]^2"):
            uv = b.vmath(VMath.ADD, b.vmath(VMath.MULTIPLY, q, (0.5, 0.5, 0.0)), (0.5, 0.5, 0.0))
        b.output("Decal UV", uv)
    return ensure("SG Decal Coordinates", build)


def _ramp(b, distance, falloff):
    """clamp(distance / falloff, 0, 1): 1 inside, 0 at the shape's boundary."""
    fade = b.math(Math.DIVIDE, distance, b.math(Math.MAXIMUM, falloff, SHAPE_FLOOR))
    return b.math(Math.MINIMUM, b.math(Math.MAXIMUM, fade, 0.0), 1.0)


def decal_weight(b, q, shape, falloff, shapes=range(len(DECAL_SHAPES))):
    """Each shape's weight in [0, 1] (reference/decals.py has the same six), selected by
    `shape`; every one is a bump scale (the paper's footnote 2), so the result stays a
    surface gradient. A constant `shape` leaves only its own nodes after Cycles' folding (the
    same as building only that one: `shapes`, tests/test_render_cost_folding.py)."""
    qx, qy, qz = b.separate(q)
    depth = _ramp(b, b.math(Math.SUBTRACT, 1.0, b.math(Math.ABSOLUTE, qz)), falloff)
    rho = b.length(b.combine(qx, qy))

    def box():
        with b.frame("Box: inside |x|, |y| <= 1, faded along depth"):
            inside = b.math(Math.MULTIPLY, *(b.math(Math.LESS_THAN, b.math(Math.ABSOLUTE, c),
                                                    1.000001) for c in (qx, qy)))
            return b.math(Math.MULTIPLY, inside, depth)

    def sphere():
        with b.frame("Sphere: faded toward |q| = 1"):
            return _ramp(b, b.math(Math.SUBTRACT, 1.0, b.length(q)), falloff)

    def cylinder():
        with b.frame("Cylinder: faded toward rho = 1 and the ends"):
            return b.math(Math.MULTIPLY, _ramp(b, b.math(Math.SUBTRACT, 1.0, rho), falloff),
                          depth)

    def cone():
        with b.frame("Cone: radius (1 - z) / 2, faded toward its side and the ends"):
            radius = b.math(Math.MAXIMUM, b.math(Math.MULTIPLY, b.math(Math.SUBTRACT, 1.0, qz),
                                                 0.5), SHAPE_FLOOR)
            return b.math(Math.MULTIPLY, _ramp(b, b.math(Math.SUBTRACT, 1.0, b.math(
                Math.DIVIDE, rho, radius)), falloff), depth)

    def wedge():
        with b.frame("Wedge: half-width (1 - y) / 2, faded toward its slopes and the ends"):
            inside = b.math(Math.GREATER_THAN, qy, -1.000001)
            half = b.math(Math.MAXIMUM, b.math(Math.MULTIPLY, b.math(Math.SUBTRACT, 1.0, qy),
                                               0.5), SHAPE_FLOOR)
            across = _ramp(b, b.math(Math.SUBTRACT, 1.0, b.math(
                Math.DIVIDE, b.math(Math.ABSOLUTE, qx), half)), falloff)
            return b.math(Math.MULTIPLY, b.math(Math.MULTIPLY, inside, across), depth)

    def capsule():
        with b.frame("Capsule: faded toward distance 1 from the axis segment |z| <= 0.5"):
            along = b.math(Math.MAXIMUM, b.math(Math.SUBTRACT, b.math(Math.ABSOLUTE, qz),
                                                CAPSULE_HALF_LENGTH), 0.0)
            return _ramp(b, b.math(Math.SUBTRACT, 1.0, b.length(b.combine(qx, qy, along))),
                         falloff)
    weights = (box, sphere, cylinder, cone, wedge, capsule)      # in DECAL_SHAPES' order
    with b.frame("The chosen shape"):
        if shape.type == "MENU":
            built = {index: weights[index]() for index in shapes}
            fill = built[next(iter(built))]        # items not built (tests) get a built one
            return menu_switch(b, shape, [built.get(k, fill) for k in range(len(weights))],
                               "FLOAT")
        total = 0.0
        for index in shapes:
            pick = b.math(Math.COMPARE, shape, float(index), 0.5)
            total = b.math(Math.ADD, total, b.math(Math.MULTIPLY, pick, weights[index]()))
        return total


def decal_group():
    def build(b):
        n = normal_input(b)
        q, color = b.input(S.DECAL_COORDINATES), b.input(S.NORMAL_COLOR)
        directx = directx_input(b)
        axis_x, axis_y = b.input("Axis X"), b.input("Axis Y")
        strength, falloff, shape = b.input(S.STRENGTH), b.input("Falloff"), b.input("Shape")
        base, overwrite, opacity = (b.input(name) for name in ("Base Gradient", "Overwrite",
                                                               "Opacity"))
        with b.frame("Falloff as a bump scale: the shape's weight"):
            weight = b.math(Math.MULTIPLY, decal_weight(b, q, shape, falloff), opacity)
        with b.frame("Listing 2"):
            dx, dy = decode_tangent_normal(b, color, directx)
        with b.frame("Listing 15: grad = deriv.x X + deriv.y Y, then Listing 8"):
            grad = b.add(b.scale(axis_x, dx), b.scale(axis_y, dy))
            sg = by_strength(b, b.sub(grad, b.scale(n, b.dot(n, grad))), strength)
        with b.frame("Add: base + a sg; Overwrite: base + a (sg - base) = lerp(base, sg, a)"):
            out = b.add(base, b.scale(b.sub(sg, b.scale(base, overwrite)), weight))
        b.output(S.SURFACE_GRADIENT_OUT, out)
    return ensure("SG Decal", build)
