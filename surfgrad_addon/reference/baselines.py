"""The methods the surface-gradient framework is measured against (never used by it).

- Perlin (1985): add the volume gradient to the normal without projecting it (paper section
  3.6; negated, as in Figure 4(a), so it bumps the same way as the framework).
- Geiss (2007) traditional triplanar: tangent-normal xy used directly in place of derivatives,
  with Perlin's perturbation (Figure 5, left); and the middle variant of Figure 5: proper
  derivatives but still Perlin's perturbation.
- The screen-derivative bump of the LxEngine blog: a frame rebuilt from dP/dx and the smooth
  normal by cross products, which throws away the lengths of dP/dx and dP/dy.
- Decals as engines do them: the negated projector direction as the normal to perturb.
"""

import numpy as np

from .listings import triplanar_volume_gradient
from .vecmath import as_float, cross, normalize


def perturb_normal_perlin1985(n, grad):
    """normalize(n - grad): Perlin's gradient addition, with no projection to the surface."""
    n, grad = as_float(n, grad)
    return normalize(n - grad)


def triplanar_geiss(n, weights, m_x, m_y, m_z):
    """Traditional triplanar: each plane's tangent normal m contributes -m.xy as if it were the
    derivative (so slopes saturate at 45 degrees), perturbed by Perlin's method."""
    m_x, m_y, m_z = as_float(m_x, m_y, m_z)
    grad = triplanar_volume_gradient(weights, -m_x[..., :2], -m_y[..., :2], -m_z[..., :2])
    return perturb_normal_perlin1985(n, grad)


def triplanar_derivative_perlin(n, weights, deriv_x, deriv_y, deriv_z):
    """Figure 5 (middle): correct derivatives, but Perlin's perturbation instead of Listing 8."""
    grad = triplanar_volume_gradient(weights, deriv_x, deriv_y, deriv_z)
    return perturb_normal_perlin1985(n, grad)


def bump_screen_derivative_lxengine(n, dpdx, dpdy, dhdx, dhdy):
    """The blog's GLSL bump_normal(): z = normalize(n), y = normalize(z x dPdx),
    x = normalize(y x z), result normalize(-dH/dx * x - dH/dy * y + z).

    dpdy only sets nothing: the rebuilt frame ignores it and the lengths of both derivatives,
    which is the ad-hoc re-orthonormalisation the accuracy chart measures.
    """
    n, dpdx, dpdy, dhdx, dhdy = as_float(n, dpdx, dpdy, dhdx, dhdy)
    z = normalize(n)
    y = normalize(cross(z, dpdx))
    x = normalize(cross(y, z))
    return normalize(-dhdx[..., None] * x - dhdy[..., None] * y + z)


def decal_projector_normal(deriv, axis_x, axis_y, axis_z):
    """Engines' decal normal: perturb the projector's own normal (axis_z, the negated projection
    direction) with the decal's tangent frame, ignoring the surface it lands on (Figure 6,
    middle)."""
    deriv, axis_x, axis_y, axis_z = as_float(deriv, axis_x, axis_y, axis_z)
    return normalize(axis_z - deriv[..., 0:1] * axis_x - deriv[..., 1:2] * axis_y)
