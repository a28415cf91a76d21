"""Objects too small for Cycles' float32 derivatives, judged before a bake (bake_request.check,
and freeze.check: a frozen map is a bake too).

The groups whose height derivative comes from the bake's texel steps (SG Height Map, SG
Parallax, SG Tangent Normal) lose precision in float32 as the object shrinks, whatever the
resolution (red teams 43b and 44b, harness/scale_limits.py for compare's figures): below the
half-size WARN_BELOW names, compare's relief (scaled to the object) left the bar; an SG Height
Map whose Bump Scale is steeper for its object than that relief, or set by a link, leaves it
sooner, below STEEP_BELOW (compare's fixed 0.05 m relief, round 43b). Below REFUSE_BELOW every
height map measured was off by degrees, its relief scaled to the object or not (the unit
sphere at 1e-7: HQ p99 9.6, Forward 11.9 deg; the torus at 1e-6: 53 to 79 deg), so the bake is
refused there. No bpy at module level: harness.scale_limits (numpy tier) reads world_extent
here."""

import numpy as np

from ..reference.method_registry import HEIGHT_BUMP_SCALE

# Group-name prefixes (the per-image groups add " [image]") and the half-size (metres) below
# which a bake through them is warned about: compare's limits (harness/scale_limits.py).
WARN_BELOW = (("SG Height Map", 5e-4), ("SG Parallax", 2e-2), ("SG Tangent Normal", 2e-3))
# compare's relief: HEIGHT_BUMP_SCALE per metre of half-size; an SG Height Map steeper than it
# is warned about below STEEP_BELOW (compare's height-map limit at a fixed 0.05 m relief).
GENTLE_BUMP_PER_METRE = HEIGHT_BUMP_SCALE
STEEP_BELOW = 1e-2
REFUSE_BELOW = 1e-6


def world_extent(obj):
    """(half-size, farthest reach from the world origin) of obj's bounding box, in metres."""
    m = np.array(obj.matrix_world, dtype=np.float64)
    box = np.array([tuple(c) for c in obj.bound_box], dtype=np.float64)
    world = box @ m[:3, :3].T + m[:3, 3]
    half = 0.5 * float(np.max(world.max(axis=0) - world.min(axis=0)))
    return half, float(np.abs(world).max())


def scale_up_text(limit, half):
    """How far to scale an object of half-size `half` up to reach `limit`."""
    factor = 10.0 ** np.ceil(np.log10(limit / half) - 1e-3)     # float32 scales: 1e-8 -> 1e4
    return (f"scale it up by {factor:.0f} or more (or the whole scene, with Scene > Units > "
            f"Unit Scale set to {1.0 / factor:g} to keep its units)")


def _node_limit(tree, node, half):
    """(the half-size below which a bake through node is warned about, whether its relief is
    what set it) for a group node of the groups above, else (None, False)."""
    for prefix, limit in WARN_BELOW:
        if tree.name.startswith(prefix):
            bump = node.inputs.get("Bump Scale")
            if prefix == "SG Height Map" and (bump is None or bump.is_linked or abs(
                    bump.default_value) > GENTLE_BUMP_PER_METRE * half):
                return STEEP_BELOW, True
            return limit, False
    return None, False


def small_object_messages(obj, only=None):
    """(problems, warnings) for a bake of obj (its materials, or material `only`) through the
    groups above while obj is small."""
    from .image_checks import objects_nodes     # bpy behind it; harness.scale_limits is not
    half, _ = world_extent(obj)
    if half <= 0.0:                 # the zero-scale and empty-mesh checks say
        return [], []
    used, steep = {}, False
    for mat, node, path, _ in objects_nodes(obj, only):
        tree = getattr(node, "node_tree", None) if node.type == "GROUP" else None
        limit, by_relief = _node_limit(tree, node, half) if tree is not None else (None, False)
        if limit is not None and half < limit:
            kind = tree.name.split(" [", 1)[0]          # one name per group kind and limit
            used.setdefault((kind, limit), (limit, f"{tree.name} node {path!r} (material "
                                                      f"{mat.name!r})"))
            steep = steep or by_relief
    if not used:
        return [], []
    limit = max(lim for lim, _ in used.values())
    names = ", ".join(name for _, name in used.values())
    size = (f"object {obj.name!r} is {2.0 * half:.3g} m across: the height derivatives of "
            f"{names} come from the bake's texel steps, which Cycles' float32 holds")
    if half < REFUSE_BELOW:
        return [f"{size} only to degrees below {2.0 * REFUSE_BELOW:g} m, so the map would be "
                f"wrong; {scale_up_text(limit, half)} and bake again"], []
    relief = (f" at a Bump Scale steeper than {GENTLE_BUMP_PER_METRE:g} x the object's "
              f"half-size, or set by a link (at most {GENTLE_BUMP_PER_METRE * half:.2g} m here "
              f"holds down to {2.0 * WARN_BELOW[0][1]:g} m)") if steep and limit == STEEP_BELOW \
        else ""
    return [], [f"{size} to within 0.1 degree only above {2.0 * limit:g} m{relief} (the bake "
                f"may be off by tenths of a degree and more); for an exact map "
                f"{scale_up_text(limit, half)}"]
