"""`python -m surfgrad_addon bench --out DIR [--quick]`: all scenarios, then the report."""

import time
from pathlib import Path

from . import report, runner, scenarios as S

DEFAULTS = {"resolution": 256, "repeats": 5}
QUICK = {"resolution": 64, "repeats": 2}


def run(out_dir, quick=False, resolution=None, repeats=None, only=None, overwrite=False,
        log=print):
    out = Path(out_dir)
    names = [sc.name for sc in S.SCENARIOS]
    unknown = [n for n in only or () if n not in names]
    if unknown:                     # before any work: a typo used to end in matplotlib's error
        raise ValueError(f"no bench scenario {unknown[0]!r}; --only takes some of "
                         f"{', '.join(names)}")
    for option, value in (("--resolution", resolution), ("--repeats", repeats)):
        if value is not None and value < 1:
            raise ValueError(f"{option} must be at least 1, not {value}")
    if (out / "bench.json").exists() and not overwrite:
        raise FileExistsError(f"{out / 'bench.json'} exists; pass --overwrite to replace it")
    out.mkdir(parents=True, exist_ok=True)
    settings = dict(QUICK if quick else DEFAULTS)
    if resolution is not None:
        settings["resolution"] = resolution
    if repeats is not None:
        settings["repeats"] = repeats
    settings["quick"] = quick
    chosen = [sc for sc in S.SCENARIOS if not only or sc.name in only]
    results, heat = [], {}
    t0 = time.perf_counter()
    for i, sc in enumerate(chosen):
        log(f"[{i + 1}/{len(chosen)}] {sc.title} ({settings['resolution']}^2, "
            f"{settings['repeats']} repeats)")
        rows, maps = runner.run_scenario(sc, settings["resolution"], settings["repeats"], quick,
                                         log)
        results += rows
        heat.update({(sc.name, label): img for label, img in maps.items()})
        for r in rows:
            log(f"    {r['method']:38s} cost {r['cost_ratio']:5.2f}  mean {r['mean_deg']:7.3f}"
                f"  p95 {r['p95_deg']:7.3f}  max {r['max_deg']:7.2f} deg")
    from . import displacement
    log("Gustavson's displacement: convergence and bump against true displacement")
    disp, disp_md = displacement.run(out, quick, log)
    (out / "displacement.json").write_text(__import__("json").dumps(disp, indent=2))
    from . import stability
    log("stability suite")
    stab = stability.run(quick, log)
    stability_md = disp_md + "\n" + stability.markdown(stab)
    (out / "stability.json").write_text(__import__("json").dumps(stab, indent=2))
    settings["seconds"] = time.perf_counter() - t0
    charts = report.write_all(out, chosen, results, heat, settings, stability_md)
    log(f"wrote {out}/bench.md, bench.json, displacement.json, stability.json, "
        f"{len(charts) + 1} charts and "
        f"{len(heat)} heat maps in {settings['seconds']:.0f} s")
    return results
