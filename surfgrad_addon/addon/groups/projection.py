"""Section 4.1-4.2: triplanar projection (Listings 13 and 14, Eq. 19) and decal projectors
(Listing 15) as volume bump maps."""

from ..node_builder import ensure_group
from ...reference.vecmath import DIVIDE_FLOOR
from . import common
from .common import (SamplerTaps, decode_tangent_normal, directx_input, normal_input,
                     object_position, require, scaled_position_inputs)


def sharpness_input(b):
    """The Sharpness socket of the triplanar groups: Listing 14's k."""
    return b.input("Sharpness", "FLOAT", "Blend sharpness k of Listing 14", default=3.0,
                   min_value=1.0, max_value=64.0)


def triplanar_blend_inputs(b):
    """Sharpness and Strength, the triplanar normal-map groups' last two inputs."""
    return sharpness_input(b), b.input("Strength", "FLOAT", "Bump scale", default=1.0,
                                       min_value=-10.0, max_value=10.0)


def triplanar_weights(b, n, k):
    """Listing 14: w = max(|n| - 0.2, 0)^k, normalised; returns the three weight sockets."""
    with b.frame("Listing 14: w = max(|n| - 0.2, 0)^k, normalised"):
        base = b.separate(b.vmath("MAXIMUM", b.vmath("SUBTRACT", b.vmath("ABSOLUTE", n),
                                                      (0.2, 0.2, 0.2)), (0.0, 0.0, 0.0)))
        wx, wy, wz = (b.math("POWER", c, k) for c in base)
        total = b.math("MAXIMUM", b.math("ADD", b.math("ADD", wx, wy), wz), DIVIDE_FLOOR)
        return tuple(b.math("DIVIDE", c, total) for c in (wx, wy, wz))


def triplanar_surface_gradient(b, n, weights, derivs):
    """Listing 13: the volume gradient of Eq. 19 from the planes' derivatives (sampled at
    (z, y), (x, z), (x, y)), projected by Listing 8."""
    w0, w1, w2 = weights
    (dxx, dxy), (dyx, dyy), (dzx, dzy) = derivs
    with b.frame("Listing 13: volume gradient of Eq. 19, then Listing 8"):
        grad = b.combine(
            b.math("ADD", b.math("MULTIPLY", w2, dzx), b.math("MULTIPLY", w1, dyx)),
            b.math("ADD", b.math("MULTIPLY", w2, dzy), b.math("MULTIPLY", w0, dxy)),
            b.math("ADD", b.math("MULTIPLY", w0, dxx), b.math("MULTIPLY", w1, dyy)))
        return b.sub(grad, b.scale(n, b.dot(n, grad)))


def triplanar_coordinates_group():
    def build(b):
        p, _ = scaled_position_inputs(b, "Where to project from (unlinked: world position)")
        with b.frame("Eq. 19 planes: X samples (z, y), Y (x, z), Z (x, y)"):
            x, y, z = b.separate(p)
            uvx, uvy, uvz = b.combine(z, y), b.combine(x, z), b.combine(x, y)
        b.output("UV X", "VECTOR", uvx, "Coordinates for the image projected along X")
        b.output("UV Y", "VECTOR", uvy, "Coordinates for the image projected along Y")
        b.output("UV Z", "VECTOR", uvz, "Coordinates for the image projected along Z")
    return ensure_group("SG Triplanar Coordinates", common.VERSION, build,
                        "The three planar projections of triplanar mapping (Eq. 19): feed "
                        "three Image Texture nodes, then SG Triplanar")


def triplanar_group():
    def build(b):
        n = normal_input(b)
        cx = b.input("Color X", "COLOR", "Tangent-space normal map sampled at UV X",
                     default=(0.5, 0.5, 1.0, 1.0))
        cy = b.input("Color Y", "COLOR", "Tangent-space normal map sampled at UV Y",
                     default=(0.5, 0.5, 1.0, 1.0))
        cz = b.input("Color Z", "COLOR", "Tangent-space normal map sampled at UV Z",
                     default=(0.5, 0.5, 1.0, 1.0))
        directx = directx_input(b)
        k, strength = triplanar_blend_inputs(b)
        weights = triplanar_weights(b, n, k)
        with b.frame("Listing 2 per plane"):
            derivs = [decode_tangent_normal(b, c, directx) for c in (cx, cy, cz)]
        sg = triplanar_surface_gradient(b, n, weights, derivs)
        w = b.combine(*weights)
        b.output("Surface Gradient", "VECTOR", b.scale(sg, strength), "Surface gradient")
        b.output("Weights", "VECTOR", w, "The blend weights (x, y, z)")
    return ensure_group("SG Triplanar", common.VERSION, build,
                        "Listings 13 and 14: triplanar normal mapping as a volume bump map")


