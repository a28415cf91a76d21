"""Texels compare leaves out for how the shading normal lies, and the warnings that name
them: backfacing (the normal faces away from its face, so Cycles shades the back side) and
grazing, where a view-dependent reference (the parallax march) is ill-conditioned in float32,
so that no float32 evaluation can follow it (reference/parallax_conditioning.py derives the
spread). Grazing texels are left out like backfacing ones, under their own reason.

The grazing bound is the float32 one compare already uses for world-projected coordinates
(scale_limits.TEXEL_FRACTION): a texel is left out where FLT_EPSILON of its shading normal,
amplified by the march's conditioning, moves the march's sample points by that fraction of a
texel of the images it reads.
"""

import numpy as np

from .no_area import faces_text
from .scale_limits import TEXEL_FRACTION

GRAZING = 6                         # texel_report.EXCLUSION_REASONS' code


def leave_out(agreement, block, spread, pixels, reasons):
    """Move the compared texels of `block` whose `spread` (N,) (texels) reaches TEXEL_FRACTION
    out of `agreement` (a texel_agreement result, compacted in place, its counts lowered) into
    reasons (H, W) as GRAZING; returns their triangles (an array, maybe empty)."""
    ill = np.asarray(spread) >= TEXEL_FRACTION
    if not ill.any():
        return ill[:0]
    width = pixels.shape[1]
    a, n = agreement, agreement.n
    ill_flat = block.pixel[ill, 1] * width + block.pixel[ill, 0]
    drop = np.isin(a.flat[:n], ill_flat)
    if not drop.any():
        return ill[:0]
    dropped = a.flat[:n][drop]
    y, x = np.divmod(dropped, width)
    reasons[y, x] = GRAZING
    b = pixels[y, x, :3].astype(np.float64)
    unit = np.isfinite(b).all(-1) & (np.abs(np.linalg.norm(b, axis=-1) - 1) < 1e-4)
    a.counts[0] -= len(dropped)                          # compared
    a.counts[1] -= int(a.marked[:n][drop].sum())         # contested
    a.counts[2] -= int(unit.sum())                       # finite_unit (of the compared)
    keep = ~drop
    k = n - len(dropped)
    a.args[:, :k] = a.args[:, :n][:, keep]
    a.valid[:, :k] = a.valid[:, :n][:, keep]
    a.flat[:k] = a.flat[:n][keep]
    a.marked[:k] = a.marked[:n][keep]
    a.n = k
    block_flat = block.pixel[:, 1] * width + block.pixel[:, 0]
    return np.unique(block.tri[np.isin(block_flat, dropped)])


def grazing_warning(mesh, report):
    """A warning naming the faces whose grazing texels were left out, or None."""
    tris = report.get("grazing_triangles") or []
    if not tris:
        return None
    return (f"{mesh.name!r}: {report['excluded']['grazing']} texels of {len(tris)} triangles "
            f"(faces {faces_text(mesh, tris)}) are not compared (grazing): their shading "
            f"normal nearly lies in the face's plane (normals facing both ways across "
            f"neighbouring faces), where the parallax march amplifies float32 rounding "
            f"beyond {TEXEL_FRACTION:g} texel. If that is not meant, recalculate the normals "
            f"(Mesh > Normals > Recalculate Outside).")


def backfacing_warning(mesh, report):
    """A warning naming the faces whose shading normals face away from them, or None."""
    tris = report.get("backfacing_triangles") or []
    if not tris:
        return None
    shown = faces_text(mesh, tris)
    return (f"{mesh.name!r}: {report['excluded']['backfacing']} texels of {len(tris)} "
            f"triangles (faces {shown}) are not compared (backfacing): their vertex or corner "
            f"normals face away from the face, so Cycles shades its back side there (normals "
            f"flipped). If that is not meant, recalculate the normals (Mesh > Normals > "
            f"Recalculate Outside) or fix the custom normals.")
