"""The bench's outputs: per-scenario and combined speed/accuracy charts (Pareto front drawn,
every point labelled), a Markdown table, raw JSON and per-method error heat maps."""

import json
import re
from pathlib import Path

import numpy as np

from ..compare import write_heat_map

COLORS = {"sg": "#1b9e77", "blender": "#7570b3", "baseline": "#d95f02"}
NAMES = {"sg": "surface gradient (ours)", "blender": "Blender built-in", "baseline": "baseline"}


def pareto(points):
    """Indices of the points no other point beats on both cost and error (lower is better)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], np.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def _slug(text):
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def _plot_scenario(ax, title, rows):
    import matplotlib.patheffects as pe
    pts = [(r["cost_ratio"], max(r["mean_deg"], 1e-4)) for r in rows]
    front = pareto(pts)
    fx, fy = zip(*sorted(pts[i] for i in front))
    ax.step(fx, fy, where="post", color="#999999", lw=1.2, zorder=1, label="Pareto front")
    for r, (x, y) in zip(rows, pts):
        on_front = pts.index((x, y)) in front
        ax.scatter(x, y, s=46 if on_front else 28, color=COLORS[r["family"]], zorder=3,
                   edgecolor="black" if on_front else "none", linewidth=0.8)
        ax.annotate(r["method"], (x, y), xytext=(4, 3), textcoords="offset points",
                    fontsize=6.5, path_effects=[pe.withStroke(linewidth=2, foreground="white")])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("bake cost (ratio to the cheapest method)", fontsize=8)
    ax.set_ylabel("mean angular error vs truth (deg)", fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)
    ax.grid(True, which="both", alpha=0.25)
    lo, hi = min(p[0] for p in pts), max(p[0] for p in pts)
    ax.set_xlim(lo / 1.15, hi * 1.8)


def write_charts(out, scenarios, results):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    legend = [Line2D([], [], marker="o", ls="", color=c, label=NAMES[f])
              for f, c in COLORS.items()] + \
        [Line2D([], [], color="#999999", label="Pareto front (ringed points)")]
    paths = []
    for sc in scenarios:
        rows = [r for r in results if r["scenario"] == sc.name]
        fig, ax = plt.subplots(figsize=(7, 4.6))
        _plot_scenario(ax, sc.title, rows)
        ax.legend(handles=legend, fontsize=7, loc="best")
        fig.tight_layout()
        path = out / f"chart_{sc.name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    cols = 3
    rows_n = -(-len(scenarios) // cols)
    fig, axes = plt.subplots(rows_n, cols, figsize=(6.2 * cols, 4.4 * rows_n), squeeze=False)
    for ax, sc in zip(axes.flat, scenarios):
        _plot_scenario(ax, sc.title, [r for r in results if r["scenario"] == sc.name])
    for ax in list(axes.flat)[len(scenarios):]:
        ax.axis("off")
    fig.legend(handles=legend, loc="lower right", fontsize=10, bbox_to_anchor=(0.98, 0.06))
    fig.suptitle("Speed against accuracy: every method baked with Cycles (CPU) on the same "
                 "mesh, error against the analytic truth", fontsize=12)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    combined = out / "chart_combined.png"
    fig.savefig(combined, dpi=80)
    plt.close(fig)
    return paths + [combined]


def markdown_table(results, scenarios, settings):
    lines = ["# Speed against accuracy", "",
             f"Cycles CPU bakes at {settings['resolution']}^2, bake time the median of "
             f"{settings['repeats']} interleaved repeats, reported as a ratio to the scenario's "
             f"cheapest method. Error: angle to the analytic truth over interior texels. "
             f"Reference/bake: the numpy reference's time for the same texels over the bake's.",
             ""]
    for sc in scenarios:
        rows = [r for r in results if r["scenario"] == sc.name]
        front = set(pareto([(r["cost_ratio"], r["mean_deg"]) for r in rows]))
        lines += [f"## {sc.title}", "",
                  "| method | kind | cost | bake s | mean deg | p95 deg | max deg | facing away | "
                  "reference/bake | note |", "|---|---|---|---|---|---|---|---|---|---|"]
        for i, r in enumerate(rows):
            rb = f"{r['reference_to_bake']:.2f}" if r["reference_to_bake"] else ""
            mark = " **(Pareto)**" if i in front else ""
            lines.append(f"| {r['method']}{mark} | {r['family']} | {r['cost_ratio']:.2f} | "
                         f"{r['bake_seconds_median']:.3f} | {r['mean_deg']:.3f} | "
                         f"{r['p95_deg']:.3f} | {r['max_deg']:.2f} | "
                         f"{100 * r['facing_away_fraction']:.2f}% | {rb} | {r['memory_note']} |")
        lines.append("")
    return "\n".join(lines) + "\n"


def write_all(out, scenarios, results, heat, settings, stability=None):
    out = Path(out)
    (out / "heat").mkdir(parents=True, exist_ok=True)
    for (scenario, label), img in heat.items():
        write_heat_map(out / "heat" / f"{scenario}_{_slug(label)}.png", img, overwrite=True)
    charts = write_charts(out, scenarios, results)
    md = markdown_table(results, scenarios, settings)
    if stability is not None:
        md += stability
    (out / "bench.md").write_text(md)
    (out / "bench.json").write_text(json.dumps({"settings": settings, "results": results},
                                               indent=2))
    return charts
