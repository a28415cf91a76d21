"""Sections 3.5-3.6 and 4.6: object-space normals (Listing 5), volume gradients (Listing 8) and
the gradient noise whose exact gradient feeds them."""

from ..node_builder import ensure_group
from ...reference.vecmath import FLT_EPSILON
from . import common
from .common import normal_input, object_position, sign_nonneg, sub_group


def volume_gradient_group():
    def build(b):
        n = normal_input(b)
        grad = b.input("Gradient", "VECTOR", "Gradient of a volume bump function (world space), "
                       "e.g. SG Noise's Gradient", hide_value=True)
        strength = b.input("Strength", "FLOAT", "Bump scale: world units of displacement "
                           "per unit of the function (0.05 gives SG Noise's default a moderate "
                           "relief on a 1 m object)", default=0.05, min_value=-1000.0,
                           max_value=1000.0)
        with b.frame("Listing 8: grad - (n . grad) n"):
            sg = b.sub(grad, b.scale(n, b.dot(n, grad)))
        b.output("Surface Gradient", "VECTOR", b.scale(sg, strength),
                 "Surface gradient: add to others, then SG Resolve")
    return ensure_group("SG Volume Gradient", common.VERSION, build,
                        "Listing 8: surface gradient of a volume bump map")


def object_normal_group():
    def build(b):
        n = normal_input(b)
        v = b.input("Perturbed Normal", "VECTOR", "The normal to reach, world space, any "
                    "positive length (for an object-space map, convert it with a Vector "
                    "Transform node, type Normal)", hide_value=True)
        strength = b.input("Strength", "FLOAT", "Scale of the resulting bump", default=1.0,
                           min_value=-100.0, max_value=100.0)
        with b.frame("Listing 5: (k n - v) / max(eps, |k|), k = n . v"):
            k = b.dot(n, v)
            denom = b.math("MAXIMUM", b.math("ABSOLUTE", k), FLT_EPSILON)
            sg = b.scale(b.sub(b.scale(n, k), v), b.math("DIVIDE", 1.0, denom))
        b.output("Surface Gradient", "VECTOR", b.scale(sg, strength), "Surface gradient")
    return ensure_group("SG Object Normal", common.VERSION, build,
                        "Listing 5: surface gradient from an object- or world-space normal")


def gradient_noise_group(tree_type="ShaderNodeTree"):
    """One octave of the reference's gradient noise (reference/noise.py), value and exact
    gradient: lattice gradients 2 WhiteNoise(corner) - 1, quintic fade, trilinear weights.
    Accumulated corner by corner (value += w v, grad += w g + v grad w) so that few values
    are live at once: Cycles' SVM stack is small. The same nodes exist in Geometry Nodes,
    which gets its own copy (tree_type "GeometryNodeTree")."""
    corners = [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)]

    def build(b):
        p = b.input("Vector", "VECTOR", "Position to evaluate", hide_value=True)
        with b.frame("Cell and fade: f = p - floor(p), u = 6f^5 - 15f^4 + 10f^3"):
            cell = b.vmath("FLOOR", p)
            f = b.sub(p, cell)
            f2 = b.vmath("MULTIPLY", f, f)
            # u = f^3 (f (6 f - 15) + 10), du = 30 f^2 (f (f - 2) + 1)
            inner = b.vmath("ADD", b.vmath("MULTIPLY", f, b.vmath("SUBTRACT", b.vmath(
                "MULTIPLY", f, (6.0, 6.0, 6.0)), (15.0, 15.0, 15.0))), (10.0, 10.0, 10.0))
            u = b.vmath("MULTIPLY", b.vmath("MULTIPLY", f2, f), inner)
            dinner = b.vmath("ADD", b.vmath("MULTIPLY", f, b.vmath("SUBTRACT", f,
                                                                   (2.0, 2.0, 2.0))),
                             (1.0, 1.0, 1.0))
            du = b.vmath("MULTIPLY", b.vmath("MULTIPLY", f2, (30.0, 30.0, 30.0)), dinner)
            # Per axis, the weight is u where the corner is 1 and 1 - u where it is 0.
            w1 = b.separate(u)
            w0 = b.separate(b.vmath("SUBTRACT", (1.0, 1.0, 1.0), u))
            d1 = b.separate(du)
            d0 = b.separate(b.vmath("MULTIPLY", du, (-1.0, -1.0, -1.0)))
        value, grad = 0.0, (0.0, 0.0, 0.0)
        with b.frame("Corners: g = 2 WhiteNoise(cell + c) - 1, v = g . (f - c); "
                     "value += w v, grad += w g + v grad w"):
            for c in corners:
                cf = tuple(float(x) for x in c)
                noise = b.node("ShaderNodeTexWhiteNoise", noise_dimensions="3D")
                b.link(b.vmath("ADD", cell, cf), noise.inputs["Vector"])
                g = b.vmath("SUBTRACT", b.vmath("MULTIPLY", noise.outputs["Color"],
                                                (2.0, 2.0, 2.0)), (1.0, 1.0, 1.0))
                v = b.dot(g, b.vmath("SUBTRACT", f, cf))
                wx, wy, wz = [(w0, w1)[c[a]][a] for a in range(3)]
                dx, dy, dz = [(d0, d1)[c[a]][a] for a in range(3)]
                wyz = b.math("MULTIPLY", wy, wz)
                w = b.math("MULTIPLY", wx, wyz)
                dw = b.combine(b.math("MULTIPLY", dx, wyz),
                               b.math("MULTIPLY", wx, b.math("MULTIPLY", dy, wz)),
                               b.math("MULTIPLY", b.math("MULTIPLY", wx, wy), dz))
                value = b.math("ADD", value, b.math("MULTIPLY", w, v))
                grad = b.add(grad, b.add(b.scale(g, w), b.scale(dw, v)))
        b.output("Value", "FLOAT", value, "Noise value")
        b.output("Gradient", "VECTOR", grad, "Exact gradient with respect to Vector")
    geometry = tree_type == "GeometryNodeTree"
    return ensure_group(".SG Gradient Noise" + (" (Geometry)" if geometry else ""), common.VERSION,
                        build, "One octave of gradient noise with its analytic gradient",
                        tree_type=tree_type)


