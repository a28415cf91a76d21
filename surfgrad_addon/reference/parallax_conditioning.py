"""Where a view-dependent reference (the parallax march) is ill-conditioned in float32: the
texels compare leaves out as "grazing" (harness/facing_exclusions.py).

Listing 11 takes the view's tangent part to texture space by solving
dir_t = a dPdx + b dPdy in the plane perpendicular to the shading normal n. The system's
determinant is n . (dPdx x dPdy) = dot(n, Ng) |dPdx x dPdy| (a bake's texel steps lie in the
face, whose normal is Ng), so where the shading normal nearly lies in its face (a smooth mesh
whose neighbours face the other way) a rounding of n by FLT_EPSILON moves the determinant by
FLT_EPSILON |dPdx x dPdy|: a relative FLT_EPSILON / dot(n, Ng) of the march vector v. The
march samples the images up to st + v, so its sample points, and the texture coordinate the
normal map is read at, are uncertain by |v| FLT_EPSILON / dot(n, Ng) in texture units. |v|
grows as 1 / dot(n, Ng) too (the view is projected along n onto the face), so this spread
grows as 1 / dot^2 and no float32 evaluation (Cycles' nodes) can follow the float64 reference
there, whatever the group does.
"""

import numpy as np

from .methods import unit_base_normal
from .parallax import project_vec_to_texture_space
from .vecmath import FLT_EPSILON


def march_spread_texels(td, view, depth, image_width, uv_map=None):
    """(N,) the float32 spread of the parallax march's sample points on td's texels, in texels
    of an image `image_width` pixels wide (one repeat per unit of UV): |v| FLT_EPSILON /
    dot(n, Ng) x image_width, v Listing 11's vector for unit view directions `view` (N, 3) and
    the parallax `depth`. Infinite where the shading normal does not face its face."""
    n = unit_base_normal(td)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps(uv_map)
    v = project_vec_to_texture_space(n, dpdx, dpdy, dst_dx, dst_dy, view, depth)
    facing = np.sum(n * td.geometric_normal, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        spread = np.linalg.norm(v, axis=-1) * FLT_EPSILON / facing * image_width
    return np.where(facing > 0, spread, np.inf)
