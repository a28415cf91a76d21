"""Sections 3.5-3.6 and 4.6: object-space normals (Listing 5), volume gradients (Listing 8) and
the gradient noise whose exact gradient feeds them."""

from ..node_vocabulary import Math, VMath
from ...reference import socket_specs as S
from ...reference.noise_footprint import FADE_HI, FADE_LO
from ...reference.socket_specs import NOISE_OCTAVES
from ...reference.vecmath import FLT_EPSILON
from ..node_builder import running_line
from .common import (BUMP_FILTER_WIDTH, bump_surface_gradient, ensure, normal_input,
                     object_position, precise_far_route, sign_nonneg, sub_group, where_zero)


def volume_gradient_group():
    def build(b):
        n = normal_input(b)
        grad, strength = b.input("Gradient"), b.input("Bump Scale")
        with b.frame("Listing 8: grad - (n . grad) n"):
            sg = b.sub(grad, b.scale(n, b.dot(n, grad)))
        b.output(S.SUMMABLE_GRADIENT_OUT, b.scale(sg, strength))
    return ensure("SG Volume Gradient", build)


def object_normal_group():
    def build(b):
        n = normal_input(b)
        v, strength = b.input("Perturbed Normal"), b.input(S.STRENGTH)
        with b.frame("Listing 5: (k n - v) / max(eps, |k|), k = n . v"):
            k = b.dot(n, v)
            denom = b.math(Math.MAXIMUM, b.math(Math.ABSOLUTE, k), FLT_EPSILON)
            sg = b.scale(b.sub(b.scale(n, k), v), b.math(Math.DIVIDE, 1.0, denom))
        b.output(S.SURFACE_GRADIENT_OUT, b.scale(sg, strength))
    return ensure("SG Object Normal", build)


def gradient_noise_group(tree_type="ShaderNodeTree"):
    """One octave of the reference's gradient noise (reference/noise.py), value and exact
    gradient: lattice gradients 2 WhiteNoise(corner) - 1, quintic fade, trilinear weights.
    Accumulated corner by corner (value += w v, grad += w g + v grad w) so that few values
    are live at once: Cycles' SVM stack is small. The same nodes exist in Geometry Nodes,
    which gets its own copy (tree_type "GeometryNodeTree")."""
    corners = [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)]

    def build(b):
        p = b.input(S.NOISE_VECTOR)
        with b.frame("Cell and fade: f = p - floor(p), u = 6f^5 - 15f^4 + 10f^3"):
            cell = b.vmath(VMath.FLOOR, p)
            f = b.sub(p, cell)
            f2 = b.vmath(VMath.MULTIPLY, f, f)
            # u = f^3 (f (6 f - 15) + 10), du = 30 f^2 (f (f - 2) + 1)
            inner = b.vmath(VMath.ADD, b.vmath(VMath.MULTIPLY, f, b.vmath(VMath.SUBTRACT, b.vmath(
                VMath.MULTIPLY, f, (6.0, 6.0, 6.0)), (15.0, 15.0, 15.0))), (10.0, 10.0, 10.0))
            u = b.vmath(VMath.MULTIPLY, b.vmath(VMath.MULTIPLY, f2, f), inner)
            dinner = b.vmath(VMath.ADD, b.vmath(VMath.MULTIPLY, f, b.vmath(VMath.SUBTRACT, f,
                                                                   (2.0, 2.0, 2.0))),
                             (1.0, 1.0, 1.0))
            du = b.vmath(VMath.MULTIPLY, b.vmath(VMath.MULTIPLY, f2, (30.0, 30.0, 30.0)), dinner)
            # Per axis, the weight is u where the corner is 1 and 1 - u where it is 0.
            w1 = b.separate(u)
            w0 = b.separate(b.vmath(VMath.SUBTRACT, (1.0, 1.0, 1.0), u))
            d1 = b.separate(du)
            d0 = b.separate(b.vmath(VMath.MULTIPLY, du, (-1.0, -1.0, -1.0)))
        value, grad = 0.0, (0.0, 0.0, 0.0)
        with b.frame("Corners: g = 2 WhiteNoise(cell + c) - 1, v = g . (f - c); "
                     "value += w v, grad += w g + v grad w"):
            for c in corners:
                cf = tuple(float(x) for x in c)
                noise = b.node("ShaderNodeTexWhiteNoise", noise_dimensions="3D")
                b.link(b.vmath(VMath.ADD, cell, cf), noise.inputs["Vector"])
                g = b.vmath(VMath.SUBTRACT, b.vmath(VMath.MULTIPLY, noise.outputs["Color"],
                                                (2.0, 2.0, 2.0)), (1.0, 1.0, 1.0))
                v = b.dot(g, b.vmath(VMath.SUBTRACT, f, cf))
                wx, wy, wz = [(w0, w1)[c[a]][a] for a in range(3)]
                dx, dy, dz = [(d0, d1)[c[a]][a] for a in range(3)]
                wyz = b.math(Math.MULTIPLY, wy, wz)
                w = b.math(Math.MULTIPLY, wx, wyz)
                dw = b.combine(b.math(Math.MULTIPLY, dx, wyz),
                               b.math(Math.MULTIPLY, wx, b.math(Math.MULTIPLY, dy, wz)),
                               b.math(Math.MULTIPLY, b.math(Math.MULTIPLY, wx, wy), dz))
                value = b.math(Math.ADD, value, b.math(Math.MULTIPLY, w, v))
                grad = b.add(grad, b.add(b.scale(g, w), b.scale(dw, v)))
        b.output(S.VALUE_OUT, value)
        b.output(S.GRADIENT_OUT, grad)
    geometry = tree_type == "GeometryNodeTree"
    return ensure(".SG Gradient Noise" + (" (Geometry)" if geometry else ""), build,
                  tree_type=tree_type)


