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
- Small objects: the relief (Bump Scale, noise amount) shrinks with the object, so that a small
  object is compared as a scaled copy of the unit one (scaled_relief; before round 44b it was
  a fixed 0.05 m, and SG Height Map HQ on the unit sphere scaled to 1e-5 was p99 0.08 deg,
  1e-6 0.67, 1e-8 169). Even so, the methods whose height derivative comes from the bake's
  texel steps (Listing 6's scale-dependent bump, the parallax march, the procedural basis)
  lose precision in Cycles' float32 as the object shrinks, whatever the resolution (16^2 to
  256^2 the same); the float64 reference keeps its answer (and flattens by 1e-12, at the
  paper's determinant guard, where the bake is wrong too). Normal maps, triplanar, volume
  noise and the box decal agree down to 1e-8 and beyond. compare refuses the others on an
  object below SMALL_LIMITS, before baking, naming its size and the fix.
"""

import numpy as np

from ..addon.far_limits import FAR_REPEATS
from ..addon.small_objects import scale_up_text, world_extent
from ..reference.method_registry import SPECS

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


# The methods whose relief is a length (metres): a Bump Scale, SG Noise's amount (the
# parameters named; height-blend's lengths are in its graph and reference, which both read
# method_registry.relief). The comparison's lengths suit the unit test objects (half-size
# UNIT_HALF); on a smaller object they shrink with it, so that it is compared as a scaled copy
# of the unit one (a fixed 0.05 m relief on a 1e-8 m sphere is all slope, and float32 loses it
# ten times sooner: SMALL_LIMITS). SG Noise reads object-space positions: its pattern already
# scales with the object, so its Scale stays.
RELIEF_LENGTHS = {"height-map": ("bump_scale",), "height-map-sampler": ("bump_scale",),
                  "volume-noise-filtered": ("amount",), "height-blend": ()}
UNIT_HALF = 1.0


def scaled_relief(obj, method):
    """(method with its relief lengths scaled to obj, the factor): the factor is obj's
    half-size / UNIT_HALF where that is below 1 and method's relief is a length, else 1."""
    half, _ = world_extent(obj)
    if method.name not in RELIEF_LENGTHS or not 0.0 < half < UNIT_HALF:
        return method, 1.0
    r = half / UNIT_HALF
    values = dict(method.values)
    return method.at(**{k: values[k] * r for k in RELIEF_LENGTHS[method.name]}), r


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


# The half-size (metres) below which compare refuses a method, with the relief scaled to the
# object (scaled_relief). Measured at 16^2 (red team 44b; p99 / max deg against the bar 0.1 / 0.5)
# on the test torus (half-size 1.4 x its scale), the worse test object; the error grows about as 1
# / size, 16^2 to 256^2 the same. Height map, scaled relief (5.2; the worst variant, Forward):
# 1.4e-3 m 0.022 / 0.031, 5e-4 0.042 / 0.12, 1.4e-4 0.20 / 0.43 (4.5 and 5.0: 5.6e-4 0.052 /
# 0.088, 1.4e-4 0.15 / 0.48); HQ 1.4e-4 0.078 / 0.088, 1.4e-5 0.55. height-blend (the rock's Bump
# Scale and the sand's amount scaled) 1.4e-2 0.044 / 0.056, 1e-2 0.046 / 0.074, 1.4e-3 0.42 /
# 0.69, every line. SG Noise's filtered footprint (its amount scaled) differs by line: 4.2 1.4e-2
# 0.023 / 0.035, 5e-3 0.042 / 0.060, 1.4e-3 0.17 / 0.43 (fixed relief, 5e-3: 1.02 / 1.77); 4.5 and
# 5.0 1.4e-3 0.057 / 0.105, 1.4e-4 0.64 to 1.1; 5.2 0.00004 / 0.00009 down to 1.4e-5, 1.4e-6 21
# (one limit, the worst line's). Not relief in metres, so as round 43b measured them: the
# overwriting decal 1.4e-2 0.04 / 0.05, 1.4e-3 0.32 / 0.58; parallax (its depth already the
# object's half-size) 1.4e-2 0.07 / 0.23, 1.4e-3 0.42 / 4.0; the procedural basis 1.4e-3 0.03 /
# 0.05, 1.4e-4 0.28 / 0.43. With the fixed 0.05 m relief (before round 44b) the limits were height
# map 1e-2, height-blend 0.1, filtered noise 5e-2 (4.2: 1e-2 0.47 / 0.88; 4.2's Forward height map
# at 5e-4 then 0.66 / 1.08, now 5.2's 0.042 / 0.12). The Sampler groups measured as their plain
# groups (the same references); they take the same limits. Figures on 5.2 unless named.
SMALL_LIMITS = {"height-map": 5e-4, "height-map-sampler": 5e-4, "height-blend": 1e-2,
                "decal-overwrite": 1e-2, "parallax": 2e-2, "parallax-sampler": 2e-2,
                "procedural-basis": 2e-3, "volume-noise-filtered": 5e-3}


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


# The reach (metres from the object's origin, in object space) beyond which compare refuses a
# method whose SG Noise reads the object coordinates unfiltered: each octave's coordinate
# (object position x Scale x its frequency) holds in Cycles' float32 only to a fraction of a
# noise cell there (red team 45b). p99 / max deg at 16^2, the test sphere's mesh (radius 1)
# scaled, the torus's (reach 1.4) in brackets, 5.2, 5.0, 4.5 and 4.2 within 0.01: volume-noise
# at 100 0.061 / 0.083 (0.075 / 0.148), 150 0.088 / 0.097 (0.084 / 0.12), 200 0.12 / 0.14
# (0.14 / 0.18), 1e3 0.60 / 0.80; the layered stack (its noise's amount smaller) 300 0.044 /
# 0.059 (0.062 / 0.149), 1e3 0.21 / 0.32 (5.2). The filtered noise fades those octaves out
# and agrees (3e4 m: p99 2e-5). Red team 48b, the sphere (torus in brackets), 5.2 / 4.2 (SG
# Displace: 4.5, its first line) within 0.01: displace-bump's finer bump 10 m 0.0018 / 0.0020,
# 100 0.016 / 0.018, 297 0.051 / 0.072 (0.050 / 0.11), 400 0.099 / 0.11, 1e3 0.22 / 0.44, 1e4
# 1.8 / 2.5; height-blend's sand noise 10 m 0.0032 / 0.0039, 100 0.042 / 0.067, 198 0.049 /
# 0.072 (0.078 / 0.13), 300 0.11 / 0.16, 1e3 0.40 / 0.80, 1e4 4.9 / 5.9. An object moved out
# (its mesh unit-sized) agrees at 1e4 m: p99 2e-4 / 4e-4 (object coordinates).
# Red team 51b, with Blender's float32 bake weights modelled (reference/scan_weights.py, red
# team 50b), which were most of the figures above: the same 16^2 sphere (torus), 5.2 / 4.2
# (displace-bump 5.2 / 4.5): volume-noise 990 m 0.078 / 0.075 (0.061 / 0.064), 1200 0.110 /
# 0.130; height-blend 990 0.055 / 0.068 (0.041 / 0.050), 1200 0.095 / 0.100, 1500 0.114 (5.2);
# displace-bump 1980 0.060 / 0.058 (0.062 / 0.051), 2500 0.096 / 0.107, 3000 0.127 (5.2); the
# layered stack 1980 0.053 / 0.044 (0.052 / 0.041; 4.5 for 4.2), 2500 0.063 / 0.081, 2970
# (torus) 0.107 / 0.092, 5000 0.101 / 0.171. The limits below sit where 0.99 x stays within the
# bar on every line and the next step reaches it; 5.0 and 4.5 read as 4.2. At 64^2 and 128^2
# p99 at 0.99 x stays within it too (worst: volume-noise 990 m 64^2 0.090 on 5.2, 4.2 0.076).
NOISE_REACH_LIMITS = {"volume-noise": 1000.0, "layered": 2000.0, "displace-bump": 2000.0,
                      "height-blend": 1000.0}
# What to compare instead, where a filtered method covers the same noise.
FILTERED_INSTEAD = {"volume-noise": "compare --method volume-noise-filtered (its Filter "
                                    "Footprint fades those octaves out and holds)",
                    "layered": "compare --method volume-noise-filtered for the noise alone"}


def _at(method, values):
    """" at Scale 16, Octaves 4" where the limit is the settings', else ""."""
    if noise_reach_limit(method, values) == NOISE_REACH_LIMITS.get(method):
        return ""
    v = dict(values)
    octaves = v.get("octaves", dict(SPECS[method].values())["octaves"])
    return f" at Scale {v['scale']:g}, Octaves {octaves}"


def object_reach(obj):
    """The farthest corner of obj's bounding box from its origin, in object space (metres)."""
    box = np.array([tuple(c) for c in obj.bound_box], dtype=np.float64)
    return float(np.abs(box).max()) if box.size else 0.0


# Methods whose reach limit shrinks with the asked Scale (noise_reach_limit), as measured:
# {method: the power of 2^(Octaves - 1) in the curvature the rule scales by}. volume-noise's
# rule takes the finest octave's frequency squared (red team 58c, measured at Octaves 4);
# displace-bump's SG Noise halves each octave's amplitude, its curvature Scale^2 x
# 2^(Octaves - 1) (red team 59a, 5.2, 32^2, Octaves 2: 30 m at Scale 100 0.103 deg p99,
# 100 m at 40 0.098, 400 m at 16 0.061, 1500 m at 8 0.059; 3e-7 deg per metre of reach
# times that curvature; Octaves 4 at Scale 100 on the unit objects 0.012-0.050).
SCALED_REACH = {"volume-noise": 2, "displace-bump": 1}


def noise_reach_limit(method, values=None):
    """The reach limit of `method` (metres) at its parameter `values` ({name: value}), or
    None. The limits above hold at the default Scale and Octaves; the bake's float32 position
    error is the reach's, and the normal turns by it times the noise's curvature, which grows
    with the square of the finest octave's frequency (Scale x 2^(Octaves - 1)). Red team 58c,
    the sphere's mesh scaled out, 32^2, p99 on 5.2: Scale 4 (the default) 100 m 0.010, 400 m
    0.039, 900 m 0.083; Scale 16: 100 m 0.127, 400 m 0.45, 900 m 1.1; Scale 40: 100 m 0.65
    (the error / (reach x Scale^2) 3e-6 to 6e-6 throughout). So the limit shrinks with that
    frequency squared (never grows past the measured one). displace-bump (its finer bump's
    Bump Scale 0.02, a rest position) agrees far past that rule at Octaves 4 (Scale 100 and
    200 on the unit objects: p99 0.012-0.050), so its Octaves count less (SCALED_REACH); it had
    no Scale rule until rt59a (a 30 m sphere at Scale 100 was called 0.103 deg wrong)."""
    limit = NOISE_REACH_LIMITS.get(method)
    values = dict(values or {})
    if limit is None or method not in SCALED_REACH or "scale" not in values:
        return limit
    default = dict(SPECS[method].values())
    # Scale squared: a negative Scale mirrors the noise, its frequency the same (Scale -16
    # had no limit: a 100 m sphere was compared, the correct group 0.125 deg p99 wrong; rt59a).
    power = SCALED_REACH[method]
    curvature = values["scale"] ** 2 * 2.0 ** (power * (values.get("octaves",
                                                                   default["octaves"]) - 1))
    at_default = default["scale"] ** 2 * 2.0 ** (power * (default["octaves"] - 1))
    if not curvature > 0:
        return None                   # Scale 0: a constant noise, no bump to lose
    return limit * min(1.0, at_default / curvature)


def noise_reach_problem(obj, method, values=None):
    """Why method (at its parameter `values`) cannot be compared on obj because its
    unfiltered noise coordinates are too large for Cycles' float32, else None."""
    limit = noise_reach_limit(method, values)
    if limit is None:
        return None
    reach = object_reach(obj)
    if not reach > limit:
        return None
    factor = 10.0 ** np.ceil(np.log10(reach / limit) - 1e-3)
    instead = FILTERED_INSTEAD.get(method)
    # whole metres from 10 km on: .4g alone would write 1e+04
    where = f"{reach:.4g}" if reach < 1e4 else f"{reach:.0f}"
    return (f"object {obj.name!r} reaches {where} m from its origin in object space: "
            f"beyond {limit:.4g} m{_at(method, values)}, the unfiltered noise coordinates that {method} reads "
            f"(object position x Scale) hold in Cycles' float32 only to a fraction of a noise "
            f"cell (the bake and the float64 reference then differ by float32, not by the "
            f"group), so it is not compared; scale its mesh down by {factor:.0f} or more about "
            f"its origin (Edit Mode)" + (f", or {instead}" if instead else ""))
