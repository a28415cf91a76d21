"""Section 4.3: parallax mapping through UV surface gradients (Listings 11 and 12), with
offset limiting and parallax occlusion."""

from ..node_vocabulary import Math, VMath
from ...reference import socket_specs as S
from ...reference.vecmath import DIVIDE_FLOOR, FLT_EPSILON
from .common import (ImageTaps, SamplerTaps, ensure, held_images_name, image_group_name,
                     images_stale, normal_input, require, sub_group, uv_gradients_group,
                     uv_input, where_zero)


POM_STEPS = 8


def parallax_group(image=None, extension="REPEAT"):
    """SG Parallax for one height image (heights in [0, 1], 1 = Depth above the surface):
    Listing 11 in surface gradients (the change of st along dir is (grad s . dir,
    grad t . dir)), Welsh's offset limiting, a POM_STEPS-step parallax-occlusion march with
    linear refinement (reference/parallax.py), and Listing 12 for the surface offset."""
    stale = images_stale(lambda count: [image] * count)
    key = "SG Parallax"
    return ensure(key, lambda b: _parallax_body(b, lambda b: ImageTaps(b, image, extension)),
                  image_group_name(key, [image], extension), stale=stale,
                  held_name=held_images_name(key))


def parallax_sampler_group():
    """SG Parallax (Sampler), Blender 5.0+: parallax_group from any height image, given as a
    Sampler closure."""
    name = "SG Parallax (Sampler)"
    require(name)
    return ensure(name, lambda b: _parallax_body(b, SamplerTaps))


def _parallax_body(b, taps_for):
    """The interface and interior shared by the per-image and the sampler parallax."""
    n = normal_input(b)
    uv = uv_input(b)
    view, scale = b.input("View"), b.input("Depth")
    taps = taps_for(b)
    with b.frame("Unlinked View: Incoming"):
        view = where_zero(b, view, b.geometry("Incoming"))
    grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
    gs, gt = grads.outputs[0], grads.outputs[1]
    with b.frame("Listing 11: dir to texture space"):
        dir_tex = b.combine(b.dot(gs, view), b.dot(gt, view), 0.0)
        limited_v = b.scale(dir_tex, scale)
        proj = b.math(Math.DIVIDE, scale, b.math(Math.MAXIMUM,
                                                 b.math(Math.ABSOLUTE, b.dot(n, view)),
                                                 FLT_EPSILON))
        v = b.scale(dir_tex, proj)
    with b.frame("Welsh: offset limiting, H(st) v"):
        h0 = taps.height(uv, "Linear")
        limited = b.scale(limited_v, h0)
    with b.frame(f"Parallax occlusion: {POM_STEPS} steps from height 1 down, refined"):
        hit, found = 0.0, 0.0
        prev_level, prev_gap = None, None
        for k in range(POM_STEPS + 1):
            level = 1.0 - k / POM_STEPS
            hk = taps.height(b.add(uv, b.scale(v, level)), "Linear")
            gap = b.math(Math.SUBTRACT, level, hk)
            below = b.math(Math.LESS_THAN, gap, DIVIDE_FLOOR)          # gap <= 0
            cross = b.math(Math.MULTIPLY, below, b.math(Math.SUBTRACT, 1.0, found))
            if prev_gap is None:
                refined = level
            else:
                t = b.math(Math.DIVIDE, prev_gap, b.math(Math.SUBTRACT, prev_gap, gap))
                refined = b.math(Math.ADD, prev_level, b.math(Math.MULTIPLY, level - prev_level, t))
            hit = b.math(Math.ADD, hit, b.math(Math.MULTIPLY, cross, refined))
            found = b.math(Math.MAXIMUM, found, cross)
            prev_level, prev_gap = level, gap
        offset = b.scale(v, hit)
    with b.frame("Listing 12: texture offset back onto the surface"):
        # The dual basis of (grad s, grad t) in the tangent plane: dP/ds, dP/dt.
        es = b.cross(gt, n)
        es = b.scale(es, b.math(Math.DIVIDE, 1.0, b.dot(gs, es)))
        et = b.cross(n, gs)
        et = b.scale(et, b.math(Math.DIVIDE, 1.0, b.dot(gt, et)))
        ox, oy, _ = b.separate(offset)
        surface = b.add(b.scale(es, ox), b.scale(et, oy))
    b.output("UV", b.add(uv, offset))
    b.output("UV Limited", b.add(uv, limited))
    b.output("Surface Offset", surface)
    b.output("Height", hit)
