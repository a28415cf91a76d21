"""What compare says and does about an object's size (issue 20, item 3: scale).

- Parallax depth: the comparison's parallax depth (methods.PARALLAX_SCALE, 0.15 m) on an
  object much smaller than it offsets the UVs by dozens of repeats, and the occlusion march
  jumps between repeats: a chaotic function of position that float32 cannot reproduce (a
  1 mm sphere: p99 38 / max 71 deg; the same group with the depth scaled to the object: p99
  0.001 / max 0.01). The comparison's depth is therefore at most the object's half-size.
- World-projected textures (triplanar, post-resolve): a texture coordinate of magnitude X
  (world position x Scale) holds in Cycles' float32 only to a few ulp(X); at 1 km with a 1 m
  repeat that is ~1e-4 m, 1/80 of a 128-pixel texel, and the normal map itself changes by
  degrees there (perturbing the reference's positions by +-0.5 ulp alone: p99 0.16 /
  max 0.38 deg at 1 km). No route in float32 nodes can do better, so compare warns where that
  floor reaches the bar instead of calling the group wrong.
- Small objects: the methods whose height derivative comes from the bake's texel steps
  (Listing 6's scale-dependent bump, the parallax march) lose precision in Cycles' float32 as
  the object shrinks, whatever the resolution (16^2 to 256^2 the same): SG Height Map HQ on the
  unit sphere scaled to 1e-5 p99 0.08 deg, 1e-6 0.67, 1e-8 169 (the torus is worse: 1e-4
  0.48); the float64 reference keeps its answer from 1e-6 to 1e-8 (and flattens by 1e-12, at
  the paper's determinant guard, where the bake is wrong too). Normal maps, triplanar, volume
  noise and the box decal agree down to 1e-8 and beyond. compare refuses the others on an
  object below SMALL_LIMITS, before baking, naming its size and the fix.
"""

import numpy as np

from ..addon.far_limits import FAR_REPEATS
from ..addon.small_objects import scale_up_text, world_extent

# Methods whose texture coordinate is the world position x Scale (Scale 1 in compare).
WORLD_PROJECTED = ("triplanar", "triplanar-height", "triplanar-sampler",
                   "triplanar-height-sampler", "post-resolve")
# Cycles' world position is good to about this many float32 ulp (barycentric interpolation
# of float32 vertices): the measured 100 m and 1 km residuals match +-2..4 ulp.
POSITION_ULPS = 4.0
# Warn where that many ulp reach this fraction of a texel of the projected image: 100 m with
# a 128-pixel image (4 ulp = 3e-5 m = 0.004 texel) gave p99 0.15 deg; 10 m (0.0005) 0.01.
TEXEL_FRACTION = 2e-3


def parallax_depth(obj, depth):
    """(the comparison's parallax depth for obj, a note or None): `depth`, or the object's
    half-size where that is smaller."""
    half, _ = world_extent(obj)
    if half <= 0.0 or half >= depth:
        return depth, None
    return half, (f"parallax depth for the comparison: {half:.3g} m, the half-size of "
                  f"{obj.name!r} (the default {depth:g} m would offset its UVs by many "
                  f"repeats, where the occlusion march is chaotic in float32)")


def float32_coordinate_warning(obj, method, image_size):
    """A warning where method's world-projected texture coordinates on obj are too large for
    float32 to place within the bar, else None."""
    if method not in WORLD_PROJECTED:
        return None
    half, reach = world_extent(obj)
    origin = float(np.abs(np.array(obj.matrix_world, dtype=np.float64)[:3, 3]).max())
    if origin > FAR_REPEATS:
        # The groups' far route: frac(origin) plus the object-space offset, about half-size.
        reach = half + 1.0
    step = POSITION_ULPS * float(np.spacing(np.float32(reach)))
    fraction = step * image_size            # Scale 1: one repeat per metre
    if fraction < TEXEL_FRACTION:
        return None
    return (f"{obj.name!r} reaches {reach:.4g} m: its world-projected texture coordinates "
            f"(world position x Scale) hold in Cycles' float32 only to about {step:.2g} m, "
            f"{fraction:.2g} of a texel of the {image_size}-pixel image, so bake and reference "
            f"differ by float32 precision there, not by the group (below ~{_limit(image_size):.3g}"
            f" m from the origin at this repeat the bar holds); for renders keep such objects "
            f"smaller or lower the projection's Scale")


def _limit(image_size):
    """The reach below which float32_coordinate_warning stays silent."""
    ulp = TEXEL_FRACTION / (POSITION_ULPS * image_size)
    return ulp * 2.0 ** 23


# The half-size (metres) below which compare refuses a method. Measured at 16^2 (red team
# 43b; p99 / max deg against the bar 0.1 / 0.5) on the test torus (half-size 1.4 x its
# scale), the worse test object; the error grows as 1 / size (16^2 to 256^2 the same):
# Forward height map 1.4e-2 m 0.04 / 0.07, 1.4e-3 0.28 / 0.64 (HQ 1.4e-3 0.05 / 0.05,
# 1.4e-4 0.48 / 0.62); height-blend 0.14 0.01 / 0.02, 1.4e-2 0.33 / 0.46; the overwriting
# decal 1.4e-2 0.04 / 0.05, 1.4e-3 0.32 / 0.58; parallax 1.4e-2 0.07 / 0.23, 1.4e-3 0.42 /
# 4.0; the procedural basis 1.4e-3 0.03 / 0.05, 1.4e-4 0.28 / 0.43. SG Noise's filtered
# footprint differs by line: on 5.2 the sphere 1e-5 0.0, 1e-6 90; on 5.0 and 4.5 the sphere
# 1e-3 0.53 / 0.84; on 4.2 the torus 1e-2 0.47 / 0.88, 5e-2 0.05 / 0.08 (one limit, the
# worst line's). The Sampler groups measured as their plain groups (the same references);
# they take the same limits. Figures on 5.2 unless named.
SMALL_LIMITS = {"height-map": 1e-2, "height-map-sampler": 1e-2, "height-blend": 0.1,
                "decal-overwrite": 1e-2, "parallax": 2e-2, "parallax-sampler": 2e-2,
                "procedural-basis": 2e-3, "volume-noise-filtered": 5e-2}


def small_object_problem(obj, method):
    """Why method cannot be compared on obj because obj is too small for Cycles' float32
    derivatives, else None."""
    limit = SMALL_LIMITS.get(method)
    if limit is None:
        return None
    half, _ = world_extent(obj)
    if half >= limit or half <= 0.0:        # zero: the zero-scale and empty-mesh checks say
        return None
    fix = scale_up_text(limit, half)
    return (f"object {obj.name!r} is {2.0 * half:.3g} m across: below {2.0 * limit:g} m, "
            f"Cycles' float32 derivatives that {method} bakes from lose precision (the bake "
            f"and the float64 reference then differ by degrees, not by the group), so it is "
            f"not compared; {fix} and compare again")
