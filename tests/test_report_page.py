"""The report page (harness/report_page.py), opened in headless Chromium: built from a real
compare-all (two methods at 16 texels, one case pushed over the bar), the real bench writer's
chart and the committed exhibits, every image loads, nothing reports an error, and the pass
marks are the ones the numbers give. Missing inputs show their command; a malformed JSON is an
error naming the file. The heat maps on the shared scale read back the compare writer's
degrees.

Chromium comes from the system's packages: `bash tools/install_chromium.sh` (run.sh test runs
it first). SURFGRAD_WRITE_SCREENSHOT=1 saves the page's screenshot as docs/report_page.png.
"""

import html
import json
import os
import re
import shutil
import subprocess
import types
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from PIL.PngImagePlugin import PngInfo

from surfgrad_addon.harness.report_page import ReportInputError, write_report_page

pytestmark = pytest.mark.tier("child")

ROOT = Path(__file__).resolve().parents[1]
P99_BAR, MAX_BAR = 0.1, 0.5             # tests/test_bake_compare.py's agreement bar
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-sync", "--no-first-run", "--hide-scrollbars"]
# Put into a copy of the page: records every image's naturalWidth and every error, into the DOM.
CHECK_SCRIPT = """<script>
var surfgradErrors = [];
window.addEventListener('error', function (e) {
  var t = e.target;
  surfgradErrors.push(t && t !== window && (t.src || t.href) ? 'failed to load ' + (t.src || t.href)
                                                             : 'error: ' + e.message);
}, true);
var surfgradConsoleError = console.error;
console.error = function () {
  surfgradErrors.push('console.error: ' + Array.prototype.join.call(arguments, ' '));
  surfgradConsoleError.apply(console, arguments);
};
window.addEventListener('load', function () {
  var pre = document.createElement('pre');
  pre.id = 'surfgrad-check';
  pre.textContent = JSON.stringify({errors: surfgradErrors, images: Array.prototype.map.call(
    document.images, function (i) { return [i.getAttribute('src'), i.naturalWidth]; })});
  document.body.appendChild(pre);
});
</script>"""


def chromium():
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return shutil.which(name)
    pytest.fail("the report page's test needs Chromium from the system's packages: run "
                "`bash tools/install_chromium.sh` (as root; it runs apt-get install chromium)",
                pytrace=False)


def run_chromium(tmp, *args):
    cmd = [chromium(), *CHROMIUM_FLAGS, f"--user-data-dir={tmp / 'chromium-profile'}", *args]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def open_page(page, tmp):
    """(dumped DOM, {"errors": [...], "images": [[src, naturalWidth], ...]}) of page in
    headless Chromium, after its images loaded."""
    checked = page.with_name("index_check.html")
    checked.write_text(page.read_text().replace("<head>", "<head>" + CHECK_SCRIPT, 1))
    dom = run_chromium(tmp, "--virtual-time-budget=30000", "--dump-dom", checked.as_uri())
    found = re.search(r'<pre id="surfgrad-check">(.*?)</pre>', dom, re.S)
    assert found, "the page's load event never came: " + dom[-1000:]
    return dom, json.loads(html.unescape(found.group(1)))


def bench_fixture(folder):
    """bench/ as the bench's own writer (bench/report.write_all) writes it, for two scenarios
    of made-up rows."""
    from surfgrad_addon.harness.bench import report
    scenarios = [types.SimpleNamespace(name="height", title="1. Height detail"),
                 types.SimpleNamespace(name="noise", title="2. Volume noise")]
    rows = []
    for sc in scenarios:
        for k, (family, method) in enumerate((("sg", "SG one"), ("blender", "Blender one"),
                                               ("baseline", "Baseline one"))):
            rows.append({"scenario": sc.name, "method": method, "family": family,
                         "cost_ratio": 1.0 + k, "mean_deg": 0.5 / (k + 1), "p95_deg": 1.0,
                         "max_deg": 2.0, "bake_seconds_median": 0.1 * (k + 1),
                         "facing_away_fraction": 0.0, "reference_to_bake": None,
                         "memory_note": ""})
    settings = {"resolution": 64, "repeats": 2, "quick": True, "seconds": 1.0}
    report.write_all(folder, scenarios, rows, {}, settings)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A page from a real compare-all (normal-map, with its settings case, and the three
    height-map variants on the four test objects at 16 texels), one case pushed over the max bar and one over the p99 bar,
    a quick-bench folder and the repository's committed docs."""
    from surfgrad_addon.harness import compare_all
    tmp = tmp_path_factory.mktemp("report_page")
    out = tmp / "demo"
    reports = compare_all.run_all(out / "compare", 16, workers=1, log=lambda *_: None,
                                  methods=["normal-map", "height-map"])
    reports[1]["max_deg"] = 0.7
    reports[6]["p99_deg"] = 0.2
    (out / "compare" / "compare.json").write_text(json.dumps(reports))
    bench_fixture(out / "bench")
    page = write_report_page(out, log=lambda *_: None)
    dom, check = open_page(page, tmp)
    return types.SimpleNamespace(tmp=tmp, out=out, page=page, reports=reports, dom=dom,
                                 check=check)


