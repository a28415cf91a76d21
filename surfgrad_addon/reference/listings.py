"""The surface-gradient framework of Mikkelsen (JCGT 9(3), 2020), Listings 1-8 and 13-15.

Each function is named after its listing in snake_case. The listings' hidden shader globals
(nrmBaseNormal, dPdx, dPdy, sigmaX, sigmaY, flip_sign) are explicit arguments, base normal
first. Vectors are arrays of shape (..., 3); derivatives and texture coordinates (..., 2).
"""

import numpy as np

from .vecmath import (DET_EPSILON, FLT_EPSILON, TSPACE_Z_CLAMP, as_float, cross, dot, safe_normalize,
                      sign_nonneg, normalize, stack_last)


def resolve_normal_from_surface_gradient(n, surf_grad):
    """Listing 1 / Eq. 5: n' = normalize(n - surfGrad).

    Where n - surfGrad has no direction (zero or non-finite) the base normal is returned, so
    the result is always a unit vector when n is.
    """
    n, surf_grad = as_float(n, surf_grad)
    return safe_normalize(n - surf_grad, n)


def tspace_normal_to_derivative(m, flip_vertical=False):
    """Listing 2 / Eq. 15: tangent-space normal m in [-1, 1]^3 to the derivative (dH/du, dH/dv).

    abs() makes the third component positive and the 1/128 clamp bounds the result to
    [-128, 128] (89.55 degrees), so z = 0 and z < 0 stay finite. The extra `tiny` guard only
    matters for m = 0, which then gives a zero derivative instead of 0/0.
    """
    (m,) = as_float(m)
    scale = TSPACE_Z_CLAMP
    ma = np.abs(m)
    z_ma = np.maximum(ma[..., 2], scale * np.maximum(ma[..., 0], ma[..., 1]))
    z_ma = np.maximum(z_ma, np.finfo(m.dtype).tiny)
    s = -1.0 if flip_vertical else 1.0
    return stack_last([-m[..., 0] / z_ma, -(s * m[..., 1]) / z_ma])


def surfgrad_from_tbn(deriv, t, b):
    """Listing 3 / Eq. 17: deriv.x * t + deriv.y * b."""
    deriv, t, b = as_float(deriv, t, b)
    return deriv[..., 0:1] * t + deriv[..., 1:2] * b


def sigma_vectors(n, dpdx, dpdy):
    """Listing 9's sigmaX, sigmaY (dP/dx, dP/dy projected to the tangent plane) and flip_sign."""
    n, dpdx, dpdy = as_float(n, dpdx, dpdy)
    sigma_x = dpdx - dot(dpdx, n) * n
    sigma_y = dpdy - dot(dpdy, n) * n
    flip_sign = sign_nonneg(dot(dpdy, cross(n, dpdx)))
    return sigma_x, sigma_y, flip_sign


def gen_basis_tb(n, dpdx, dpdy, dst_dx, dst_dy):
    """Listing 4: an orthonormal (t, b) for any texture coordinate from its screen derivatives.

    dst_dx, dst_dy are ddx(st), ddy(st). Works for clockwise and counter-clockwise UVs. Where
    the UV mapping is degenerate (det = 0) t is left unnormalised, as in the listing; where t
    itself has no direction it is returned as zero rather than NaN.
    """
    n, dpdx, dpdy, dst_dx, dst_dy = as_float(n, dpdx, dpdy, dst_dx, dst_dy)
    sigma_x, sigma_y, flip_sign = sigma_vectors(n, dpdx, dpdy)
    det = (dst_dx[..., 0] * dst_dy[..., 1] - dst_dx[..., 1] * dst_dy[..., 0])[..., None]
    sign_det = sign_nonneg(det)
    # invC0 = (dX/ds, dY/ds) up to the positive factor 1/|det|.
    inv_c0_x = sign_det * dst_dy[..., 1:2]
    inv_c0_y = -sign_det * dst_dx[..., 1:2]
    t = sigma_x * inv_c0_x + sigma_y * inv_c0_y
    t = np.where(np.abs(det) > 0, safe_normalize(t, np.zeros_like(t)), t)
    b = (sign_det * flip_sign) * cross(n, t)
    return t, b


def surfgrad_from_perturbed_normal(n, v):
    """Listing 5: the surface gradient whose resolve points along v (any positive length).

    k = n.v; an inward v (k < 0) perturbs toward v all the same.
    """
    n, v = as_float(n, v)
    k = dot(n, v)
    return (k * n - v) / np.maximum(FLT_EPSILON, np.abs(k))


