"""What a Cycles bake gives shader nodes in place of ddx/ddy (pinned in
tests/test_blender_facts.py): the Bump node's dP/dx, dP/dy, and how attributes move along
them in its shifted copies. Used to reproduce the Bump node's forward differences (the
paper's Listing 7 with Cycles' differentials) in the reference.
"""

import numpy as np

from .vecmath import cross, dot, length, normalize


def make_orthonormals(n):
    """Cycles' make_orthonormals (util/math_float3.h): a = normalize((1,1,1) x N) (or
    (-1,1,1) x N when N.x == N.y == N.z), b = N x a."""
    n = np.asarray(n, dtype=np.float64)
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    same = (x == y) & (x == z)
    a = np.where(same[..., None], np.stack([z - y, x + z, -y - x], -1),
                 np.stack([z - y, x - z, y - x], -1))
    a = normalize(a)
    return a, cross(n, a)


def bump_differentials(td):
    """dPdx, dPdy (N, 3) a bake gives the Bump node: r * make_orthonormals(Ng) with
    r = k (|dP/ds| / W + |dP/dt| / H) on the bake's UV map (Blender's bake differentials,
    averaged to one length by Cycles), along fixed diagonals of the triangle's plane rather
    than the texel axes. k is the line's fact: 1/4 up to 5.0 (half-texel differentials), 1/2
    in 5.2 (blender_lines.LineFacts.bake_differential_scale)."""
    dp_ds, dp_dt, _ = td.derivatives(td.uv_map)
    r = td.facts.bake_differential_scale * (length(dp_ds)[:, 0] / td.width
                                            + length(dp_dt)[:, 0] / td.height)
    a, b = make_orthonormals(td.geometric_normal)
    return r[:, None] * a, r[:, None] * b


def uv_step(td, v, name=None):
    """How UV map `name` changes along an in-plane world vector v (N, 3) on each texel's
    triangle: what the Bump node's shifted copies add to an attribute."""
    dp_ds, dp_dt, _ = td.derivatives(name or td.uv_map)
    ng = td.geometric_normal
    r1, r2 = cross(dp_dt, ng), cross(ng, dp_ds)
    det = dot(dp_ds, r1)
    return np.concatenate([dot(v, r1), dot(v, r2)], -1) / det