def _cases():
    """The fixture's cases: each case of the two methods (the settings cases too) on the four
    test objects."""
    from surfgrad_addon.harness import compare_all
    return 4 * len(compare_all.all_cases(["normal-map", "height-map"]))


def test_every_image_loads_and_no_error_is_recorded(built):
    images = built.check["images"]
    assert built.check["errors"] == []
    bad = [src for src, width in images if width <= 0]
    assert bad == []
    srcs = [src for src, _ in images]
    # One shared-scale heat map per case, the legend, this run's and the committed chart, the
    # committed exhibits with their crops.
    heat = [s for s in srcs if s.startswith("report/heat/") and s != "report/heat/legend.png"]
    assert len(heat) == len(built.reports) == _cases()
    assert "report/heat/legend.png" in srcs and "bench/chart_combined.png" in srcs
    exhibits = sorted((ROOT / "docs" / "exhibits").glob("*.png"))
    assert sum("docs/exhibits/" in s for s in srcs) == len(exhibits) > 0
    assert sum(s.endswith("docs/bench_combined.png") for s in srcs) == 1
    assert "no heat map" not in built.dom


def test_sections_and_pass_marks_match_the_numbers(built):
    dom = built.dom
    for anchor in ("proof", "heat", "speed", "exhibits", "cost"):
        assert f'<section id="{anchor}">' in dom
    marks = dict(re.findall(r'data-case="([^"]+)" data-pass="([01])"', dom))
    expected = {}
    for r in built.reports:
        label = r["method"] + (f"-{r['variant']}" if r["variant"] else "")
        # (compare-all's settings cases: "-directx-strength0.6")
        label += "".join(f"-{k}" if v is True else f"-{k}{v:g}"
                         for k, v in sorted(r.get("settings", {}).items()))
        expected[f"{label}|{r['object']}"] = str(int(r["p99_deg"] <= P99_BAR and
                                                     r["max_deg"] <= MAX_BAR))
    assert marks == expected
    assert sorted(v for v in marks.values()).count("0") == 2
    passed = sum(v == "1" for v in expected.values())
    n = _cases()
    assert f'data-passed="{passed}" data-cases="{n}">{passed} of {n} cases within the bars' in dom
    # The JSON it read is linked; what this run did not make names its command.
    for href in ('href="compare/compare.json"', 'href="bench/bench.json"',
                 'docs/bench_batch.json"'):
        assert href in dom
    # The committed render cost (docs/render_cost.json) is shown: each SG row's ratio as the
    # JSON has it.
    cost = json.loads((ROOT / "docs" / "render_cost.json").read_text())
    assert 'docs/render_cost.json"' in dom
    for row in (r for r in cost["rows"] if "ratio" in r):
        assert f"<td>{html.escape(row['label'])}</td><td>{row['seconds']:.2f}</td>" \
            f"<td>{row['ratio']:.2f}x</td>" in dom, row["label"]


def screenshot(page, shot, tmp):
    run_chromium(tmp, "--window-size=1280,2400", f"--screenshot={shot}", page.as_uri())
    img = np.asarray(Image.open(shot).convert("RGB")).astype(float)
    assert img.shape == (2400, 1280, 3)
    assert img.std() > 20                    # text, tables and heat maps, not a blank page


def test_screenshot_reads(built):
    """The page's top at 1280 x 2400. With SURFGRAD_WRITE_SCREENSHOT=1 also the main job's
    real page (out/demo/index.html, after `bash run.sh main`) into docs/report_page.png: this
    test's page has made-up failures and bench rows, no picture for the docs."""
    screenshot(built.page, built.tmp / "report_page.png", built.tmp)
    if os.environ.get("SURFGRAD_WRITE_SCREENSHOT"):
        real = ROOT / "out" / "demo" / "index.html"
        assert real.is_file(), f"{real} is missing: run `bash run.sh main` first"
        screenshot(real, ROOT / "docs" / "report_page.png", built.tmp)


def _png(path, size, text=None):
    info = PngInfo()
    for k, v in (text or {}).items():
        info.add_text(k, v)
    Image.new("RGB", size, (120, 130, 140)).save(path, pnginfo=info)


def render_cost_fixture():
    """Shaped like bench-render's render_cost.json; its own markdown writer reads it."""
    from surfgrad_addon.harness.bench import render_cost
    rows = [{"key": "none", "label": "no bump", "seconds": 1.0, "nodes": 3,
             "normal_map_nodes": 0, "image_lookups": 0, "svm": 53},
            {"key": "nm-sg", "label": "SG Normal Map", "seconds": 1.2, "nodes": 9,
             "normal_map_nodes": 0, "image_lookups": 1, "twin": "nm", "ratio": 1.2,
             "overhead_ratio": 2.0, "target": 1.1, "svm": 360, "svm_ratio": 5.0},
            {"key": "h-sg", "label": "SG Height Map", "seconds": 1.0, "nodes": 9,
             "normal_map_nodes": 0, "image_lookups": 1, "twin": "h", "ratio": 1.02,
             "overhead_ratio": 1.0, "target": 1.05, "svm": 301, "svm_ratio": 2.74}]
    folded = [{"key": r["key"], "label": r["label"], "svm": r["svm"], "unit": "int"}
              for r in rows]
    result = {"blender": "5.2.3 LTS", "size": 64, "samples": 4, "repeats": 2, "quick": True,
              "rows": rows, "marginal_layer": {"sg_s": 0.1, "builtin_s": 0.1}, "eevee": {},
              "seconds": 9.0, "folded": folded}
    assert "SG Height Map" in render_cost.markdown(result)
    return result


