"""Parallax helpers: Listings 11 and 12, Welsh's offset limiting, and a parallax-occlusion march.

Conventions: bump_scale maps a height of 1 to a world distance along the base normal
(p' = p + bump_scale * H(s, t) * n); heights are in [0, 1].
"""

import numpy as np

from .vecmath import DET_EPSILON, FLT_EPSILON, as_float, cross, dot, sign_nonneg


def project_vec_to_texture_space(n, dpdx, dpdy, dst_dx, dst_dy, direction, bump_scale,
                                 skip_proj=False):
    """Listing 11: a unit direction (toward the viewer) as a 2-D texture-space vector.

    Without skip_proj the vector is extended so that its component along n is one unit (the
    ray from height 1 down to height 0); with skip_proj it is Welsh's unprojected offset.
    """
    n, dpdx, dpdy, dst_dx, dst_dy, direction = as_float(n, dpdx, dpdy, dst_dx, dst_dy,
                                                        direction)
    r1 = cross(dpdy, n)
    r2 = cross(n, dpdx)
    det = dot(dpdx, r1)
    s = sign_nonneg(det) / np.maximum(DET_EPSILON, np.abs(det))
    # Screen-space coordinates (a, b) of the tangent part of dir: dir_t = a dPdx + b dPdy.
    a = s * dot(r1, direction)
    b = s * dot(r2, direction)
    dir_tex = dst_dx * a + dst_dy * b
    if skip_proj:
        return bump_scale * dir_tex
    dir_tex_z = dot(n, direction)
    return bump_scale * dir_tex / np.maximum(FLT_EPSILON, np.abs(dir_tex_z))


def tex_space_offs_to_surface(sigma_x, sigma_y, dst_dx, dst_dy, corr_offs):
    """Listing 12: a texture-space offset (from the uncorrected st) back onto the surface."""
    sigma_x, sigma_y, dst_dx, dst_dy, corr_offs = as_float(sigma_x, sigma_y, dst_dx, dst_dy,
                                                           corr_offs)
    det = (dst_dx[..., 0] * dst_dy[..., 1] - dst_dx[..., 1] * dst_dy[..., 0])[..., None]
    s = sign_nonneg(det) / np.maximum(DET_EPSILON, np.abs(det))
    # The 2x2 inverse of [ddx(st) | ddy(st)] takes the offset to screen space.
    vx = s * (dst_dy[..., 1:2] * corr_offs[..., 0:1] - dst_dy[..., 0:1] * corr_offs[..., 1:2])
    vy = s * (-dst_dx[..., 1:2] * corr_offs[..., 0:1] + dst_dx[..., 0:1] * corr_offs[..., 1:2])
    return vx * sigma_x + vy * sigma_y


def parallax_offset_limited(height, v_tex):
    """Welsh (2004) parallax with offset limiting: offset = H(st) * v, where v comes from
    Listing 11 with skip_proj=True."""
    height, v_tex = as_float(height, v_tex)
    return height[..., None] * v_tex


def parallax_occlusion_march(sample_height, st, v_tex, steps=16):
    """A fixed-step parallax-occlusion ray march through a height field in [0, 1].

    sample_height(st) -> heights for (..., 2) coordinates. v_tex is Listing 11's projected
    vector (height 1 at st + v_tex, height 0 at st). The ray is marched from height 1 down in
    `steps` equal steps until it is under the height field, then the crossing is refined
    linearly between the last two samples. Returns the texture offset to add to st.
    Rays that never hit stop at height 0 (offset 0).
    """
    st, v_tex = as_float(st, v_tex)
    dtype = st.dtype
    levels = np.linspace(1.0, 0.0, steps + 1, dtype=dtype)
    prev_level = np.ones(st.shape[:-1], dtype=dtype)
    prev_gap = prev_level - np.asarray(sample_height(st + v_tex), dtype=dtype)
    hit_level = np.zeros(st.shape[:-1], dtype=dtype)
    found = np.zeros(st.shape[:-1], dtype=bool)
    found |= prev_gap <= 0
    hit_level = np.where(found, prev_level, hit_level)
    for level in levels[1:]:
        # Vectorised over all pixels; the loop runs over the fixed number of steps only.
        h = np.asarray(sample_height(st + level * v_tex), dtype=dtype)
        gap = level - h
        crossing = (~found) & (gap <= 0)
        # Linear refinement: where (level - H) changes sign between the two samples.
        t = prev_gap / np.where(crossing, prev_gap - gap, 1)
        refined = prev_level + (level - prev_level) * t
        hit_level = np.where(crossing, refined, hit_level)
        found |= crossing
        prev_level = np.full_like(prev_level, level)
        prev_gap = gap
    return hit_level[..., None] * v_tex
