"""The report page's sections as HTML: each a heading, one sentence on what it shows, its
figures or tables, and links to the files it came from. A missing input is shown as "not
produced by this run" with the command that produces it."""

import math
import os
from html import escape
from pathlib import Path
from urllib.parse import quote

from PIL import Image

from .inputs import need, png_provenance

HEAT_DISPLAY = 192           # px: a heat map drawn at least this wide, whole pixels per texel


def href(target, page_dir):
    """A relative link from the page's folder to target."""
    return quote(Path(os.path.relpath(Path(target).resolve(), Path(page_dir).resolve()))
                 .as_posix())


def link(target, page_dir, text=None):
    return f'<a href="{href(target, page_dir)}">{escape(text or Path(target).name)}</a>'


def missing(what, command):
    return (f'<p class="missing">{escape(what)}: not produced by this run: run '
            f'<code>{escape(command)}</code></p>')


def section(anchor, title, what, body):
    return (f'<section id="{anchor}"><h2>{escape(title)}</h2>'
            f'<p class="what">{escape(what)}</p>{body}</section>')


def source(page_dir, *paths, note=""):
    links = ", ".join(link(p, page_dir) for p in paths)
    return f'<p class="source">Data: {links}{escape(note)}</p>'


def image(target, page_dir, alt, extra=""):
    return f'<img src="{href(target, page_dir)}" alt="{escape(alt)}"{extra}>'


def provenance_text(date, machine):
    return f"{date or 'date not recorded'}; " + (machine or "machine not recorded")


# The proof: the compare table ------------------------------------------------------------------

def passes(report, bar):
    """Whether a case is within both bars (a case with no texel compared is not)."""
    p99, mx = report.get("p99_deg"), report.get("max_deg")
    return p99 is not None and mx is not None and p99 <= bar["p99_deg"] and \
        mx <= bar["max_deg"]


def grid(reports, label_of):
    """(row labels, objects, {(label, object): index}) in the reports' order."""
    rows, objects, at = [], [], {}
    for i, r in enumerate(reports):
        label = label_of(r)
        rows += [label] if label not in rows else []
        objects += [r["object"]] if r["object"] not in objects else []
        at[(label, r["object"])] = i
    return rows, objects, at


def _degrees(value):
    """Degrees with two significant figures, never in exponent form (0.000012, 0.0031)."""
    if value is None:
        return "n/a"
    if value <= 0:
        return "0"
    return f"{value:.{max(2, 1 - math.floor(math.log10(value)))}f}"


def proof_section(reports, bar, page_dir, paths, label_of, command):
    what = ("Every method's node groups baked with Cycles and compared texel by texel with the "
            "numpy reference on each test object: a case passes when its angular error stays "
            f"within the bars (p99 at most {bar['p99_deg']} deg, max at most "
            f"{bar['max_deg']} deg).")
    if reports is None:
        return section("proof", "What was proven, and how", what,
                       missing("The bake-against-reference table (compare.json)", command))
    json_path = paths["compare_json"]
    if not isinstance(reports, list):
        need(reports, json_path, 0)         # not a list of cases: the error names the file
    for k in range(len(reports)):
        for key in ("method", "object", "p99_deg", "max_deg", "texels_compared"):
            need(reports, json_path, k, key)
    ok = sum(passes(r, bar) for r in reports)
    verdict = "pass" if ok == len(reports) else "fail"
    rows, objects, at = grid(reports, label_of)
    head = "".join(f'<th class="num">{escape(o)}</th>' for o in objects)
    body = []
    for label in rows:
        cells = []
        for obj in objects:
            i = at.get((label, obj))
            if i is None:
                cells.append('<td class="case none">not run</td>')
                continue
            r = reports[i]
            good = passes(r, bar)
            cells.append(
                f'<td class="case {"pass" if good else "fail"}" data-case="{escape(label)}|'
                f'{escape(obj)}" data-pass="{int(good)}" title="{r["texels_compared"]} texels '
                f'compared">p99 {_degrees(r["p99_deg"])} &middot; max {_degrees(r["max_deg"])}'
                f'<span class="mark">{"&#10003;" if good else "&#10007; over the bar"}</span>'
                f'</td>')
        body.append(f"<tr><th>{escape(label)}</th>{''.join(cells)}</tr>")
    resolution = reports[0].get("resolution") if reports else None
    text = (f'<p class="verdict {verdict}" id="verdict" data-passed="{ok}" '
            f'data-cases="{len(reports)}">{ok} of {len(reports)} cases within the bars'
            + (f" (bakes of {resolution} x {resolution} texels)" if resolution else "")
            + "</p>")
    table = (f'<table id="proof-table"><thead><tr><th>method</th>{head}</tr></thead>'
             f'<tbody>{"".join(body)}</tbody></table>')
    extra = [p for p in (paths.get("compare_md"),) if p and Path(p).is_file()]
    note = " (per case: texels compared, excluded texels by reason, bake and reference seconds)"
    return section("proof", "What was proven, and how", what,
                   text + table + source(page_dir, json_path, *extra, note=note))


