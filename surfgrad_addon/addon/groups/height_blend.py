"""SG Height Blend: two layers' surface gradients weighted by their heights (the height blend of
terrain and material-layering tools, not in the JCGT paper; reference/height_blend.py has the
equations (HB1), (HB2) and why). More layers chain through the Height output."""

from ..node_vocabulary import Math
from ...reference import socket_specs as S
from ...reference.height_blend import MIN_TRANSITION
from .common import ensure


def height_blend_group():
    def build(b):
        sg_a, sg_b = b.input("A"), b.input("B")
        h_a = b.input("Height A")
        h_b = b.math(Math.ADD, b.input("Height B"), b.input("Offset B"))
        contrast = b.input(S.CONTRAST)
        with b.frame("Transition width c = max(1 - Contrast, 0.001)"):
            c = b.math(Math.MAXIMUM, b.math(Math.SUBTRACT, 1.0, contrast), MIN_TRANSITION)
        with b.frame("HB1: w_i = max(h_i - max(h_A, h_B) + c, 0); W_B = w_B / (w_A + w_B)"):
            # k = c - m once, so each weight is one Add and one Maximum. The higher layer's
            # weight is c > 0: the sum never vanishes.
            k = b.math(Math.SUBTRACT, c, b.math(Math.MAXIMUM, h_a, h_b))
            w_a = b.math(Math.MAXIMUM, b.math(Math.ADD, h_a, k), 0.0)
            w_b = b.math(Math.MAXIMUM, b.math(Math.ADD, h_b, k), 0.0)
            weight_b = b.math(Math.DIVIDE, w_b, b.math(Math.ADD, w_a, w_b))
        with b.frame("HB2: W_A sg_A + W_B sg_B, and the height W_A h_A + W_B h_B"):
            sg = b.mix_vector(weight_b, sg_a, sg_b)
            height = b.math(Math.MULTIPLY_ADD, b.math(Math.SUBTRACT, h_b, h_a), weight_b, h_a)
        b.output(S.SURFACE_GRADIENT_OUT, sg)
        b.output("Height", height)
        b.output("Weight B", weight_b)
    return ensure("SG Height Blend", build)
