"""Height-blended layers: N layers' surface gradients weighted by their heights, so the higher
surface shows through and the lower one settles into the hollows (sand between cobbles, moss in
the cracks of a rock).

This is not in the JCGT paper: it is the height blend common to terrain and material-layering
tools (e.g. the "height-based texture blending" of game terrain shaders and of layered
materials). With layer heights h_i and per-layer offsets o_i (a painted mask raises or lowers a
layer), a transition width c > 0 and m = max_j (h_j + o_j):

    w_i = max(h_i + o_i - m + c, 0),     W_i = w_i / sum_j w_j                        (HB1)
    surface gradient = sum_i W_i sg_i,    height = sum_i W_i (h_i + o_i)              (HB2)

Only layers within c of the highest get any weight; the highest always gets w = c, so the sum
never vanishes and every W_i is continuous in the heights (no seam where two heights cross).
The weights are those of an interpolation, and surface gradients add linearly (Eq. 14), so
(HB2) is the paper's masked layering with masks W_i from the heights.

contrast in [0, 1] sets c = max(1 - contrast, MIN_TRANSITION) in height units: 0 a soft blend
over the whole unit range, 1 a hard switch to the highest layer (MIN_TRANSITION keeps it
continuous). The blended height is what a chain hands on: blend(blend(A, B), C) uses the
(A, B) mix's weighted height where the N-layer form uses A's and B's own; the two agree where
the (A, B) transition is settled (one of them has all its weight).
"""

import numpy as np

HEIGHT_BLEND_CONTRAST = 0.8      # c = 0.2: a short, visible transition on unit-range heights
MIN_TRANSITION = 1e-3            # c at contrast 1: a hard but continuous switch


def height_blend_transition(contrast):
    """The transition width c of (HB1) for `contrast` (0 soft .. 1 hard)."""
    return np.maximum(1.0 - np.asarray(contrast, dtype=np.float64), MIN_TRANSITION)


def height_blend_weights(heights, contrast=HEIGHT_BLEND_CONTRAST, offsets=None):
    """(W, blended height): the normalised weights W (N, ...) of (HB1) and the height of (HB2)
    for N layer heights (a sequence of arrays or scalars that broadcast together)."""
    h = np.asarray(np.broadcast_arrays(*[np.asarray(x, dtype=np.float64) for x in heights]))
    if offsets is not None:
        if len(offsets) != len(h):
            raise ValueError(f"{len(offsets)} offsets for {len(h)} layers")
        h = h + np.asarray([np.broadcast_to(np.asarray(o, dtype=np.float64), h.shape[1:])
                            for o in offsets])
    w = np.maximum(h - h.max(axis=0) + height_blend_transition(contrast), 0.0)
    weights = w / w.sum(axis=0)
    return weights, (weights * h).sum(axis=0)


def surfgrad_height_blend(surface_gradients, heights, contrast=HEIGHT_BLEND_CONTRAST,
                          offsets=None):
    """(surface gradient (..., 3), blended height (...), weights (N, ...)): N layers'
    surface gradients blended by their heights, (HB1) and (HB2)."""
    if len(surface_gradients) != len(heights) or len(heights) < 2:
        raise ValueError(f"give two or more layers, each a surface gradient and a height "
                         f"({len(surface_gradients)} and {len(heights)} given)")
    weights, height = height_blend_weights(heights, contrast, offsets)
    sg = sum(wi[..., None] * np.asarray(g, dtype=np.float64)
             for wi, g in zip(weights, surface_gradients))
    return sg, height, weights
