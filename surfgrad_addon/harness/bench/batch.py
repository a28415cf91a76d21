"""Scale figures of bake-batch (python -m surfgrad_addon bench-batch): a benchmark that writes
JSON, never a timed test.

1. N small procedural assets (one object, UVs in two UDIM tiles, an SG material) baked at R^2
   with 1 and 2 worker processes: wall time, assets and tiles per second, their ratio.
2. Per-asset overhead: a worker's process start (Python + bpy import) and file load against
   the bake and save, from the manifest's timings; and the whole cost of one farm task (a
   fresh process baking one asset, as OpenJD / Flamenco tasks do) against its bake.
3. Bake time against size (512^2 .. 2048^2, one asset, 1 sample; and 4 samples at 1024^2),
   fitted as a + b texels, to compute what a 16-worker farm would do with 500 assets x 2 tiles
   at 4096^2.
The machine's load average is recorded before and after: other work on it slows the figures.
"""

import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from .. import batch_assets


def _median(values):
    values = sorted(values)
    n = len(values)
    return (values[n // 2] + values[(n - 1) // 2]) / 2 if n else None


def _fresh_task(blend, out_dir, resolution):
    """One farm-like task: a new process bakes one asset; returns (wall s, bake s, load s)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[3])
    manifest = out_dir / "task_manifest.json"
    manifest.unlink(missing_ok=True)
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "surfgrad_addon", "bake-batch", str(blend),
                          "--output", str(out_dir / "{file}.<UDIM>.png"), "--resolution",
                          str(resolution), "--workers", "0", "--force", "--overwrite",
                          "--manifest", str(manifest)],
                         env=env, capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t0
    if res.returncode:
        raise RuntimeError(f"the farm-like task failed: {res.stderr[-2000:]}")
    data = json.loads(manifest.read_text())
    (entry,) = data["assets"].values()
    (f,) = data["files"].values()
    return wall, entry["attempts"][-1]["bake_s"], f.get("load_s") or 0.0


def run(out="out/bench_batch", assets=50, resolution=512, workers=(1, 2), overwrite=False,
        log=print, thread_modes=("shared", "one")):
    import bpy
    from ...addon import batch, normal_bake

    out = Path(out)
    report_path = out / "bench_batch.json"
    if report_path.exists() and not overwrite:
        raise FileExistsError(f"{report_path} exists; pass --overwrite to replace it")
    if assets < 1 or resolution < 4:
        raise ValueError("give at least 1 asset and a resolution of 4 or more")
    out.mkdir(parents=True, exist_ok=True)
    load_before = os.getloadavg()
    log(f"[1/4] writing {assets} procedural assets (2 UDIM tiles each)")
    asset_dir = out / "assets"
    shutil.rmtree(asset_dir, ignore_errors=True)
    blends = batch_assets.write_assets(asset_dir, assets)

    # "shared": Cycles' threads are every core, shared out between the workers (the default);
    # "one": one thread per worker, so the workers' scaling shows apart from Cycles' own.
    runs = {}
    for mode in thread_modes:
        for w in workers:
            threads = None if mode == "shared" else 1
            log(f"[2/4] baking {assets} assets x 2 tiles at {resolution}^2 with {w} worker(s), "
                f"threads {mode}")
            maps = out / f"maps_{mode}_w{w}"
            shutil.rmtree(maps, ignore_errors=True)
            t0 = time.perf_counter()
            rep = batch.bake_batch([str(b) for b in blends], str(maps / "{file}.<UDIM>.png"),
                                   defaults={"resolution": resolution}, workers=w, force=True,
                                   manifest=str(maps / "manifest.json"), threads=threads,
                                   log=lambda line: log("      " + line)
                                   if line.startswith("[batch]") else None)
            wall = time.perf_counter() - t0
            baked = [a for a in rep["assets"].values() if a.get("status") == "baked"]
            if len(baked) != assets:
                raise RuntimeError(f"{assets - len(baked)} asset(s) failed with {w} worker(s)")
            t = [a["timings"] for a in baked]
            man = json.loads((maps / "manifest.json").read_text())
            loads = [f["load_s"] for f in man["files"].values() if f.get("load_s") is not None]
            runs[f"{mode}_w{w}"] = {
                "workers": w, "threads": mode, "load_average_at_start": os.getloadavg(),
                "wall_s": wall, "assets_per_s": assets / wall, "tiles_per_s": 2 * assets / wall,
                "process_start_s": rep.get("process_start_s", []),
                "median_file_load_s": _median(loads),
                "cycles_threads_per_worker": threads or
                (max(1, (os.cpu_count() or 1) // w) if w > 1 else "all"),
                "median_bake_s": _median([x["bake_s"] for x in t]),
                "median_save_s": _median([x["save_s"] for x in t]),
                "median_asset_total_s": _median([x["total_s"] for x in t]),
                "sum_bake_s": sum(x["bake_s"] for x in t),
                "sum_asset_total_s": sum(x["total_s"] for x in t),
                "median_asset_cpu_s": _median([x["cpu_s"] for x in t]),
                # CPU cores this run had, on average, while it baked (other work on a shared
                # machine takes the rest)
                "cores_used": sum(x["cpu_s"] for x in t) / wall}
            log(f"      {wall:.1f} s: {assets / wall:.2f} assets/s")
        base = runs[f"{mode}_w{workers[0]}"]
        for w in workers:
            r = runs[f"{mode}_w{w}"]
            r["speedup_vs_first"] = base["wall_s"] / r["wall_s"]

    log("[3/4] farm-like tasks: a fresh process per asset (3 runs)")
    task_dir = out / "task"
    task_dir.mkdir(exist_ok=True)
    tasks = [_fresh_task(blends[i], task_dir, resolution) for i in range(3)]
    task = {"median_wall_s": _median([x[0] for x in tasks]),
            "median_bake_s": _median([x[1] for x in tasks]),
            "median_load_s": _median([x[2] for x in tasks])}
    task["overhead_s"] = task["median_wall_s"] - task["median_bake_s"]

    log("[4/4] bake time against size (one asset, 2 tiles)")
    from ...addon.open_blend import open_mainfile
    open_mainfile(blends[0])
    obj = bpy.data.objects["Asset000"]
    sizes = {}
    for size, samples in ((512, 1), (1024, 1), (2048, 1), (1024, 4)):
        target = out / "size" / f"s{size}_{samples}.<UDIM>.png"
        target.parent.mkdir(exist_ok=True)
        best = math.inf
        for _ in range(2):
            r = normal_bake.bake_normal_tiles(obj, target, resolution=size, samples=samples,
                                              overwrite=True, log=lambda *_: None)
            best = min(best, r["bake_s"] + r["save_s"])
        sizes[f"{size}x{samples}"] = best
        log(f"      {size}^2, {samples} sample(s): {best:.2f} s (bake + save, 2 tiles)")
    # a + b * texels through 512^2 and 2048^2 (1 sample), per tile
    t512, t2048 = sizes["512x1"] / 2, sizes["2048x1"] / 2
    b = (t2048 - t512) / (2048 ** 2 - 512 ** 2)
    a = max(t512 - b * 512 ** 2, 0.0)
    per_sample_1024 = (sizes["1024x4"] - sizes["1024x1"]) / 2 / 3   # per tile, per extra sample

    # 16 workers, 500 assets x 2 tiles at 4096^2, one task per asset x tile.
    n_tasks, farm_workers = 1000, 16
    tile_4k_1 = a + b * 4096 ** 2
    tile_4k_16 = tile_4k_1 + 15 * per_sample_1024 * 16          # texels x16 from 1024^2
    task_cost = {s: task["overhead_s"] + t for s, t in (("1", tile_4k_1), ("16", tile_4k_16))}
    rounds = math.ceil(n_tasks / farm_workers)
    farm = {"tasks": n_tasks, "workers": farm_workers, "rounds": rounds,
            "tile_4096_bake_s": {"1": tile_4k_1, "16": tile_4k_16},
            "task_s": task_cost,
            "farm_hours": {s: rounds * c / 3600 for s, c in task_cost.items()},
            "one_machine_hours": {s: n_tasks * c / 3600 for s, c in task_cost.items()},
            "overhead_share": {s: task["overhead_s"] / c for s, c in task_cost.items()}}

    report = {
        "blender": bpy.app.version_string, "cpus": os.cpu_count(),
        "load_average_before": load_before, "load_average_after": os.getloadavg(),
        "assets": assets, "tiles_per_asset": 2, "resolution": resolution, "samples": 1,
        "runs": runs,
        "farm_like_task": task,
        "size_s": sizes, "fit_per_tile": {"a_s": a, "b_s_per_texel": b,
                                          "per_extra_sample_at_1024_s": per_sample_1024},
        "farm_estimate": farm,
        "note": "Wall-clock figures on a shared machine: compare ratios within this run.",
    }
    report_path.write_text(json.dumps(report, indent=1))
    for name, r in runs.items():
        log(f"{name}: {r['wall_s']:.1f} s, {r['assets_per_s']:.2f} assets/s, "
            f"x{r['speedup_vs_first']:.2f}; per asset: load {r['median_file_load_s']:.2f} s, "
            f"bake {r['median_bake_s']:.2f} s, save {r['median_save_s']:.2f} s, "
            f"CPU {r['median_asset_cpu_s']:.2f} s; {r['cores_used']:.2f} cores used")
    log(f"farm-like task: {task['median_wall_s']:.2f} s of which bake "
        f"{task['median_bake_s']:.2f} s (overhead {task['overhead_s']:.2f} s)")
    log(f"16-worker farm, 500 assets x 2 tiles at 4096^2: {farm['farm_hours']['1']:.2f} h at 1 "
        f"sample, {farm['farm_hours']['16']:.2f} h at 16 samples; wrote {report_path}")
    return report
