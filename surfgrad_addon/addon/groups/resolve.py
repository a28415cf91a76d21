"""Section 3: resolving a surface gradient into a normal (Listing 1, Eq. 5) and adding,
scaling and masking surface gradients before one resolve (Eq. 13-14)."""

from ..node_vocabulary import Math
from ...reference import socket_specs as S
from .common import ensure, normal_input, safe_normal_group


def resolve_group():
    def build(b):
        n = normal_input(b)
        sg = b.input(S.SURFACE_GRADIENT)
        with b.frame("Listing 1: normalize(n - surfGrad)"):
            # Where n - surfGrad has no direction (zero, NaN, Inf) the shading normal is used:
            # the result is always a finite unit vector.
            safe = b.node("ShaderNodeGroup", label="normalize", node_tree=safe_normal_group())
            b.link(b.sub(n, sg), safe.inputs[0])
            out = safe.outputs[0]
        b.output(S.NORMAL_OUT, out)
    return ensure("SG Resolve", build)


def combine_group():
    def build(b):
        a, c = b.input("A"), b.input("B")
        scale_a, scale_b, mask = b.input("Scale A"), b.input("Scale B"), b.input("Mask B")
        with b.frame("Eq. 14: surface gradients add linearly"):
            out = b.add(b.scale(a, scale_a), b.scale(c, b.math(Math.MULTIPLY, scale_b, mask)))
        b.output(S.SURFACE_GRADIENT_OUT, out)
    return ensure("SG Combine", build)
