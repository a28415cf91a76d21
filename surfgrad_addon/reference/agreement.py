"""How far a bake is from its reference, texel by texel: the angles and counts compare reports.

`angle_deg` is the definition of the angular error (float64, atan2 of |a x b| and a . b,
accurate near zero). `texel_agreement` classifies one block's texels and measures them: the
numpy code (`_agreement_numpy`) is the definition and `agreement_texels` its compiled twin
(compiled.py), which does in one pass what numpy does with a dozen gathers and temporaries.
Both leave atan2 to numpy (`angles`), so every angle is the same float either way
(tests/test_compare_kernels.py holds them bit for bit).
"""

import numpy as np

from . import compiled
from .compiled import kernel

# A texel's class (`code`): compared (1: compared and contested, i.e. claimed by two
# triangles of overlapping UV islands), or why not: 2 edge, 4 backfacing, 5 not baked.
COMPARED, CONTESTED, EDGE, BACKFACING, NOT_BAKED = 0, 1, 2, 4, 5
# counts[...] of texel_agreement, in this order.
COUNTS = ("compared", "contested", "finite_unit", "both", "finite_unit_all", "away",
          "truth_away", "away_wrong")


def angles(y, x, valid):
    """Degrees of atan2(y, x) where valid, 180 elsewhere (a vector without direction)."""
    return np.where(valid, np.degrees(np.arctan2(y, x)), 180.0)


def _atan2_args(a, b):
    """(|a x b|, a . b, valid) for (N, 3) float64 arrays, as numpy's cross and norm do it."""
    y = np.linalg.norm(np.cross(a, b), axis=-1)
    x = np.sum(a * b, axis=-1)
    valid = (np.isfinite(a).all(-1) & np.isfinite(b).all(-1)
             & (np.linalg.norm(a, axis=-1) > 0) & (np.linalg.norm(b, axis=-1) > 0))
    return y, x, valid


def angle_deg(a, b):
    """Angle between vectors in float64, accurate near zero (atan2 of |a x b| and a . b).
    A zero-length or non-finite vector has no direction: it scores 180 degrees, never 0."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return angles(*_atan2_args(a, b))


class Agreement:
    """One block's result: over its compared texels (in block order) the atan2 arguments of
    the error (bake against reference) and of both tilts (bake and reference against the
    base normal), `flat` (y * width + x), `marked` (contested); per texel `backfacing`;
    `counts` (COUNTS)."""

    def __init__(self, n):
        self.args = np.empty((6, n))         # y, x of: error, bake tilt, reference tilt
        self.valid = np.empty((3, n), dtype=bool)
        self.flat = np.empty(n, dtype=np.int64)
        self.marked = np.empty(n, dtype=bool)
        self.backfacing = np.empty(n, dtype=bool)
        self.counts = np.zeros(len(COUNTS), dtype=np.int64)
        self.n = 0

    def error(self):
        """The compared texels' angular error (degrees), in block order."""
        return angles(self.args[0, :self.n], self.args[1, :self.n], self.valid[0, :self.n])

    def tilts(self):
        """(bake tilt, reference tilt) against the base normal (degrees), compared texels."""
        n = self.n
        return (angles(self.args[2, :n], self.args[3, :n], self.valid[1, :n]),
                angles(self.args[4, :n], self.args[5, :n], self.valid[2, :n]))


