"""Gustavson's procedural displacement and bump ("Recomputing normals for displacement and bump
mapping, procedural style", 2021), Eq. 3-8: everything in object space, no tangent frame."""

from .vecmath import as_float, dot, safe_normalize


def displace_along_normal(p0, n0, h, amount=1.0):
    """Eq. 3: P = P0 + amount * h(P0) * N0."""
    p0, n0, h = as_float(p0, n0, h)
    return p0 + (amount * h)[..., None] * n0


def displaced_normal(n0, grad, amount=1.0):
    """Eq. 4-8: the normal of the surface displaced by amount * h along N0, from g = grad h.

    g_par = (g . N0) N0 (Eq. 5), g_perp = g - g_par (Eq. 6), N = N0 - amount * g_perp
    (Eq. 7), normalised (Eq. 8). This is also Listing 8 then Listing 1 with a bump scale, which
    is why bump and displacement share it; the approximation holds while the curvature of the
    surface is small next to that of h.
    """
    n0, grad = as_float(n0, grad)
    g_perp = grad - dot(grad, n0) * n0
    return safe_normalize(n0 - amount * g_perp, n0)