def triplanar_sampler_group():
    """SG Triplanar (Sampler), Blender 5.0+: SG Triplanar Coordinates and SG Triplanar in one,
    the tangent-space normal map given as a Sampler closure evaluated on the three planes."""
    name = "SG Triplanar (Sampler)"
    require(name)

    def build(b):
        n = normal_input(b)
        p, _ = scaled_position_inputs(b, "Where to project from (unlinked: world position)")
        taps = SamplerTaps(b)
        directx = directx_input(b)
        k, strength = triplanar_blend_inputs(b)
        weights = triplanar_weights(b, n, k)
        with b.frame("Eq. 19 planes: X samples (z, y), Y (x, z), Z (x, y); Listing 2 each"):
            x, y, z = b.separate(p)
            colors = [taps.color(b.combine(u, v)) for u, v in ((z, y), (x, z), (x, y))]
            derivs = [decode_tangent_normal(b, c, directx) for c in colors]
        sg = triplanar_surface_gradient(b, n, weights, derivs)
        b.output("Surface Gradient", "VECTOR", b.scale(sg, strength), "Surface gradient")
        b.output("Weights", "VECTOR", b.combine(*weights), "The blend weights (x, y, z)")
    return ensure_group(name, common.VERSION, build,
                        "Listings 13 and 14: triplanar normal mapping as a volume bump map, "
                        "the normal map given as a Sampler closure")


def projector_coordinates_group():
    def build(b):
        near_q = b.input("Decal Coordinates", "VECTOR", "A Texture Coordinate node's Object "
                         "output with the projector as its object: used near the origin "
                         "(unlinked: the precise route everywhere)", hide_value=True)
        location = b.input("Projector Location", "VECTOR", "The projector's world location "
                           "(the Add Decal Projector operator drives it)", default=(0.0, 0.0, 0.0))
        rows = [b.input(f"To Projector {a}", "VECTOR", f"Row {a} of the projector's "
                        "world-to-local 3 x 3 matrix, the inverse of its rotation and scale "
                        "(driven by the operator)", default=e)
                for a, e in zip("XYZ", ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))]
        with b.frame("Offset from the projector in world axes, from precise parts: "
                     "(object origin - projector) + object-space position turned to world"):
            origin = b.node("ShaderNodeObjectInfo").outputs["Location"]
            turn = b.node("ShaderNodeVectorTransform", vector_type="VECTOR",
                          convert_from="OBJECT", convert_to="WORLD")
            b.link(object_position(b), turn.inputs[0])
            offset = b.add(b.sub(origin, location), turn.outputs[0])
        with b.frame("To the projector's space: one row per axis"):
            precise = b.combine(*(b.dot(row, offset) for row in rows))
        with b.frame(f"Near the origin (< {common.FAR_METRES:g} m) the linked Texture "
                     "Coordinate, as it always was; far out or unlinked, the precise route"):
            ox, oy, oz = b.separate(b.vmath("ABSOLUTE", origin))
            reach = b.math("MAXIMUM", b.math("MAXIMUM", ox, oy), oz)
            unlinked = b.math("COMPARE", b.length(near_q), 0.0, 0.0)
            use = b.math("MAXIMUM", b.math("GREATER_THAN", reach, common.FAR_METRES), unlinked)
            q = common.select(b, use, near_q, precise)
        b.output("Decal Coordinates", "VECTOR", q, "Position in the projector's space, for SG "
                 "Decal Coordinates and SG Decal")
    return ensure_group("SG Projector Coordinates", common.VERSION, build,
                        "A decal projector's coordinates, precise kilometres from the origin "
                        "(a Texture Coordinate node's Object output alone is not): feed SG "
                        "Decal Coordinates and SG Decal")


def decal_coordinates_group():
    def build(b):
        q = b.input("Decal Coordinates", "VECTOR", "Position in the projector's space (a "
                    "Texture Coordinate node's Object output, the projector as its object)",
                    hide_value=True)
        with b.frame("[-1, 1]^2 of the projector to [0, 1]^2"):
            uv = b.vmath("ADD", b.vmath("MULTIPLY", q, (0.5, 0.5, 0.0)), (0.5, 0.5, 0.0))
        b.output("Decal UV", "VECTOR", uv, "Where to sample the decal image (its Image "
                 "Texture's Vector)")
    return ensure_group("SG Decal Coordinates", common.VERSION, build,
                        "Image coordinates of a decal projector: feed the decal's Image "
                        "Texture, then SG Decal")


DECAL_SHAPES = ("box", "sphere", "cylinder", "cone")      # the Shape input's 0, 1, 2, 3
SHAPE_TOOLTIP = ("Projector volume, in the projector's [-1, 1] cube: 0 box (fades toward its "
                 "near and far faces), 1 sphere (fades toward its surface), 2 cylinder along "
                 "the projection axis (fades toward its side and ends), 3 cone with its apex "
                 "at the projector (+z) and radius 1 at the far end (fades toward its side "
                 "and ends)")


def _ramp(b, distance, falloff):
    """clamp(distance / falloff, 0, 1): 1 inside, 0 at the shape's boundary."""
    fade = b.math("DIVIDE", distance, b.math("MAXIMUM", falloff, 1e-6))
    return b.math("MINIMUM", b.math("MAXIMUM", fade, 0.0), 1.0)


