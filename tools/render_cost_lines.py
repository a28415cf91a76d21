"""Issue 21's render-cost table on every supported line in quick mode, before and after: runs
`bench-render`'s rounds with each line's venv, once with this checkout's groups and once with an
older checkout's (the "before" commit), and writes the figures the docs quote
(docs/render_cost_lines.json, the `render-cost-lines` table in docs/performance.md).

Quick mode here is one frame for both sides (the older bench has no --size or --samples, so both
run as `run(out, quick=True)` with the quick settings set to QUICK below): no EEVEE, 3 rounds.

    git worktree add --detach /tmp/before 1519e9c      # the groups before issue 21
    python tools/render_cost_lines.py /tmp/before docs/render_cost_lines.json [LINE ...]

Each line needs its venv (.venv for 5.2, .venv-bpy50/45/42) in this checkout; the older checkout
is run with the same venvs. Run it on an otherwise idle machine: it takes about 2 minutes per
line and side.
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
QUICK = {"size": 192, "samples": 32, "repeats": 3, "eevee": False}
LINES = ("5.2", "5.0", "4.5", "4.2")
# What the docs table keeps of each row (the rest is in the bench's own JSON).
ROW_KEYS = ("key", "label", "seconds", "ratio", "target", "twin", "svm")

CHILD = """
import json, sys
root, out, quick = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
sys.path.insert(0, root)
from surfgrad_addon.harness.bench import render_cost
render_cost.QUICK.update(quick)
render_cost.run(out, True, True)
"""


def venv_python(line):
    name = ".venv" if line == "5.2" else ".venv-bpy" + line.replace(".", "")
    return ROOT / name / "bin" / "python"


def bench(line, root, out):
    """One quick bench-render of the groups in checkout root with the line's Blender."""
    subprocess.run([str(venv_python(line)), "-c", CHILD, str(root), str(out), json.dumps(QUICK)],
                   check=True, cwd=root, stdout=subprocess.DEVNULL)
    return json.loads((Path(out) / "render_cost.json").read_text())


def trimmed(result):
    return {"blender": result["blender"], "seconds": result["seconds"],
            "marginal_layer": result["marginal_layer"],
            "rows": [{k: r[k] for k in ROW_KEYS if k in r} for r in result["rows"]]}


def commit(root):
    return subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True, check=True).stdout.strip()


def main(argv):
    if len(argv) < 2:
        print(__doc__)
        return 2
    before_root, target, lines = Path(argv[0]).resolve(), Path(argv[1]), argv[2:] or LINES
    result = {"what": "bench-render in quick mode on each line, the groups before issue 21 "
                      "and now (tools/render_cost_lines.py)",
              "size": QUICK["size"], "samples": QUICK["samples"], "repeats": QUICK["repeats"],
              "before_commit": commit(before_root), "after_commit": commit(ROOT), "lines": []}
    with tempfile.TemporaryDirectory() as tmp:
        for line in lines:
            entry = {"line": line}
            for side, root in (("after", ROOT), ("before", before_root)):
                print(f"{line} {side} ...", flush=True)
                entry[side] = trimmed(bench(line, root, Path(tmp) / f"{line}-{side}"))
            result["lines"].append(entry)
    target.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
