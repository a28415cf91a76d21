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
"""

import numpy as np

from ..addon.far_limits import FAR_REPEATS

# Methods whose texture coordinate is the world position x Scale (Scale 1 in compare).
WORLD_PROJECTED = ("triplanar", "triplanar-height", "triplanar-sampler",
                   "triplanar-height-sampler", "post-resolve")
# Cycles' world position is good to about this many float32 ulp (barycentric interpolation
# of float32 vertices): the measured 100 m and 1 km residuals match +-2..4 ulp.
POSITION_ULPS = 4.0
# Warn where that many ulp reach this fraction of a texel of the projected image: 100 m with
# a 128-pixel image (4 ulp = 3e-5 m = 0.004 texel) gave p99 0.15 deg; 10 m (0.0005) 0.01.
TEXEL_FRACTION = 2e-3


def world_extent(obj):
    """(half-size, farthest reach from the world origin) of obj's bounding box, in metres."""
    m = np.array(obj.matrix_world, dtype=np.float64)
    box = np.array([tuple(c) for c in obj.bound_box], dtype=np.float64)
    world = box @ m[:3, :3].T + m[:3, 3]
    half = 0.5 * float(np.max(world.max(axis=0) - world.min(axis=0)))
    return half, float(np.abs(world).max())


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
