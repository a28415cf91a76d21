"""Section 3: resolving a surface gradient into a normal (Listing 1, Eq. 5) and adding,
scaling and masking surface gradients before one resolve (Eq. 13-14)."""

from ..node_builder import ensure_group
from . import common
from .common import normal_input, safe_normal_group


def resolve_group():
    def build(b):
        n = normal_input(b)
        sg = b.input("Surface Gradient", "VECTOR", "Sum of the surface gradients to apply",
                     hide_value=True)
        with b.frame("Listing 1: normalize(n - surfGrad)"):
            # Where n - surfGrad has no direction (zero, NaN, Inf) the shading normal is used:
            # the result is always a finite unit vector.
            safe = b.node("ShaderNodeGroup", label="normalize", node_tree=safe_normal_group())
            b.link(b.sub(n, sg), safe.inputs[0])
            out = safe.outputs[0]
        b.output("Normal", "VECTOR", out, "Perturbed unit normal (world space): link it to a "
                 "BSDF's Normal")
    return ensure_group("SG Resolve", common.VERSION, build,
                        "Listing 1: the perturbed normal from the base normal and the summed "
                        "surface gradient")


def combine_group():
    def build(b):
        a = b.input("A", "VECTOR", "First surface gradient", hide_value=True)
        c = b.input("B", "VECTOR", "Second surface gradient", hide_value=True)
        scale_a = b.input("Scale A", "FLOAT", "Weight of A (negative inverts that bump)",
                          default=1.0, min_value=-100.0, max_value=100.0)
        scale_b = b.input("Scale B", "FLOAT", "Weight of B (negative inverts that bump)",
                          default=1.0, min_value=-100.0, max_value=100.0)
        mask = b.input("Mask B", "FLOAT", "Mask for B (0 hides it, 1 keeps it)", default=1.0,
                       min_value=0.0, max_value=1.0, subtype="FACTOR")
        with b.frame("Eq. 14: surface gradients add linearly"):
            out = b.add(b.scale(a, scale_a), b.scale(c, b.math("MULTIPLY", scale_b, mask)))
        b.output("Surface Gradient", "VECTOR", out, "Scale A x A + Scale B x Mask B x B")
    return ensure_group("SG Combine", common.VERSION, build,
                        "Layering (Eq. 13-14): add, scale, mask or invert surface gradients")
