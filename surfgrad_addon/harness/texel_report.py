"""compare's figures for one baked image: every texel classified and measured against the
reference, and the report over the tiles (harness/compare.py bakes; this measures).

The reference and the statistics of a block run together on the block threads
(reference.methods.evaluated_blocks): a block is evaluated, classified and its angles taken
in one task, so both cores work through the whole pass instead of the statistics waiting,
alone on one core, for each window of reference blocks. The per-block sums are added in
block order, so every figure is the float it was when the statistics ran after the window.
"""

import time

import numpy as np

from ..reference import methods as M
from . import facing_exclusions as G
from ..reference.agreement import COUNTS as AGREEMENT_COUNTS, texel_agreement

# Why a covered texel is not compared (codes in ErrorImage.reasons, keys in the report's
# "excluded"). Code 1 marks contested texels (overlapping UV islands): they ARE compared,
# since the reference gives each to the triangle the bake gives it (the last in mesh order),
# and are counted in "texels_contested", with their own error in "contested_max_deg".
CONTESTED = 1
EXCLUSION_REASONS = {
    2: ("edge", "within float32 rounding of a triangle edge: Blender's float32 scan "
                "conversion decides the side, and on an island border Cycles moves a sample it "
                "finds outside its triangle by a hashed jitter (bake_jitter_barycentric)"),
    3: ("outside", "covered by the bake or by the reference but not by both"),
    4: ("backfacing", "the shading normal (the interpolated vertex or corner normals) faces "
                      "away from its triangle (or within rounding of it): a bake's ray comes "
                      "in along -N (integrator/init_from_bake.h), so Cycles finds the back "
                      "face and flips N, Ng, dPdu and dPdv there (geom/shader_data.h), and "
                      "every node shades the back side; the references model the front side"),
    6: ("grazing", "a view-dependent method (parallax) where the shading normal nearly lies in "
                   "its face: Listing 11's solve is conditioned by dot(shading, geometric), so "
                   "float32 rounding of the normal moves the march's samples by a texel "
                   "fraction no float32 route avoids (reference/parallax_conditioning.py); "
                   "only methods with a spread report it"),
}
# dot(shading normal, geometric normal) below this is "backfacing": the bake's float32 sign
# test can go either way within the rounding of the (packed) stored normals.
BACKFACING_DOT = 1e-4
OUTSIDE = 3


class ErrorImage(np.ndarray):
    """The per-texel error (H, W) in degrees, NaN where not compared, with `reasons` (H, W):
    the EXCLUSION_REASONS code of an excluded texel, CONTESTED for a compared contested one,
    else 0."""

    def __new__(cls, error, reasons):
        obj = np.asarray(error, dtype=np.float64).view(cls)
        obj.reasons = np.asarray(reasons, dtype=np.int8)
        return obj

    def __array_finalize__(self, obj):
        self.reasons = getattr(obj, "reasons", None)


def compare_tile(td, reference, pixels, covered, spread=None):
    """One image's comparison, block by block (reference/raster.py: the reference's working
    memory and the comparison's are one block's; the errors and the error image are whole):
    the report fields, its ErrorImage and the seconds the reference took (the block pass's
    wall time times the reference's share of the block threads' time). spread(block) -> (N,)
    (a view-dependent method's, texels): its texels past harness/facing_exclusions' bound are left
    out as "grazing" (a reason only such methods report)."""
    h, w = covered.shape
    reasons = np.zeros((h, w), dtype=np.int8)
    reasons[covered ^ td.covered] = OUTSIDE
    heat = np.full((h, w), np.nan)
    heat_flat = heat.reshape(-1)                # a view: blocks write their own texels

    def measure(block):
        """reference(block), then its texels classified and measured (a block thread)."""
        t0 = time.perf_counter()
        ref = reference(block)
        t1 = time.perf_counter()
        a = texel_agreement(block.pixel, pixels, covered, td.contested, td.on_edge, ref,
                            block.shading_normal, block.geometric_normal,
                            M.unit_base_normal(block), BACKFACING_DOT, reasons)
        grazing = () if spread is None else G.leave_out(a, block, spread(block), pixels,
                                                         reasons)
        err = a.error()
        heat_flat[a.flat[:a.n]] = err           # blocks hold distinct texels
        tilt_bake, tilt_ref = a.tilts()
        backfacing = np.unique(block.tri[a.backfacing]) if a.backfacing.any() else ()
        return (err, err[a.marked[:a.n]], (backfacing, grazing), float(tilt_bake.sum()),
                float(tilt_ref.sum()), a.counts, t1 - t0, time.perf_counter() - t1)

    errs = np.empty(td.texel_count)            # the compared texels' errors, block after block
    n_errs = 0
    contested_errs = []
    sums = dict.fromkeys(("tilt_bake", "tilt_ref", *AGREEMENT_COUNTS), 0)
    sums["backfacing_triangles"] = set()
    sums["grazing_triangles"] = set()
    wall, thread_seconds = [0.0], [0.0, 0.0]
    for _, _, _, (err, contested, (backfacing, grazing), tilt_bake, tilt_ref, counts, ref_s,
                  stat_s) in M.evaluated_blocks(measure, td, seconds=wall):
        errs[n_errs:n_errs + len(err)] = err
        n_errs += len(err)
        contested_errs.append(contested)
        sums["backfacing_triangles"].update(int(t) for t in backfacing)
        sums["grazing_triangles"].update(int(t) for t in grazing)
        sums["tilt_bake"] += tilt_bake
        sums["tilt_ref"] += tilt_ref
        for name, count in zip(AGREEMENT_COUNTS, counts.tolist()):
            sums[name] += count
        thread_seconds[0] += ref_s
        thread_seconds[1] += stat_s
    contested_err = np.concatenate(contested_errs) if contested_errs else np.zeros(0)
    # One comparison per reason (a 4096^2 image: 5 ms each; np.bincount took 0.1 s).
    excluded = {name: int(np.count_nonzero(reasons == code))
                for code, (name, _) in EXCLUSION_REASONS.items()
                if code != G.GRAZING or spread is not None}
    busy = sum(thread_seconds)
    r = {
        "texels_covered": int(np.count_nonzero(covered | td.covered)),
        "texels_compared": sums["compared"],
        "texels_contested": sums["contested"],
        "excluded": excluded,
        "contested_max_deg": float(contested_err.max()) if len(contested_err) else None,
        "_err": errs[:n_errs], "_sums": sums,
    }
    return r, ErrorImage(heat, reasons), wall[0] * (thread_seconds[0] / busy if busy else 1.0)