def noise_footprint(b, p):
    """The footprint F in the noise's coordinates p, from the Bump node inverted
    (reference/noise_footprint.footprint_from_differentials): the surface gradients g_k of
    p's components (exact, p is linear on a triangle) and of |p|^2 / 2, whose forward
    differences leave the remainder R = s (|J dP/dx|^2 e_x + |J dP/dy|^2 e_y) / 2 beside
    sum_k p_k g_k; F = 2 |R| / (s sqrt(sum_k |g_k|^2)), s the Bump node's step."""
    n = b.geometry("Normal")
    step = running_line().bump_step_scale(BUMP_FILTER_WIDTH)
    comps = b.separate(p)
    grads = [bump_surface_gradient(b, c, n, BUMP_FILTER_WIDTH) for c in comps]
    half_square = b.math(Math.MULTIPLY, b.dot(p, p), 0.5)
    remainder = bump_surface_gradient(b, half_square, n, BUMP_FILTER_WIDTH)
    spread = None
    for c, g in zip(comps, grads):
        remainder = b.sub(remainder, b.scale(g, c))
        g2 = b.dot(g, g)
        spread = g2 if spread is None else b.math(Math.ADD, spread, g2)
    denom = b.math(Math.MAXIMUM, b.math(Math.MULTIPLY, b.math(Math.SQRT, spread), step),
                   FLT_EPSILON)
    return b.math(Math.DIVIDE, b.math(Math.MULTIPLY, b.length(remainder), 2.0), denom)


def footprint_weight(b, footprint, frequency):
    """w = 1 - smoothstep(FADE_LO, FADE_HI, frequency F): a Map Range (Smooth Step) from
    [lo, hi] to [1, 0] (clamped)."""
    node = b.node("ShaderNodeMapRange", interpolation_type="SMOOTHSTEP", clamp=True)
    b.link(b.math(Math.MULTIPLY, footprint, frequency), node.inputs["Value"])
    for name, value in (("From Min", FADE_LO), ("From Max", FADE_HI), ("To Min", 1.0),
                        ("To Max", 0.0)):
        node.inputs[name].default_value = value
    return node.outputs["Result"]


def footprint_fade(b, amp, filtered, footprint, frequency):
    """amp (1 + Filter (w - 1)), w the octave's footprint weight: Filter Footprint off (a
    constant 0) folds it to amp, and the footprint's nodes go unused."""
    fade = b.math(Math.ADD, b.math(Math.MULTIPLY, filtered, b.math(
        Math.SUBTRACT, footprint_weight(b, footprint, frequency), 1.0)), 1.0)
    return b.math(Math.MULTIPLY, amp, fade)


def noise_group():
    def build(b):
        vec, scale = b.input(S.NOISE_VECTOR), b.input(S.NOISE_SCALE)
        octaves, gain = b.input(S.OCTAVES), b.input(S.GAIN)
        turb, obj_space = b.input("Turbulence"), b.input("Object Space")
        filtered = b.input("Filter Footprint")
        with b.frame("Unlinked Vector: object coordinates (precise far from the origin where "
                     "Precise Far From Origin is on)"):
            coords = precise_far_route(b, b.node("ShaderNodeTexCoord").outputs["Object"],
                                 lambda: object_position(b))
            p = b.scale(where_zero(b, vec, coords), scale)
        with b.frame("Filter Footprint: octaves finer than the footprint fade out, w = 1 - "
                     "smoothstep(lo, hi, 2^i F) (off, a constant: folds away)"):
            footprint = noise_footprint(b, p)
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
                    q = b.vmath(VMath.ADD, q, b.math(Math.SUBTRACT, prev, prev))
                node = sub_group(b, octave_tree, f"octave {i + 1}", Vector=q)
                v, g = node.outputs[0], node.outputs[1]
                prev = v
                sgn = sign_nonneg(b, v)
                v = b.math(Math.ADD, v, b.math(Math.MULTIPLY, turb, b.math(Math.SUBTRACT, b.math(
                    Math.ABSOLUTE, v), v)))
                g = b.mix_vector(turb, g, b.scale(g, sgn))
                on = b.math(Math.LESS_THAN, float(i), octaves)
                amp = b.math(Math.MULTIPLY, on, b.math(Math.POWER, gain, float(i)))
                amp = footprint_fade(b, amp, filtered, footprint, freq)
                value = b.math(Math.ADD, value, b.math(Math.MULTIPLY, amp, v))
                grad = b.add(grad, b.scale(g, b.math(Math.MULTIPLY, amp, freq)))
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
        b.output(S.VALUE_OUT, value)
        b.output(S.GRADIENT_OUT, grad)
    return ensure("SG Noise", build)
