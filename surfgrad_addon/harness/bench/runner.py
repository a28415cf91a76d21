"""Run the bench: every method of every scenario baked on the same mesh at the same
resolution, timed by the median of interleaved repeats, scored against the analytic truth."""

import statistics
import time

import numpy as np

from ... import reference as R
from .. import bake as B
from ..compare import angle_deg
from ..mesh_data import mesh_arrays_from_object
from ...reference import methods as M
from ..graph import Graph


def error_stats(err):
    return {"mean_deg": float(np.mean(err)), "p95_deg": float(np.percentile(err, 95)),
            "max_deg": float(np.max(err))}


def run_scenario(scenario, resolution, repeats, quick, log=print):
    """Returns (results per method, heat maps per method {label: (H, W) error image})."""
    import bpy
    ctx = scenario.setup(quick)
    ctx.params["resolution"] = resolution
    try:
        methods = scenario.methods(ctx)
        # Geometry, texels and truth per object, computed once.
        objs = {}
        for name, obj in ctx.objects.items():
            td = R.rasterize(mesh_arrays_from_object(obj), ctx.uv_map, resolution, resolution,
                             facts=B.running_line(), as_baked=True)
            objs[name] = (obj, td, td.interior(), scenario.truth(ctx, td),
                          M.unit_base_normal(td))
        times = {m.label: [] for m in methods}
        pixels = {}
        for rep in range(repeats):
            # Interleaved: one bake of each method per round, so drift hits all alike.
            for m in methods:
                total = 0.0
                for name, (obj, td, *_rest) in objs.items():
                    px, cov, seconds = B.bake_vector(
                        obj, lambda nodes, links, m=m: m.build(Graph(nodes, links), ctx),
                        resolution, resolution, uv_map=ctx.uv_map)
                    total += seconds
                    if rep == 0:
                        pixels[(m.label, name)] = (px, cov)
                times[m.label].append(total)
            log(f"  [{scenario.name}] round {rep + 1}/{repeats} done")
        results, heat = [], {}
        for m in methods:
            errs, away = [], []
            heat_img = None
            ref_seconds = None
            for name, (obj, td, interior, truth, base) in objs.items():
                px, cov = pixels[(m.label, name)]
                baked = px[td.pixel[:, 1], td.pixel[:, 0]].astype(np.float64)
                ok = interior & cov[td.pixel[:, 1], td.pixel[:, 0]]
                e = angle_deg(baked[ok], truth[ok])
                errs.append(e)
                away.append(np.sum(baked[ok] * td.geometric_normal[ok], axis=-1) <= 0)
                if heat_img is None:
                    heat_img = np.full((resolution, resolution), np.nan)
                    heat_img[td.pixel[ok, 1], td.pixel[ok, 0]] = e
                if m.reference is not None:
                    t0 = time.perf_counter()
                    m.reference(ctx, td)
                    ref_seconds = (ref_seconds or 0.0) + time.perf_counter() - t0
            err = np.concatenate(errs)
            bake_median = statistics.median(times[m.label])
            results.append({
                "scenario": scenario.name, "method": m.label, "family": m.family,
                "bake_seconds_median": bake_median, "bake_seconds_all": times[m.label],
                "reference_seconds": ref_seconds,
                "reference_to_bake": (ref_seconds / bake_median) if ref_seconds else None,
                "texels": int(err.size), "facing_away_fraction": float(np.mean(np.concatenate(away))),
                "memory_note": m.memory_note, **error_stats(err)})
            heat[m.label] = heat_img
        cheapest = min(r["bake_seconds_median"] for r in results)
        for r in results:
            r["cost_ratio"] = r["bake_seconds_median"] / cheapest
        return results, heat
    finally:
        for block in ctx.cleanup:
            try:
                if isinstance(block, bpy.types.Image):
                    bpy.data.images.remove(block)
                elif isinstance(block, bpy.types.Object):
                    bpy.data.objects.remove(block)
            except ReferenceError:
                pass