def texel_agreement(pixel, pixels, covered, contested, on_edge, ref, shading, geometric, base,
                    backfacing_dot, reasons):
    """Classify and measure one block of texels: pixel (n, 2) their (x, y); pixels (H, W, >=3)
    float32 the bake and covered (H, W) where it wrote; contested, on_edge (H, W) of the
    rasterised reference; ref, shading, geometric, base (n, 3) float64 the reference's
    normal, shading and geometric normals and the base normal the tilts are measured from.
    A baked texel is an edge texel when on_edge and not contested, backfacing when
    dot(shading, geometric) < backfacing_dot, else compared. Writes the reason code of each
    baked texel that is not plainly compared into reasons (H, W) (EDGE, BACKFACING,
    CONTESTED) and returns an Agreement."""
    out = Agreement(len(pixel))
    if compiled.enabled() and len(pixel):
        rows = [np.ascontiguousarray(np.asarray(v, dtype=np.float64).T)
                for v in (ref, shading, geometric, base)]
        out.n = agreement_texels(np.ascontiguousarray(pixel), pixels, covered, contested,
                                 on_edge, *rows, float(backfacing_dot), reasons, out.args,
                                 out.valid, out.flat, out.marked, out.backfacing, out.counts)
    else:
        _agreement_numpy(pixel, pixels, covered, contested, on_edge, ref, shading, geometric,
                         base, backfacing_dot, reasons, out)
    return out


def _agreement_numpy(pixel, pixels, covered, contested_image, on_edge, ref, shading,
                     geometric, base, backfacing_dot, reasons, out):
    """The definition of texel_agreement (numpy)."""
    px, py = pixel[:, 0], pixel[:, 1]
    baked = pixels[py, px, :3].astype(np.float64)
    in_bake = covered[py, px]
    contested = contested_image[py, px]
    edge = on_edge[py, px] & ~contested
    facing = np.sum(shading * geometric, axis=-1)
    backfacing = in_bake & ~edge & (facing < backfacing_dot)
    compared = in_bake & ~edge & ~backfacing
    marked = contested & compared
    reasons[py[edge & in_bake], px[edge & in_bake]] = EDGE
    reasons[py[backfacing], px[backfacing]] = BACKFACING
    reasons[py[marked], px[marked]] = CONTESTED
    b_cmp = baked[compared]
    n = out.n = int(compared.sum())
    for k, (a, b) in enumerate(((b_cmp, ref[compared]), (b_cmp, base[compared]),
                                (ref[compared], base[compared]))):
        out.args[2 * k, :n], out.args[2 * k + 1, :n], out.valid[k, :n] = _atan2_args(a, b)
    out.flat[:n] = (py * pixels.shape[1] + px)[compared]
    out.marked[:n] = marked[compared]
    out.backfacing[:] = backfacing
    ng = geometric[in_bake]
    b_all, r_all = baked[in_bake], ref[in_bake]
    away = np.sum(b_all * ng, axis=-1) < -1e-3
    truth_dot = np.sum(r_all * ng, axis=-1)
    out.counts[:] = (
        n, int(marked.sum()),
        int(np.sum(np.isfinite(b_cmp).all(-1) & (np.abs(np.linalg.norm(b_cmp, axis=-1) - 1)
                                                  < 1e-4))),
        len(b_all),
        int(np.sum(np.isfinite(b_all).all(-1) & (np.abs(np.linalg.norm(b_all, axis=-1) - 1)
                                                  < 1e-3))),
        int(away.sum()), int(np.sum(truth_dot < 0)), int(np.sum(away & ~(truth_dot < 1e-3))))


@kernel(inline=True)
def _finite3(x, y, z):
    return np.isfinite(x) and np.isfinite(y) and np.isfinite(z)


@kernel(inline=True)
def _length3(x, y, z):
    return np.sqrt((x * x + y * y) + z * z)


@kernel(inline=True)
def _squared3(x, y, z):
    return (x * x + y * y) + z * z


@kernel(inline=True)
def _has_direction(x, y, z):
    """np.isfinite(v).all() and np.linalg.norm(v) > 0 (sqrt(s) > 0 exactly when s > 0)."""
    return _finite3(x, y, z) and _squared3(x, y, z) > 0


@kernel(inline=True)
def _atan2_row(a0, a1, a2, b0, b1, b2, pair_valid, args, valid, k, i):
    """args[2k, i], args[2k + 1, i], valid[k, i] = |a x b|, a . b, valid (numpy's order:
    cross(a, b) = (a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0), sums left to right)."""
    c0 = a1 * b2 - a2 * b1
    c1 = a2 * b0 - a0 * b2
    c2 = a0 * b1 - a1 * b0
    args[2 * k, i] = _length3(c0, c1, c2)
    args[2 * k + 1, i] = (a0 * b0 + a1 * b1) + a2 * b2
    valid[k, i] = pair_valid


