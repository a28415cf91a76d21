"""The report page's stylesheet, inlined into the page (it loads nothing from the network)."""

CSS = """
:root { --ink: #1d2330; --muted: #5b6475; --line: #d9dde5; --pass: #1a7f37; --fail: #c62828;
        --paper: #ffffff; --band: #f4f6f9; --accent: #2f5597; }
* { box-sizing: border-box; }
body { margin: 0; background: var(--band); color: var(--ink);
       font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; }
header, main > section, footer { max-width: 1240px; margin: 0 auto; padding: 0 20px; }
header { padding-top: 22px; }
h1 { font-size: 28px; margin: 0 0 4px; }
h2 { font-size: 21px; margin: 0 0 4px; }
h3 { font-size: 16px; margin: 18px 0 4px; }
.meta, .what, .source { color: var(--muted); }
.what { margin: 0 0 12px; font-size: 15.5px; color: var(--ink); }
.source { font-size: 13px; margin: 6px 0; }
nav { margin: 10px 0 6px; }
nav a { margin-right: 16px; }
a { color: var(--accent); }
main > section { background: var(--paper); border: 1px solid var(--line); border-radius: 8px;
                 margin-top: 18px; padding: 16px 20px 18px; }
.verdict { font-size: 18px; font-weight: 600; margin: 8px 0 12px; }
.verdict.pass { color: var(--pass); }
.verdict.fail { color: var(--fail); }
.missing { background: #fff6e0; border: 1px solid #f0d48a; border-radius: 6px; padding: 8px 12px;
           margin: 8px 0; }
code { background: #eef1f5; border-radius: 4px; padding: 1px 5px; font-size: 13.5px; }
table { border-collapse: collapse; font-size: 13.5px; margin: 6px 0; }
th, td { border-bottom: 1px solid var(--line); padding: 4px 10px; text-align: left;
         vertical-align: top; }
th { background: var(--band); font-weight: 600; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
td.case { font-variant-numeric: tabular-nums; white-space: nowrap; text-align: right; }
td.case .mark { font-weight: 700; margin-left: 6px; }
td.pass .mark { color: var(--pass); }
td.fail { background: #fdecea; }
td.fail .mark { color: var(--fail); }
td.none { color: var(--muted); }
.figure img { max-width: 100%; height: auto; border: 1px solid var(--line); background: #fff; }
.figure .caption { font-size: 13px; color: var(--muted); margin: 2px 0 14px; }
.pair { display: grid; grid-template-columns: 1fr 1fr; gap: 16px; }
.legend { display: flex; align-items: flex-start; gap: 40px; margin: 10px 0 16px; }
.scale { position: relative; width: 520px; margin-left: 28px; padding-bottom: 30px; }
.swatches { display: grid; grid-template-columns: auto auto; gap: 3px 22px; font-size: 13px; }
.scale img { display: block; width: 520px; height: 18px; border: 1px solid #999;
             image-rendering: pixelated; }
.tick { position: absolute; top: 20px; font-size: 12px; transform: translateX(-50%);
        white-space: nowrap; }
.tick::before { content: ""; position: absolute; left: 50%; top: -4px; height: 4px;
                border-left: 1px solid #333; }
.tick.bar { font-weight: 600; color: var(--fail); }
.swatch { display: inline-block; width: 14px; height: 14px; border: 1px solid #777;
          vertical-align: -2px; margin-right: 5px; }
.swatch.none { background: repeating-conic-gradient(#c9ced8 0 25%, #eef0f4 0 50%) 0 0 / 8px 8px; }
.heat { display: grid; grid-template-columns: 190px repeat(var(--cols), auto); gap: 6px 12px;
        align-items: start; }
.heat .row-name { font-weight: 600; font-size: 13.5px; padding-top: 4px; }
.heat .col-name { font-weight: 600; font-size: 13px; }
.heat figure { margin: 0; }
.heat img { display: block; image-rendering: pixelated; border: 1px solid #aab;
            background: repeating-conic-gradient(#c9ced8 0 25%, #eef0f4 0 50%) 0 0 / 8px 8px; }
.heat figcaption { font-size: 11.5px; color: var(--muted); font-variant-numeric: tabular-nums; }
.heat figcaption.fail { color: var(--fail); font-weight: 600; }
.exhibit { margin: 14px 0 22px; }
.exhibit .pair { grid-template-columns: 1fr 1fr; align-items: start; }
footer { padding: 18px 20px 40px; font-size: 13px; color: var(--muted); }
"""