def decal_weight(b, q, shape, falloff):
    """Each shape's weight in [0, 1] (reference/decals.py has the same four), selected by
    `shape`; every one is a bump scale (the paper's footnote 2), so the result stays a
    surface gradient."""
    qx, qy, qz = b.separate(q)
    depth = _ramp(b, b.math("SUBTRACT", 1.0, b.math("ABSOLUTE", qz)), falloff)
    rho = b.length(b.combine(qx, qy))
    with b.frame("Box: inside |x|, |y| <= 1, faded along depth"):
        inside = b.math("MULTIPLY", b.math("LESS_THAN", b.math("ABSOLUTE", qx), 1.000001),
                        b.math("LESS_THAN", b.math("ABSOLUTE", qy), 1.000001))
        box = b.math("MULTIPLY", inside, depth)
    with b.frame("Sphere: faded toward |q| = 1"):
        sphere = _ramp(b, b.math("SUBTRACT", 1.0, b.length(q)), falloff)
    with b.frame("Cylinder: faded toward rho = 1 and the ends"):
        cylinder = b.math("MULTIPLY", _ramp(b, b.math("SUBTRACT", 1.0, rho), falloff), depth)
    with b.frame("Cone: radius (1 - z) / 2, faded toward its side and the ends"):
        radius = b.math("MAXIMUM", b.math("MULTIPLY", b.math("SUBTRACT", 1.0, qz), 0.5), 1e-6)
        cone = b.math("MULTIPLY", _ramp(b, b.math("SUBTRACT", 1.0, b.math(
            "DIVIDE", rho, radius)), falloff), depth)
    with b.frame("The chosen shape"):
        total = 0.0
        for index, weight in enumerate((box, sphere, cylinder, cone)):
            pick = b.math("COMPARE", shape, float(index), 0.5)
            total = b.math("ADD", total, b.math("MULTIPLY", pick, weight))
        return total


def decal_group():
    def build(b):
        n = normal_input(b)
        q = b.input("Decal Coordinates", "VECTOR", "Position in the projector's space: a "
                    "Texture Coordinate node's Object output with the projector (an empty) "
                    "as its object; the decal covers [-1, 1] in x and y", hide_value=True)
        color = b.input("Color", "COLOR", "Tangent-space normal map sampled at the Decal UV "
                        "of SG Decal Coordinates", default=(0.5, 0.5, 1.0, 1.0))
        directx = directx_input(b)
        axis_x = b.input("Axis X", "VECTOR", "The projector's X axis in world space (unit "
                         "length; the Add Decal Projector operator drives it)",
                         default=(1.0, 0.0, 0.0), subtype="DIRECTION")
        axis_y = b.input("Axis Y", "VECTOR", "The projector's Y axis in world space (unit "
                         "length)", default=(0.0, 1.0, 0.0), subtype="DIRECTION")
        strength = b.input("Strength", "FLOAT", "Bump scale", default=1.0, min_value=-10.0,
                           max_value=10.0)
        falloff = b.input("Falloff", "FLOAT", "Distance over which the decal fades out toward "
                          "its shape's boundary (fraction of the projector's half-size)",
                          default=0.2, min_value=0.0, max_value=1.0)
        shape = b.input("Shape", "INT", SHAPE_TOOLTIP, default=0, min_value=0, max_value=3)
        base = b.input("Base Gradient", "VECTOR", "The surface gradient underneath (the sum "
                       "of the layers below). Add mode adds the decal to it; Overwrite "
                       "replaces it where the decal is, faded by Opacity and the falloff",
                       hide_value=True)
        overwrite = b.input("Overwrite", "BOOLEAN", "Off: add (the surface gradients sum). "
                            "On: the decal's gradient replaces the Base Gradient", default=False)
        opacity = b.input("Opacity", "FLOAT", "How much of the decal: scales it in Add mode, "
                          "blends from the Base Gradient to it in Overwrite mode",
                          default=1.0, min_value=0.0, max_value=1.0)
        with b.frame("Falloff as a bump scale: the shape's weight"):
            weight = b.math("MULTIPLY", decal_weight(b, q, shape, falloff), opacity)
        with b.frame("Listing 2"):
            dx, dy = decode_tangent_normal(b, color, directx)
        with b.frame("Listing 15: grad = deriv.x X + deriv.y Y, then Listing 8"):
            grad = b.add(b.scale(axis_x, dx), b.scale(axis_y, dy))
            sg = b.scale(b.sub(grad, b.scale(n, b.dot(n, grad))), strength)
        with b.frame("Add: base + a sg; Overwrite: base + a (sg - base) = lerp(base, sg, a)"):
            out = b.add(base, b.scale(b.sub(sg, b.scale(base, overwrite)), weight))
        b.output("Surface Gradient", "VECTOR", out, "Surface gradient (with the Base "
                 "Gradient, added or overwritten)")
    return ensure_group("SG Decal", common.VERSION, build,
                        "Listing 15: a decal projector (box, sphere, cylinder or cone) as a "
                        "volume bump map, faded by its falloff, added to or overwriting the "
                        "surface gradient underneath")
