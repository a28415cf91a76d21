"""Objects too small for Cycles' float32 derivatives, judged before a bake (bake_request.check).

The groups whose height derivative comes from the bake's texel steps (SG Height Map, SG
Parallax, SG Tangent Normal) lose precision in float32 as the object shrinks, whatever the
resolution (red team 43b, harness/scale_limits.py for compare's figures): below the half-size
WARN_BELOW names, compare's relief left the bar; below REFUSE_BELOW every height map measured
was off by degrees even with its relief scaled to the object (the unit sphere at 1e-7: HQ p99
9.6, Forward 11.9 deg; at 1e-6 Forward 0.48 / max 1.9), so the bake is refused there. No bpy
at module level: harness.scale_limits (numpy tier) reads world_extent here."""

import numpy as np

# Group-name prefixes (the per-image groups add " [image]") and the half-size (metres) below
# which a bake through them is warned about: compare's limits (harness/scale_limits.py).
WARN_BELOW = (("SG Height Map", 1e-2), ("SG Parallax", 2e-2), ("SG Tangent Normal", 2e-3))
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


def small_object_messages(obj):
    """(problems, warnings) for a bake of obj through the groups above while obj is small."""
    from .image_checks import objects_nodes     # bpy behind it; harness.scale_limits is not
    half, _ = world_extent(obj)
    if half <= 0.0:                 # the zero-scale and empty-mesh checks say
        return [], []
    used = {}
    for mat, node, path, _ in objects_nodes(obj):
        tree = getattr(node, "node_tree", None) if node.type == "GROUP" else None
        for prefix, limit in WARN_BELOW:
            if tree is not None and tree.name.startswith(prefix) and half < limit:
                used.setdefault((prefix, limit), f"{tree.name} node {path!r} (material "
                                                 f"{mat.name!r})")
    if not used:
        return [], []
    limit = max(lim for _, lim in used)
    names = ", ".join(used.values())
    size = (f"object {obj.name!r} is {2.0 * half:.3g} m across: the height derivatives of "
            f"{names} come from the bake's texel steps, which Cycles' float32 holds")
    if half < REFUSE_BELOW:
        return [f"{size} only to degrees below {2.0 * REFUSE_BELOW:g} m, so the map would be "
                f"wrong; {scale_up_text(limit, half)} and bake again"], []
    return [], [f"{size} to within 0.1 degree only above {2.0 * limit:g} m (the bake may be "
                f"off by tenths of a degree and more); for an exact map "
                f"{scale_up_text(limit, half)}"]