NOISE_OCTAVES = 4


def noise_group():
    def build(b):
        vec = b.input("Vector", "VECTOR", "Where to evaluate (unlinked: object coordinates)",
                      hide_value=True)
        scale = b.input("Scale", "FLOAT", "Frequency of the first octave", default=4.0,
                        min_value=0.0, max_value=1e4)
        octaves = b.input("Octaves", "INT", f"Octaves of the fractal sum (1 to {NOISE_OCTAVES})",
                          default=4, min_value=1, max_value=NOISE_OCTAVES)
        gain = b.input("Gain", "FLOAT", "Amplitude ratio between octaves (frequency doubles)",
                       default=0.5, min_value=0.0, max_value=1.0)
        turb = b.input("Turbulence", "BOOLEAN", "Sum |noise| (Perlin's turbulence) instead of "
                       "noise (fractal sum)", default=False)
        obj_space = b.input("Object Space", "BOOLEAN", "Vector is in object space: return the "
                            "gradient in world space (for SG Volume Gradient)", default=True)
        with b.frame("Unlinked Vector: object coordinates"):
            coords = object_position(b)
            unlinked = b.math("COMPARE", b.length(vec), 0.0, 0.0)
            p = b.scale(b.mix_vector(unlinked, vec, coords), scale)
        value, grad = 0.0, (0.0, 0.0, 0.0)
        octave_tree = gradient_noise_group()
        with b.frame("Fractal sum / turbulence: sum gain^i noise(2^i p), chain rule"):
            prev = None
            for i in range(NOISE_OCTAVES):
                freq = 2.0 ** i
                q = b.scale(p, freq) if i else p
                if prev is not None:
                    # q + (v - v): exactly q, but it makes this octave wait for the previous
                    # one, so Cycles' SVM compiler never holds two octaves' temporaries (its
                    # stack overflows otherwise).
                    q = b.vmath("ADD", q, b.math("SUBTRACT", prev, prev))
                node = sub_group(b, octave_tree, f"octave {i + 1}", Vector=q)
                v, g = node.outputs[0], node.outputs[1]
                prev = v
                sgn = sign_nonneg(b, v)
                v = b.math("ADD", v, b.math("MULTIPLY", turb, b.math("SUBTRACT", b.math(
                    "ABSOLUTE", v), v)))
                g = b.mix_vector(turb, g, b.scale(g, sgn))
                on = b.math("LESS_THAN", float(i), octaves)
                amp = b.math("MULTIPLY", on, b.math("POWER", gain, float(i)))
                value = b.math("ADD", value, b.math("MULTIPLY", amp, v))
                grad = b.add(grad, b.scale(g, b.math("MULTIPLY", amp, freq)))
            grad = b.scale(grad, scale)
        with b.frame("Object to world: (M^-T g)_i = (M^-1 e_i) . g"):
            comps = []
            for axis in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
                vt = b.node("ShaderNodeVectorTransform", vector_type="VECTOR",
                            convert_from="WORLD", convert_to="OBJECT")
                vt.inputs[0].default_value = axis
                comps.append(b.dot(vt.outputs[0], grad))
            world = b.combine(*comps)
            grad = b.mix_vector(obj_space, grad, world)
        b.output("Value", "FLOAT", value, "Noise value (for displacement or masks)")
        b.output("Gradient", "VECTOR", grad, "Exact gradient of Value (world space when Object "
                 "Space is on): feed SG Volume Gradient")
    return ensure_group("SG Noise", common.VERSION, build,
                        "The reference's 3-D gradient noise (fractal sum or turbulence) with its "
                        "exact gradient, bit-compatible lattice (White Noise hash)")