def error_stats(err):
    """mean, p99 and max of the errors (None when there are none). The percentile partitions
    err in place (no copy of a whole image's errors): pass an array nothing reads after."""
    if len(err) == 0:
        return {"mean_deg": None, "p99_deg": None, "max_deg": None}
    mean, top = float(err.mean()), float(err.max())       # before the partition reorders err
    return {"mean_deg": mean, "p99_deg": float(np.percentile(err, 99, overwrite_input=True)),
            "max_deg": top}


def merge(tile_reports):
    """The report over every tile (per-tile figures stay in each tile's dict)."""
    err = (tile_reports[0]["_err"] if len(tile_reports) == 1 else
           np.concatenate([t["_err"] for t in tile_reports]))
    backfacing = set().union(*(t["_sums"].pop("backfacing_triangles") for t in tile_reports))
    grazing = set().union(*(t["_sums"].pop("grazing_triangles") for t in tile_reports))
    sums = {k: sum(t["_sums"][k] for t in tile_reports) for k in tile_reports[0]["_sums"]}
    covered = sum(t["texels_covered"] for t in tile_reports)
    compared = sums["compared"]
    contested = sum(t["texels_contested"] for t in tile_reports)
    excluded = {k: sum(t["excluded"][k] for t in tile_reports)
                for k in tile_reports[0]["excluded"]}
    cmax = [t["contested_max_deg"] for t in tile_reports if t["contested_max_deg"] is not None]
    n_excl = sum(excluded.values())
    both = sums["both"]
    report = {
        "finite_unit_fraction_all": sums["finite_unit_all"] / both if both else 0.0,
        "facing_away_fraction": sums["away"] / both if both else 0.0,
        "truth_facing_away_fraction": sums["truth_away"] / both if both else 0.0,
        "faces_away_where_truth_does_not": int(sums["away_wrong"]),
        "tilt_mean_deg": sums["tilt_ref"] / compared if compared else None,
        "bake_tilt_mean_deg": sums["tilt_bake"] / compared if compared else None,
        "texels_covered": covered, "texels_compared": compared,
        "texels_contested": contested,
        "texels_excluded": n_excl, "excluded": excluded,
        "backfacing_triangles": sorted(int(t) for t in backfacing),
        **({"grazing_triangles": sorted(grazing)} if "grazing" in excluded else {}),
        "excluded_fraction": n_excl / max(1, covered),
        **error_stats(err),
        "contested_max_deg": max(cmax) if cmax else None,
        "finite_unit_fraction": sums["finite_unit"] / compared if compared else 0.0,
    }
    for t in tile_reports:
        # One tile: its errors are the report's (no second pass over them).
        err = t.pop("_err")
        t.update(error_stats(err) if len(tile_reports) > 1 else
                 {k: report[k] for k in ("mean_deg", "p99_deg", "max_deg")})
        del t["_sums"]
    return report


# Below this many compared texels a compare says little of the surface: its p99 is their
# max, and a mistake that shows on part of the surface only (a triplanar plane's axes
# swapped: p99 0.0095 on the 9 texels of a 0.05-wide island at 64^2, 0.79 on its 144 at
# 256^2) can miss every one of them (red team 59b).
SPARSE_TEXELS = 100


def sparse_warning(name, compared, resolution, largest):
    """None, or the warning that only `compared` texels of object `name` were compared at
    resolution^2, with the resolution (a power of two, at most `largest`) that would give
    about SPARSE_TEXELS (texels grow with its square)."""
    if compared >= SPARSE_TEXELS:
        return None
    wanted = resolution * np.sqrt(SPARSE_TEXELS / max(int(compared), 1))
    needed = int(min(largest, 2 ** int(np.ceil(np.log2(wanted)))))
    more = (f"compare again at --resolution {needed}" if needed > resolution else
            "its UV islands are too small for any resolution compare takes: scale them up "
            "in UV space for the compare")
    return (f"only {compared} texel(s) of {name!r} were compared at {resolution}^2: too few "
            f"to judge the method on its surface, where a mistake on its other parts goes "
            f"unseen; {more}")
