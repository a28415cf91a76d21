"""The report page's render-cost section: the committed render-cost and slow-bench JSON files
(docs/render_cost*.json, docs/bench_*.json), each as a small table labelled with its date and
machine."""

from html import escape
from pathlib import Path

from .inputs import json_provenance, load_json, need, png_provenance
from .sections import figure, link, missing, provenance_text, section


def _num(value, digits=2, suffix=""):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return "" if value is None else escape(str(value))
    return f"{value:.{digits}f}{suffix}"


def _table(head, rows):
    th = "".join(f"<th>{escape(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def render_cost_table(data, path):
    """bench-render's JSON: each material's render time against Blender's own nodes."""
    rows = []
    for k, r in enumerate(need(data, path, "rows")):
        label = need(data, path, "rows", k, "label")
        target = r.get("target")
        met = "" if target is None or "ratio" not in r else \
            ("met" if r["ratio"] <= target else "missed")
        rows.append([escape(label), _num(r.get("seconds")), _num(r.get("ratio"), 2, "x"),
                     "" if target is None else f"&le; {target:.2f}x {met}"])
    head = (f"Cycles CPU {data.get('size')} x {data.get('size')}, {data.get('samples')} samples,"
            f" median of {data.get('repeats')} rounds" + (" (quick)" if data.get("quick") else ""))
    return (f"<p>{escape(head)}</p>"
            + _table(["material", "render s", "ratio to Blender's own", "target"], rows))


def bench_batch_table(data, path):
    rows = [[escape(name), _num(r.get("workers"), 0), escape(str(r.get("threads", ""))),
             _num(r.get("wall_s"), 1), _num(r.get("assets_per_s")),
             _num(r.get("speedup_vs_first"), 2, "x")]
            for name, r in need(data, path, "runs").items()]
    head = (f"{data.get('assets')} assets of {data.get('tiles_per_asset')} tiles at "
            f"{data.get('resolution')}^2, {data.get('samples')} sample(s)")
    return f"<p>{escape(head)}</p>" + _table(
        ["run", "workers", "threads", "wall s", "assets per s", "speed-up"], rows)


def bench_compare_table(data, path):
    rows = [[escape(size), _num(s.get("compare_over_bake_alone"), 2, "x"),
             _num(s.get("compare_over_bake_operator"), 2, "x")]
            for size, s in need(data, path, "sizes").items()]
    head = (f"A whole compare of {data.get('method')} on {data.get('object')} against the "
            f"bake alone, median of {data.get('repeats')} pairs")
    return f"<p>{escape(head)}</p>" + _table(
        ["size", "compare / bake process", "compare / bake operator"], rows)


def folded_table(data, path):
    """folded_cost's JSON: Cycles' SVM program size after constant folding per material,
    before and after, per Blender line (units differ by line: compare within a column)."""
    after = need(data, path, "after")
    lines = sorted(after, key=lambda v: tuple(int(x) for x in v.split(".")), reverse=True)
    before = data.get("before", {})
    by = {(when, line): {r["key"]: r for r in need(src, path, line, "rows")}
          for when, src in (("before", before), ("after", after)) for line in lines
          if line in src}
    rows = []
    for k, r in enumerate(need(after, path, lines[0], "rows")):
        cells = [escape(r["label"])]
        for line in lines:
            b = by.get(("before", line), {}).get(r["key"], {}).get("svm")
            a = by.get(("after", line), {}).get(r["key"], {}).get("svm")
            cells += [_num(b, 0), _num(a, 0)]
        rows.append(cells)
    head = [h for line in lines for h in (f"{line} before", f"{line} after")]
    return ("<p>Cycles' own SVM program size after its constant folding (what a sample runs; "
            "5.2 counts 32-bit words, older lines int4 records)</p>"
            + _table(["material"] + head, rows))


def scalar_table(data, path):
    """Any other bench JSON: its top-level numbers and words."""
    rows = [[escape(k), _num(v, 3) if isinstance(v, float) else escape(str(v))]
            for k, v in (data.items() if isinstance(data, dict) else [])
            if isinstance(v, (int, float, str)) and not isinstance(v, bool)]
    return _table(["field", "value"], rows) if rows else "<p>(no top-level figures)</p>"


def _shape(data):
    if isinstance(data, dict) and "rows" in data and "marginal_layer" in data:
        return render_cost_table
    if isinstance(data, dict) and "after" in data and "before" in data:
        return folded_table
    if isinstance(data, dict) and "runs" in data:
        return bench_batch_table
    if isinstance(data, dict) and "sizes" in data and "method" in data:
        return bench_compare_table
    return scalar_table


def cost_section(docs, page_dir, repo_root, command):
    """(HTML, [JSON paths read])."""
    what = ("What the groups cost to render against Blender's own nodes, and the committed "
            "slow benches (batch baking, a compare's overhead), each with the date and machine "
            "it was measured on.")
    docs = Path(docs)
    files = sorted(docs.glob("render_cost*.json")) + sorted(docs.glob("bench_*.json"))
    parts = []
    if not (docs / "render_cost.json").is_file():
        parts.append(missing("The render-cost table (docs/render_cost.json)", command))
    chart = docs / "render_cost.png"
    if chart.is_file():
        parts.append(figure(chart, page_dir, "Render cost chart (committed): "
                            + provenance_text(*png_provenance(chart, repo_root))))
    for path in files:
        data = load_json(path, "a committed bench")
        date, machine = json_provenance(data, path, repo_root)
        parts.append(f'<h3>{link(path, page_dir)}</h3><p class="source">'
                     f'{escape(provenance_text(date, machine))}</p>'
                     + _shape(data)(data, path))
    return section("cost", "Render cost and the slow benches", what, "".join(parts)), files
