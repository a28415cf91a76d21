"""Listing 9 (the pixel-shader prologue) as separate pieces, and Listing 10.

Listing 9 caches, per pixel: the MikkTSpace tangent frame scaled by 1/|n| (so that the
surface-gradient form stays MikkTSpace compliant), the unit base normal (flipped on back
faces of two-sided materials), and sigmaX, sigmaY, flip_sign from dP/dx and dP/dy.
"""

from dataclasses import dataclass

import numpy as np

from .listings import sigma_vectors
from .vecmath import FLT_EPSILON, as_float, cross, length, sign_nonneg


def mikkts_bitangent(normal, tangent, sign):
    """Listing 9: bitangent on the fly, sign_w * cross(n, t), with sign_w = +-1 from tangent.w."""
    normal, tangent = as_float(normal, tangent)
    sign_w = np.where(np.asarray(sign)[..., None] > 0, 1.0, -1.0).astype(normal.dtype)
    return sign_w * cross(normal, tangent)


def mikkts_renormalize(normal, tangent, sign):
    """Listing 9: (n/|n|, t/|n|, b/|n|) from the interpolated, unnormalised vertex attributes.

    A positive uniform scale of the perturbed normal cancels in the resolve, so scaling the
    whole frame by 1/|n| keeps MikkTSpace compliance while giving a unit base normal.
    """
    normal, tangent = as_float(normal, tangent)
    bitangent = mikkts_bitangent(normal, tangent, sign)
    renorm = 1.0 / length(normal)
    return renorm * normal, renorm * tangent, renorm * bitangent


def two_sided_flip(n, is_back_face):
    """Listing 9: flip the base normal on back faces. Tangent, bitangent and surface
    gradients do not flip with it."""
    (n,) = as_float(n)
    return np.where(np.asarray(is_back_face)[..., None], -n, n)


@dataclass
class BumpPrologue:
    """The cached globals of Listing 9 for a batch of pixels."""
    base_normal: np.ndarray
    tangent: np.ndarray
    bitangent: np.ndarray
    dpdx: np.ndarray
    dpdy: np.ndarray
    sigma_x: np.ndarray
    sigma_y: np.ndarray
    flip_sign: np.ndarray


def bump_prologue(normal, tangent, sign, dpdx, dpdy, is_back_face=False):
    """All of Listing 9 at once. For post-resolve bump mapping, recompute with the resolved
    normal as `normal` (sigma vectors and flip_sign follow the new base normal)."""
    n, t, b = mikkts_renormalize(normal, tangent, sign)
    n = two_sided_flip(n, is_back_face)
    dpdx, dpdy = as_float(dpdx, dpdy)
    sigma_x, sigma_y, flip_sign = sigma_vectors(n, dpdx, dpdy)
    return BumpPrologue(n, t, b, dpdx, dpdy, sigma_x, sigma_y, flip_sign)


def screen_deriv_of_pos_no_ddxy(pos, norm, inv_view_proj_scr, x0, y0):
    """Listing 10: dP/dx and dP/dy analytically from the tangent plane and the inverse
    view-projection (screen [0, w] x [0, h] x [0, 1] to the space of pos and norm).

    pos, norm: (..., 3); inv_view_proj_scr: (4, 4) or (..., 4, 4); x0, y0: pixel centres
    (at .5). Returns (dpdx, dpdy), both in the tangent plane of norm.
    """
    pos, norm, m = as_float(pos, norm, inv_view_proj_scr)
    x0 = np.asarray(x0, dtype=pos.dtype)[..., None]
    y0 = np.asarray(y0, dtype=pos.dtype)[..., None]
    plane = np.concatenate([norm, -np.sum(pos * norm, axis=-1, keepdims=True)], axis=-1)
    mt = np.swapaxes(m, -1, -2)
    # The plane in screen space: planes transform by the transpose of the point transform.
    plane_scr = np.einsum("...ij,...j->...i", mt, plane)
    pz = plane_scr[..., 2:3]
    nz = sign_nonneg(pz) * np.maximum(FLT_EPSILON, np.abs(pz))
    ac = -plane_scr[..., 0:1] / nz
    bc = -plane_scr[..., 1:2] / nz
    dc = -plane_scr[..., 3:4] / nz
    c2 = mt[..., 2, :]
    v0 = mt[..., 0, :] + ac * c2
    v1 = mt[..., 1, :] + bc * c2
    v2 = mt[..., 3, :] + dc * c2
    # Homogeneous intersection point of the pixel's ray with the tangent plane.
    ipw = v0 * x0 + v1 * y0 + v2
    w = ipw[..., 3:4]
    denom = np.maximum(FLT_EPSILON, w * w)
    # Quotient rule: d(f/g) = (f' g - f g') / g^2.
    dpdx = (v0[..., :3] * w - ipw[..., :3] * v0[..., 3:4]) / denom
    dpdy = (v1[..., :3] * w - ipw[..., :3] * v1[..., 3:4]) / denom
    return dpdx, dpdy
