"""Section 4.3: parallax mapping through UV surface gradients (Listings 11 and 12), with
offset limiting and parallax occlusion."""

from ..node_builder import ensure_group
from ...reference.vecmath import DIVIDE_FLOOR, FLT_EPSILON
from . import common
from .common import (images_stale, normal_input, sub_group, uv_gradients_group, uv_input)
from .height import height_image_node


POM_STEPS = 8


def parallax_group(image=None, extension="REPEAT"):
    """SG Parallax for one height image (heights in [0, 1], 1 = Bump Scale above the surface):
    Listing 11 in surface gradients (the change of st along dir is (grad s . dir,
    grad t . dir)), Welsh's offset limiting, a POM_STEPS-step parallax-occlusion march with
    linear refinement (reference/parallax.py), and Listing 12 for the surface offset."""
    def build(b):
        n = normal_input(b)
        uv = uv_input(b, "Texture coordinate of the height image (link a UV Map node for another map)")
        view = b.input("View", "VECTOR", "Unit direction toward the viewer, world space "
                       "(unlinked: the Geometry node's Incoming)", hide_value=True)
        scale = b.input("Bump Scale", "FLOAT", "World distance of height 1 above the surface",
                        default=0.05, min_value=0.0, max_value=100.0)
        with b.frame("Unlinked View: Incoming"):
            incoming = b.node("ShaderNodeNewGeometry").outputs["Incoming"]
            unlinked = b.math("COMPARE", b.length(view), 0.0, 0.0)
            view = b.mix_vector(unlinked, view, incoming)
        grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
        gs, gt = grads.outputs[0], grads.outputs[1]
        with b.frame("Listing 11: dir to texture space"):
            dir_tex = b.combine(b.dot(gs, view), b.dot(gt, view), 0.0)
            limited_v = b.scale(dir_tex, scale)
            proj = b.math("DIVIDE", scale, b.math("MAXIMUM", b.math("ABSOLUTE", b.dot(n, view)),
                                                  FLT_EPSILON))
            v = b.scale(dir_tex, proj)
        with b.frame("Welsh: offset limiting, H(st) v"):
            h0 = height_image_node(b, image, uv, "Linear", extension)
            limited = b.scale(limited_v, h0)
        with b.frame(f"Parallax occlusion: {POM_STEPS} steps from height 1 down, refined"):
            hit, found = 0.0, 0.0
            prev_level, prev_gap = None, None
            for k in range(POM_STEPS + 1):
                level = 1.0 - k / POM_STEPS
                hk = height_image_node(b, image, b.add(uv, b.scale(v, level)), "Linear",
                                        extension)
                gap = b.math("SUBTRACT", level, hk)
                below = b.math("LESS_THAN", gap, DIVIDE_FLOOR)          # gap <= 0
                cross = b.math("MULTIPLY", below, b.math("SUBTRACT", 1.0, found))
                if prev_gap is None:
                    refined = level
                else:
                    t = b.math("DIVIDE", prev_gap, b.math("SUBTRACT", prev_gap, gap))
                    refined = b.math("ADD", prev_level, b.math("MULTIPLY", level - prev_level, t))
                hit = b.math("ADD", hit, b.math("MULTIPLY", cross, refined))
                found = b.math("MAXIMUM", found, cross)
                prev_level, prev_gap = level, gap
            offset = b.scale(v, hit)
        with b.frame("Listing 12: texture offset back onto the surface"):
            # The dual basis of (grad s, grad t) in the tangent plane: dP/ds, dP/dt.
            es = b.cross(gt, n)
            es = b.scale(es, b.math("DIVIDE", 1.0, b.dot(gs, es)))
            et = b.cross(n, gs)
            et = b.scale(et, b.math("DIVIDE", 1.0, b.dot(gt, et)))
            ox, oy, _ = b.separate(offset)
            surface = b.add(b.scale(es, ox), b.scale(et, oy))
        b.output("UV", "VECTOR", b.add(uv, offset), "Parallax-occlusion corrected texture "
                 "coordinate: sample the material's other maps here")
        b.output("UV Limited", "VECTOR", b.add(uv, limited), "Parallax with offset limiting "
                 "(cheaper, one height sample)")
        b.output("Surface Offset", "VECTOR", surface, "World offset of the corrected point "
                 "along the surface (Listing 12)")
        b.output("Height", "FLOAT", hit, "Height where the view ray meets the height field")

    stale = images_stale(lambda count: [image] * count)
    name = "SG Parallax" + (f" [{image.name}]" if image is not None else "")
    return ensure_group(name, common.VERSION, build,
                        "Listings 11 and 12: parallax mapping with offset limiting and "
                        "parallax occlusion", stale=stale)