# Heat maps on one scale ------------------------------------------------------------------------

def _ticks(bar, position):
    values = [1e-5, 1e-4, 1e-3, 1e-2, bar["p99_deg"], bar["max_deg"]]
    out = []
    for v in values:
        is_bar = v in (bar["p99_deg"], bar["max_deg"])
        text = f"{v:.5f}".rstrip("0").rstrip(".") + "&deg;"
        out.append(f'<span class="tick{" bar" if is_bar else ""}" '
                   f'style="left:{100 * float(position(v, bar["max_deg"])):.2f}%">{text}</span>')
    return "".join(out)


def heat_section(reports, bar, page_dir, heat, label_of, command):
    """heat: None, or {"paths": {index: png or None}, "legend": png, "colours": {code: rgb},
    "position": scale_position, "names": {code: reason name}}."""
    what = ("Where the error sits: each case's error per texel on one shared logarithmic "
            f"scale, light at 0.00001 deg to dark at the max bar ({bar['max_deg']} deg), red "
            "above it; every texel is drawn as a square of whole screen pixels.")
    if reports is None or heat is None:
        return section("heat", "Heat maps on one scale", what,
                       missing("The compare heat maps (compare/heat)", command))
    swatch = lambda rgb, text: (f'<span><span class="swatch" style="background:rgb{rgb}">'
                                f'</span>{escape(text)}</span>')
    swatches = [swatch(heat["over"], f"above the max bar ({bar['max_deg']} deg)")]
    swatches += [swatch(heat["colours"][c], name) for c, name in heat["names"].items()]
    swatches.append('<span><span class="swatch none"></span>not covered by the bake or the '
                    'reference</span>')
    legend = (f'<div class="legend"><div class="scale">'
              f'{image(heat["legend"], page_dir, "the shared error scale")}'
              f'{_ticks(bar, heat["position"])}</div>'
              f'<div class="swatches">{"".join(swatches)}</div></div>')
    rows, objects, at = grid(reports, label_of)
    cells = ['<div></div>'] + [f'<div class="col-name">{escape(o)}</div>' for o in objects]
    for label in rows:
        cells.append(f'<div class="row-name">{escape(label)}</div>')
        for obj in objects:
            i = at.get((label, obj))
            path = heat["paths"].get(i) if i is not None else None
            if path is None:
                cells.append('<div class="none">no heat map</div>')
                continue
            r = reports[i]
            w, h = Image.open(path).size
            k = max(1, -(-HEAT_DISPLAY // max(w, h)))
            bad = "" if passes(r, bar) else ' class="fail"'
            picture = image(path, page_dir, f"{label} on {obj}",
                            f" width={k * w} height={k * h}")
            cells.append(f'<figure>{picture}<figcaption{bad}>max {_degrees(r["max_deg"])}'
                         f'&deg; &middot; {k} px a texel</figcaption></figure>')
    body = (legend + f'<div class="heat" style="--cols:{len(objects)}">{"".join(cells)}</div>'
            + f'<p class="source">Decoded from compare-all\'s own heat maps (each on its own '
              f'scale) with each case\'s max error from compare.json.</p>')
    return section("heat", "Heat maps on one scale", what, body)


# Figures from files ----------------------------------------------------------------------------

def figure(path, page_dir, caption):
    return (f'<div class="figure">{image(path, page_dir, caption)}'
            f'<p class="caption">{escape(caption)}</p></div>')


def speed_section(bench, page_dir, paths, committed_chart, repo_root, command):
    what = ("How long each method takes to bake against how far its result lands from the "
            "analytic truth; a point on the grey step line (the Pareto front) is beaten by no "
            "other on both.")
    parts = []
    chart = paths["bench_chart"]
    if bench is None or not Path(chart).is_file():
        parts.append(missing("This run's speed-accuracy chart (bench/bench.json)", command))
    else:
        settings = need(bench, paths["bench_json"], "settings")
        quick = " quick bench: small bakes, few repeats" if settings.get("quick") else " bench"
        caption = (f"This run's{quick} ({settings.get('resolution')} x "
                   f"{settings.get('resolution')} texels, {settings.get('repeats')} repeats)"
                   + (": its costs are a smoke test, not a measurement" if settings.get("quick")
                      else ""))
        parts.append(figure(chart, page_dir, caption) + source(page_dir, paths["bench_json"]))
    if committed_chart is not None and Path(committed_chart).is_file():
        date, machine = png_provenance(committed_chart, repo_root)
        parts.append(figure(committed_chart, page_dir, "The committed full bench: "
                            + provenance_text(date, machine)))
    return section("speed", "Speed against accuracy", what, "".join(parts))


EXHIBIT_NOTES = {
    "layered": "detail on a second, rotated UV map",
    "triplanar": "triplanar projection on a displaced rock",
    "decal": "a decal across a torus and a plane",
    "decal-shapes": "the four decal shapes",
    "noise": "bump from volume noise",
    "height": "height-map derivatives",
    "displacement": "displacement with bump on top",
    "parallax": "parallax with detail after the resolve",
    "post-resolve": "detail on a resolved normal map: the Bump node against SG Volume Gradient, "
                    "with each one's error",
    "sampler": "one Sampler group for two images (Blender 5.0+)",
}


def exhibits_section(folder, page_dir, repo_root, this_run, command):
    what = ("The same object, light and content shaded the usual way and the surface-gradient "
            "way, side by side, with enlarged crops of one spot on each.")
    pictures = sorted(p for p in Path(folder).glob("*.png") if not p.stem.endswith("_crop")) \
        if folder is not None and Path(folder).is_dir() else []
    if not pictures:
        return section("exhibits", "Exhibits", what, missing("The exhibit pictures", command))
    whose = "Rendered by this run" if this_run else "The last committed pictures"
    parts = [f'<p class="source">{whose} ({link(folder, page_dir, Path(folder).name + "/")}); '
             f'to render them anew: <code>{escape(command)}</code></p>']
    for p in pictures:
        date, machine = png_provenance(p, repo_root)
        crop = p.with_name(p.stem + "_crop.png")
        note = EXHIBIT_NOTES.get(p.stem)
        title = p.stem + (f": {note}" if note else "")
        inner = image(p, page_dir, title)
        if crop.is_file():
            inner = f'<div class="pair">{inner}{image(crop, page_dir, title + ", crops")}</div>'
        parts.append(f'<div class="exhibit figure"><h3>{escape(title)}</h3>{inner}'
                     f'<p class="caption">{escape(provenance_text(date, machine))}</p></div>')
    return section("exhibits", "Exhibits", what, "".join(parts))
