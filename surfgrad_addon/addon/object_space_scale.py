"""An object-space bake of an object whose world matrix scales unevenly (a non-uniform scale,
its own, a delta scale or a parent's): Blender turns the baked normal back into object space
as a direction (by the inverse of the object's matrix, RE_bake_normal_world_to_object), while
its Normal Map node (Object Space) reads the map as a normal (by the inverse transpose), so the
map it wrote is read back bent. Measured on 5.2 and 4.2 alike (red team 46a,
tests/test_faults_assets46.py): a plane scaled (2, 0.5, 1) fed a normal map leaning 60 degrees
baked an object-space map that Blender's own reader turns 36.6 degrees off (scaled (1, 1, 0.1):
59.0), exit 0; a tangent-space bake of the same object is right."""

import numpy as np

# Worst bend (degrees) the uneven scale may make before the bake is refused: float noise in an
# imported scale (0.99999994) stays far below it.
MAX_BEND_DEG = 0.01


def worst_bend_deg(matrix):
    """The largest angle between a world normal and the one Blender's Object Space Normal Map
    node reads back from the object-space map baked of it: the angle between n and
    (M M^T)^-1 n, at most arccos(2 sqrt(k) / (1 + k)) for k the ratio of the squared largest
    and smallest singular values of M (the matrix's 3 x 3 part)."""
    sv = np.linalg.svd(np.asarray(matrix, dtype=np.float64)[:3, :3], compute_uv=False)
    if not sv.min() > 0:
        return 0.0          # (a zero scale axis is refused on its own: zero_scale_problem)
    k = (sv.max() / sv.min()) ** 2
    return float(np.degrees(np.arccos(min(1.0, 2.0 * np.sqrt(k) / (1.0 + k)))))


def object_space_scale_problem(obj, matrix):
    """The refusal for an object-space bake of `obj` (world matrix `matrix`) that Blender would
    write bent, or None."""
    bend = worst_bend_deg(matrix)
    if bend <= MAX_BEND_DEG:
        return None
    scale = tuple(round(float(v), 6) for v in obj.scale)
    sv = np.linalg.svd(np.asarray(matrix, dtype=np.float64)[:3, :3], compute_uv=False)
    return (f"object {obj.name!r} is scaled unevenly in the world (scale {scale}; its world "
            f"matrix stretches {sv.min():.4g} to {sv.max():.4g}, from its own, delta or a "
            f"parent's scale): Blender's object-space bake turns normals into object space "
            f"by the inverse matrix, not its transpose, so an Object Space Normal Map node "
            f"would read the map up to {bend:.1f} degrees off; apply the scale (Object > "
            f"Apply > Scale, also on its parents) or bake in tangent space (--space tangent; "
            f"api: space=\"tangent\"; settings file: \"space\": \"tangent\")")
