"""Footprint filtering of the fractal noise: each octave fades out as it becomes finer than the
shading footprint, so distant procedural bump does not sparkle (issue 24, after the fade by
octave frequency against the pixel footprint that the issue describes in the author's demo;
the constants lo, hi are this project's).

Octave i of frequency f_i (lacunarity^i, in the noise's own coordinates) is weighted by
    w_i = 1 - smoothstep(lo, hi, f_i * F),   smoothstep(a, b, x) = t^2 (3 - 2 t),
    t = clamp((x - a) / (b - a), 0, 1),
with F the footprint in the same coordinates. An octave's lattice spacing is 1 / f_i: at
f_i F = hi = 1/2 a pixel spans half a cell (Nyquist for the lattice) and the octave is gone;
below lo = 1/4 it is untouched. w_i is a screen quantity: the gradient of the filtered noise
treats it as a constant (as a shader's ddx/ddy-driven fade does).

The footprint the node group measures (addon/groups/volume.py) comes from the Bump-node
inversion, the only route to dP/dx, dP/dy in Cycles: see footprint_from_differentials.
"""

import numpy as np

from .vecmath import cross, dot, length

FADE_LO, FADE_HI = 0.25, 0.5


def smoothstep(lo, hi, x):
    """GLSL/HLSL smoothstep (and Cycles' Map Range Smooth Step): t^2 (3 - 2 t)."""
    t = np.clip((np.asarray(x, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def octave_weight(frequency, footprint, lo=FADE_LO, hi=FADE_HI):
    """w = 1 - smoothstep(lo, hi, frequency * footprint): 1 for coarse octaves, 0 for those
    finer than the footprint."""
    return 1.0 - smoothstep(lo, hi, frequency * np.asarray(footprint, dtype=np.float64))


def footprint_from_differentials(dpdx, dpdy, n, jx, jy):
    """The footprint the node group measures, from the differentials dpdx, dpdy (N, 3) its
    Bump nodes see, their base normal n, and jx = J dpdx, jy = J dpdy (N, 3): how the noise
    coordinates q move along each differential (J = dq/dP).

    The Bump node inverted gives the surface gradient of its height from forward differences
    along s dpdx, s dpdy, divided by s (its step s, the Filter Width): with the dual basis
    e_x = (dpdy x n) / det, e_y = (n x dpdx) / det, det = dpdx . (dpdy x n), a height h gives
    (dh_x e_x + dh_y e_y) / s. For each coordinate q_k (linear on a triangle) that is exactly
    g_k = (J dpdx)_k e_x + (J dpdy)_k e_y; for h = |q|^2 / 2 it is sum_k q_k g_k + R with
    the second-order remainder R = s (|jx|^2 e_x + |jy|^2 e_y) / 2. The group's footprint is
        F = 2 |R| / (s sqrt(sum_k |g_k|^2)),
    which for equal orthogonal differentials (a bake's: dpdx = r a, dpdy = r b) and a
    uniform J = c is c r = max(|J dpdx|, |J dpdy|); for orthogonal differentials of unequal
    lengths (a render's, roughly) it is c times their RMS, between max / sqrt(2) and max."""
    dpdx, dpdy, n, jx, jy = (np.asarray(a, dtype=np.float64) for a in (dpdx, dpdy, n, jx, jy))
    rx, ry = cross(dpdy, n), cross(n, dpdx)
    det = dot(dpdx, rx)
    ex, ey = rx / det, ry / det
    remainder = 0.5 * (dot(jx, jx) * ex + dot(jy, jy) * ey)
    g2 = sum(dot(jx[:, k:k + 1] * ex + jy[:, k:k + 1] * ey,
                 jx[:, k:k + 1] * ex + jy[:, k:k + 1] * ey)[:, 0] for k in range(3))
    return 2.0 * length(remainder)[:, 0] / np.sqrt(g2)