def surfgrad_scale_dependent(n, dpdx, dpdy, deriv, dst_dx, dst_dy, dim,
                             is_deriv_screen_space=False):
    """Listing 6 / Eq. 7: scale-dependent (displacement-style) bump.

    deriv is dH/d(u,v) in pixel units of a texture of size dim = (width, height); with
    is_deriv_screen_space it is already (dH/dx, dH/dy). dpdx, dpdy: screen derivatives of the
    undisplaced position; dst_dx, dst_dy: of the texture coordinate.
    """
    n, dpdx, dpdy, deriv, dst_dx, dst_dy = as_float(n, dpdx, dpdy, deriv, dst_dx, dst_dy)
    if is_deriv_screen_space:
        dhdx, dhdy = deriv[..., 0:1], deriv[..., 1:2]
    else:
        dhdst = np.asarray(dim, dtype=deriv.dtype) * deriv
        dhdx = dot(dhdst, dst_dx)
        dhdy = dot(dhdst, dst_dy)
    r1 = cross(dpdy, n)
    r2 = cross(n, dpdx)
    det = dot(dpdx, r1)
    s = sign_nonneg(det) / np.maximum(DET_EPSILON, np.abs(det))
    return s * (dhdx * r1 + dhdy * r2)


def surfgrad_from_volume_gradient(n, grad):
    """Listing 8 / Eq. 6: project a volume gradient onto the tangent plane of n."""
    n, grad = as_float(n, grad)
    return grad - dot(n, grad) * n


def determine_triplanar_weights(n, k=3.0):
    """Listing 14: blend weights from |n| - 0.2, sharpened by the power k, summing to one."""
    (n,) = as_float(n)
    w = np.maximum(np.abs(n) - 0.2, 0)
    # A whole power multiplies out (pow() is several times slower; within an ulp).
    w = w * w * w if k == 3 else (w * w if k == 2 else w ** k)
    total = (w[..., 0:1] + w[..., 1:2]) + w[..., 2:3] if w.shape[-1] == 3 else \
        np.sum(w, axis=-1, keepdims=True)
    # A unit n always has a component above 0.2; the guard only keeps zero vectors finite.
    return w / np.maximum(total, np.finfo(n.dtype).tiny)


def triplanar_volume_gradient(weights, deriv_x, deriv_y, deriv_z):
    """The volume gradient of Eq. 19 with fixed weights (Listing 13 before its projection).

    The planes are sampled with (z, y), (x, z) and (x, y) respectively.
    """
    weights, deriv_x, deriv_y, deriv_z = as_float(weights, deriv_x, deriv_y, deriv_z)
    w0, w1, w2 = weights[..., 0], weights[..., 1], weights[..., 2]
    return stack_last([w2 * deriv_z[..., 0] + w1 * deriv_y[..., 0],
                       w2 * deriv_z[..., 1] + w0 * deriv_x[..., 1],
                       w0 * deriv_x[..., 0] + w1 * deriv_y[..., 1]])


def surfgrad_from_triplanar_projection(n, weights, deriv_x, deriv_y, deriv_z):
    """Listing 13: triplanar bump as a volume bump map, projected with Listing 8."""
    return surfgrad_from_volume_gradient(
        n, triplanar_volume_gradient(weights, deriv_x, deriv_y, deriv_z))


def surfgrad_from_decal(n, deriv, axis_x, axis_y):
    """Listing 15: a decal projector's derivative as a volume gradient, projected (Eq. 6)."""
    deriv, axis_x, axis_y = as_float(deriv, axis_x, axis_y)
    if axis_x.ndim == axis_y.ndim == 1:         # one projector: component by component
        grad = stack_last([deriv[..., 0] * axis_x[j] + deriv[..., 1] * axis_y[j]
                           for j in range(3)])
    else:
        grad = deriv[..., 0:1] * axis_x + deriv[..., 1:2] * axis_y
    return surfgrad_from_volume_gradient(n, grad)


def derivative_to_tspace_normal(deriv):
    """Eq. 12: the unit tangent-space normal (-dH/du, -dH/dv, 1)/|.| of a derivative."""
    (deriv,) = as_float(deriv)
    m = np.concatenate([-deriv, np.ones_like(deriv[..., :1])], axis=-1)
    return normalize(m)