@kernel()
def agreement_texels(pixel, pixels, covered, contested, on_edge, ref, shading, geometric,
                     base, backfacing_dot, reasons, args, valid, flat, marked, backfacing,
                     counts):
    """Compiled twin of _agreement_numpy (ref, shading, geometric, base as (3, n) rows);
    returns the number of compared texels. Each vector's length and validity is taken once
    (the numpy code takes them per pair): the same booleans and floats."""
    width = pixels.shape[1]
    n = 0
    n_both = n_unit_all = n_away = n_truth_away = n_away_wrong = 0
    n_contested = n_unit = 0
    for i in range(pixel.shape[0]):
        x, y = pixel[i, 0], pixel[i, 1]
        backfacing[i] = False
        if not covered[y, x]:
            continue
        b0 = np.float64(pixels[y, x, 0])
        b1 = np.float64(pixels[y, x, 1])
        b2 = np.float64(pixels[y, x, 2])
        r0, r1, r2 = ref[0, i], ref[1, i], ref[2, i]
        g0, g1, g2 = geometric[0, i], geometric[1, i], geometric[2, i]
        n_both += 1
        b_finite = _finite3(b0, b1, b2)
        b_off = abs(_length3(b0, b1, b2) - 1)           # |length - 1| of the bake
        if b_finite and b_off < 1e-3:
            n_unit_all += 1
        away = (b0 * g0 + b1 * g1) + b2 * g2 < -1e-3
        truth_dot = (r0 * g0 + r1 * g1) + r2 * g2
        if away:
            n_away += 1
        if truth_dot < 0:
            n_truth_away += 1
        if away and not truth_dot < 1e-3:
            n_away_wrong += 1
        if on_edge[y, x] and not contested[y, x]:
            reasons[y, x] = 2                               # EDGE
            continue
        facing = (shading[0, i] * g0 + shading[1, i] * g1) + shading[2, i] * g2
        if facing < backfacing_dot:
            reasons[y, x] = 4                               # BACKFACING
            backfacing[i] = True
            continue
        marked[n] = contested[y, x]
        if marked[n]:
            reasons[y, x] = 1                               # CONTESTED
            n_contested += 1
        if b_finite and b_off < 1e-4:
            n_unit += 1
        s0, s1, s2 = base[0, i], base[1, i], base[2, i]
        b_ok = b_finite and _squared3(b0, b1, b2) > 0
        r_ok = _has_direction(r0, r1, r2)
        s_ok = _has_direction(s0, s1, s2)
        _atan2_row(b0, b1, b2, r0, r1, r2, b_ok and r_ok, args, valid, 0, n)
        _atan2_row(b0, b1, b2, s0, s1, s2, b_ok and s_ok, args, valid, 1, n)
        _atan2_row(r0, r1, r2, s0, s1, s2, r_ok and s_ok, args, valid, 2, n)
        flat[n] = y * width + x
        n += 1
    counts[0] += n
    counts[1] += n_contested
    counts[2] += n_unit
    counts[3] += n_both
    counts[4] += n_unit_all
    counts[5] += n_away
    counts[6] += n_truth_away
    counts[7] += n_away_wrong
    return n


def _load():
    """Load the kernel for the types compare uses (raster.load_compiled)."""
    pixel = np.zeros((1, 2), dtype=np.int64)
    image = np.zeros((1, 1), dtype=bool)
    rows = np.zeros((1, 3))
    texel_agreement(pixel, np.zeros((1, 1, 4), dtype=np.float32), image, image, image, rows,
                    rows, rows, rows, 1e-4, np.zeros((1, 1), dtype=np.int8))


compiled.LOADERS.append(_load)
