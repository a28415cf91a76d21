"""The main job's report page, out/demo/index.html: what was proven and how (the compare table
with its pass marks), heat maps on one shared scale, the speed-accuracy chart, the exhibits and
the render cost, each with one sentence on what it shows and links to the JSON it came from.

    write_report_page("out/demo")        # after compare-all (and the quick bench) wrote there

Self-contained: one HTML file with its stylesheet inlined, no script, no network; pictures are
relative links (this run's under out_dir, the committed ones under the repository's docs/).
What a run did not produce is shown with the command that produces it; a malformed JSON is an
error (report.inputs.ReportInputError, a ValueError) naming the file.
"""

import datetime
import os
import platform
import sys
from html import escape
from pathlib import Path

from .report import heat as H
from .report.costs import cost_section
from .report.inputs import ReportInputError, load_json
from .report.sections import (exhibits_section, heat_section, link, proof_section,
                              speed_section)
from .report.style import CSS

ROOT = Path(__file__).resolve().parents[2]
PAGE = "index.html"
SHARED_HEAT = Path("report") / "heat"         # under out_dir: the shared-scale heat maps

__all__ = ["write_report_page", "ReportInputError"]


def _commands(out):
    return {"compare": f"python -m surfgrad_addon compare-all --out {out}/compare "
                       f"(or bash run.sh main)",
            "bench": f"python -m surfgrad_addon bench --quick --out {out}/bench",
            "exhibits": "python -m surfgrad_addon demo-blend --out demo.blend "
                        "--pictures docs/exhibits",
            "cost": "bash run.sh bench-render, then copy out/bench_render/render_cost.json "
                    "into docs/"}


def _reason_names():
    from .compare import CONTESTED, EXCLUSION_REASONS
    names = {CONTESTED: "contested: overlapping UV islands (error in the table)"}
    from .heat_map import HEAT_ALIASES
    for code, (name, _) in EXCLUSION_REASONS.items():
        shown = HEAT_ALIASES.get(code, code)          # drawn in another reason's colour
        names[shown] = f"{names[shown]}, {name}" if shown in names else f"excluded: {name}"
    return names


def _machine():
    bpy = sys.modules.get("bpy")        # the Blender this process runs, if it has one
    blender = f"; Blender {bpy.app.version_string}" if bpy is not None else ""
    return (f"{os.cpu_count()} CPUs, {platform.system()} {platform.machine()}, Python "
            f"{platform.python_version()}{blender}")


def write_report_page(out_dir, repo_root=None, job_seconds=None, overwrite=False, log=print,
                      shown_as=None):
    """Write out_dir/index.html from what out_dir holds (compare/compare.json and its heat
    maps, bench/bench.json and its chart, pictures/ if this run rendered any) and the
    committed figures under repo_root/docs (default: this checkout's); returns the page's path.
    job_seconds: the main job's time, shown in the header when given. Refuses to replace an
    existing page unless overwrite. shown_as: the folder named in the page's commands (where
    out_dir will be moved; default out_dir)."""
    from .bench.far import BAR
    out = Path(out_dir)
    repo_root = Path(repo_root) if repo_root is not None else ROOT
    page = out / PAGE
    if page.exists() and not overwrite:
        raise FileExistsError(f"{page} exists; pass --overwrite to replace it")
    out.mkdir(parents=True, exist_ok=True)
    commands = _commands(out_dir if shown_as is None else shown_as)
    docs = repo_root / "docs"
    paths = {"compare_json": out / "compare" / "compare.json",
             "compare_md": out / "compare" / "compare.md",
             "bench_json": out / "bench" / "bench.json",
             "bench_chart": out / "bench" / "chart_combined.png"}
    reports = load_json(paths["compare_json"], "compare-all's table")
    bench = load_json(paths["bench_json"], "the bench's results")
    proof = proof_section(reports, BAR, out, paths, H.case_label, commands["compare"])
    heat = None
    if reports is not None and (out / "compare" / "heat").is_dir():
        shared, legend, colours = H.write_shared_heat_maps(
            reports, out / "compare" / "heat", out / SHARED_HEAT, BAR["max_deg"])
        heat = {"paths": shared, "legend": legend, "colours": colours,
                "names": _reason_names(), "over": H.OVER_BAR, "position": H.scale_position}
    this_run = out / "pictures"
    run_pictures = this_run.is_dir() and any(this_run.glob("*.png"))
    cost, cost_files = cost_section(docs, out, repo_root, commands["cost"])
    sections = [
        proof,
        heat_section(reports, BAR, out, heat, H.case_label, commands["compare"]),
        speed_section(bench, out, paths, docs / "bench_combined.png", repo_root,
                      commands["bench"]),
        exhibits_section(this_run if run_pictures else docs / "exhibits", out, repo_root,
                         run_pictures, commands["exhibits"]),
        cost,
    ]
    read = [p for p in (paths["compare_json"], paths["bench_json"]) if p.is_file()] + cost_files
    also = [out / n for n in ALSO if (out / n).exists()]
    page.write_text(_page(sections, read, also, out, job_seconds))
    log(f"wrote {page}")
    return page


# The run's other outputs, linked from the footer when they are there.
ALSO = ("summary.md", "summary.json", "overview.png", "compare/compare.md", "bench/bench.md",
        "demo.blend")
NAV = (("proof", "Proof"), ("heat", "Heat maps"), ("speed", "Speed and accuracy"),
       ("exhibits", "Exhibits"), ("cost", "Render cost"))


def _page(sections, read, also, out, job_seconds):
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    took = f"; the main job took {job_seconds:.0f} s" if job_seconds is not None else ""
    nav = "".join(f'<a href="#{a}">{escape(t)}</a>' for a, t in NAV)
    files = ", ".join(link(p, out) for p in read) or "none"
    others = ", ".join(link(p, out, p.relative_to(out).as_posix()) for p in also)
    others = f"<br>Also written by this run: {others}." if others else ""
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>surfgrad: what this run proved</title>
<style>{CSS}</style>
</head>
<body>
<header>
<h1>surfgrad: what this run proved</h1>
<p class="meta">Surface-gradient bump mapping as Blender node groups, checked against a numpy
reference. Written {escape(now)} on {escape(_machine())}{escape(took)}.</p>
<nav>{nav}</nav>
</header>
<main>
{"".join(sections)}
</main>
<footer>The JSON this page was built from: {files}.{others}</footer>
</body>
</html>
"""
