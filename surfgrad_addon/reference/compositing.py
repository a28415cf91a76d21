"""Compositing two tangent-space normals (paper section 4.2, Table 1, Eq. 18) and
post-resolve bump mapping (section 4.6).

The classic forms combine tangent normals a, b in [-1, 1]^3 that share one unwrap and return a
unit tangent normal. The surface-gradient forms take each normal with its own tangent frame
(so the two maps may sit on different UV maps), convert through Listing 2 and Listing 3, and
return a surface gradient to add to others and resolve with Listing 1.
"""

import numpy as np

from .listings import (resolve_normal_from_surface_gradient, surfgrad_from_tbn,
                       tspace_normal_to_derivative)
from .vecmath import as_float, dot, normalize


def _xyz(x, y, z):
    return np.stack([x, y, z], axis=-1)


def blend_pd(a, b):
    """Partial derivatives: add the Eq. 15 derivatives, back to a normal by Eq. 12."""
    a, b = as_float(a, b)
    return normalize(_xyz(a[..., 0] * b[..., 2] + b[..., 0] * a[..., 2],
                          a[..., 1] * b[..., 2] + b[..., 1] * a[..., 2],
                          a[..., 2] * b[..., 2]))


def blend_whiteout(a, b):
    """Whiteout: normalize(a.xy + b.xy, a.z * b.z)."""
    a, b = as_float(a, b)
    return normalize(_xyz(a[..., 0] + b[..., 0], a[..., 1] + b[..., 1], a[..., 2] * b[..., 2]))


def blend_udn(a, b):
    """UDN: normalize(a.xy + b.xy, a.z)."""
    a, b = as_float(a, b)
    return normalize(_xyz(a[..., 0] + b[..., 0], a[..., 1] + b[..., 1], a[..., 2]))


def blend_rnm(a, b):
    """Reoriented normal mapping, Eq. 18: b rotated by the rotation that takes z to a."""
    a, b = as_float(a, b)
    ap = _xyz(a[..., 0], a[..., 1], a[..., 2] + 1)
    bp = _xyz(-b[..., 0], -b[..., 1], b[..., 2])
    m = ap * (dot(ap, bp) / ap[..., 2:3]) - bp
    return normalize(m)


# Table 1: the tangent normals each method feeds to Listing 2 before the surface gradients
# are added. PD uses (a, b); whiteout replaces both z by a.z*b.z; UDN gives b the z of a.
def table1_inputs(method, a, b):
    a, b = as_float(a, b)
    if method == "pd":
        return a, b
    if method == "whiteout":
        z = a[..., 2] * b[..., 2]
        return _xyz(a[..., 0], a[..., 1], z), _xyz(b[..., 0], b[..., 1], z)
    if method == "udn":
        return a, _xyz(b[..., 0], b[..., 1], a[..., 2])
    raise ValueError(f"unknown Table 1 method {method!r}; use 'pd', 'whiteout' or 'udn'")


def surfgrad_blend(method, a, t_a, b_a, b, t_b, b_b):
    """The surface-gradient form of PD, whiteout or UDN (Table 1): each tangent normal through
    Listing 2 and Listing 3 with its own frame (t_a, b_a) and (t_b, b_b), then added (Eq. 14)."""
    first, second = table1_inputs(method, a, b)
    return (surfgrad_from_tbn(tspace_normal_to_derivative(first), t_a, b_a)
            + surfgrad_from_tbn(tspace_normal_to_derivative(second), t_b, b_b))


def surfgrad_blend_rnm(a, b, t, bt):
    """RNM in the framework: the Eq. 18 result as a surface gradient on the shared frame
    (t, bt), ready to be added to other contributions (section 4.2)."""
    return surfgrad_from_tbn(tspace_normal_to_derivative(blend_rnm(a, b)), t, bt)


def post_resolve_bump(n, surf_grad, second_pass):
    """Post-resolve bump mapping (section 4.6): resolve, make the result the new base normal,
    and go again. second_pass(new_base_normal) returns the next surface gradient; it must
    recompute anything that depends on the base normal (sigma vectors, triplanar weights).
    Returns the final normal."""
    n1 = resolve_normal_from_surface_gradient(n, surf_grad)
    return resolve_normal_from_surface_gradient(n1, second_pass(n1))