def test_missing_inputs_show_their_command_and_bad_json_names_its_file(tmp_path):
    repo = tmp_path / "repo"
    (repo / "docs" / "exhibits").mkdir(parents=True)
    _png(repo / "docs" / "exhibits" / "layered.png", (64, 36),
         {"Date": "2026/11/23 20:56:56", "RenderTime": "00:25.24"})
    (repo / "docs" / "render_cost.json").write_text(json.dumps(render_cost_fixture()))
    out = tmp_path / "demo"
    page = write_report_page(out, repo_root=repo, log=lambda *_: None)
    text = page.read_text()
    for command in ("compare-all --out", "bench --quick --out"):
        assert command in text
    assert text.count("not produced by this run") == 3       # compare, heat maps, bench
    assert "2026/11/23 20:56:56 (rendered in 00:25.24); machine not recorded" in text
    # The render-cost rows against their targets: 1.2 > 1.1 missed, 1.02 <= 1.05 met.
    assert "1.20x</td><td>&le; 1.10x missed" in text and "1.02x</td><td>&le; 1.05x met" in text
    dom, check = open_page(page, tmp_path)
    assert check["errors"] == [] and all(w > 0 for _, w in check["images"])
    # The check sees a picture that does not load (so the passes above can fail).
    page.write_text(text.replace("</main>", '<img src="gone.png" alt="gone"></main>'))
    _, check = open_page(page, tmp_path)
    assert ["gone.png", 0] in check["images"]
    assert any(e.startswith("failed to load") and e.endswith("gone.png")
               for e in check["errors"])
    with pytest.raises(FileExistsError, match="overwrite"):
        write_report_page(out, repo_root=repo, overwrite=False, log=lambda *_: None)

    (repo / "docs" / "bench_broken.json").write_text('{"runs": ')
    with pytest.raises(ReportInputError, match=r"bench_broken\.json .* is not valid JSON"):
        write_report_page(out, repo_root=repo, overwrite=True, log=lambda *_: None)
    (repo / "docs" / "bench_broken.json").unlink()
    (out / "compare").mkdir()
    (out / "compare" / "compare.json").write_text(json.dumps([{"method": "normal-map"}]))
    with pytest.raises(ReportInputError, match=r"compare\.json has no 0/object"):
        write_report_page(out, repo_root=repo, overwrite=True, log=lambda *_: None)


@pytest.mark.tier("blender")
def test_shared_heat_maps_read_back_the_compare_writers_degrees(tmp_path):
    from surfgrad_addon.harness import compare as C
    from surfgrad_addon.harness.report import heat as H
    errors = np.geomspace(1e-4, 0.5, 40)
    for top in (0.5, 2.0):                    # a case within the bar, one far above it
        grid = np.concatenate([errors, [top, np.nan, 0.01, 0.01]])[None, :]
        reasons = np.zeros(grid.shape, dtype=np.int8)
        reasons[0, -2], reasons[0, -1] = C.CONTESTED, 2          # contested, edge
        path = C.write_heat_map(tmp_path / f"h{top}.png", C.ErrorImage(grid, reasons), True)
        got, codes = H.decode_heat_png(path, top)
        v, back = grid[0, :41] / top, got[0, :41] / top
        # The index holds sqrt(v) rounded to a 1/250 step.
        assert np.all(np.abs(np.sqrt(back) - np.sqrt(v)) <= 0.5 / 250 + 1e-9)
        assert codes[0, 41] == -1 and codes[0, 42] == C.CONTESTED and codes[0, 43] == 2
        assert np.isnan(got[0, 41:]).all() and (codes[0, :41] == 0).all()
        rgba = H.shared_rgba(got, codes, MAX_BAR, H.reason_colours())
        assert rgba[0, 41, 3] == 0                                # not compared: transparent
        over = grid[0, :41] > MAX_BAR + top / 255
        assert (rgba[0, :41][over, :3] == H.OVER_BAR).all()
        grey = rgba[0, :41][~over & (grid[0, :41] < MAX_BAR), 0].astype(int)
        assert np.all(np.diff(grey) <= 1)                        # darker as the error grows


def test_a_missing_render_cost_names_its_command(tmp_path):
    repo = tmp_path / "repo"
    (repo / "docs" / "exhibits").mkdir(parents=True)
    _png(repo / "docs" / "exhibits" / "layered.png", (64, 36), {})
    page = write_report_page(tmp_path / "demo", repo_root=repo, log=lambda *_: None)
    text = page.read_text()
    assert "The render-cost table (docs/render_cost.json)" in text
    assert "bash run.sh bench-render" in text
