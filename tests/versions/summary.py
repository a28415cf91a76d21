"""The lines side by side, from tests/versions/check.py's JSON files (tools/versions.sh runs
it last): worst p99 / max angular error over the four test objects per method and line.
Exit status 1 if a file is missing or a line failed."""

import json
import sys
from pathlib import Path


def main(paths):
    runs, status = [], 0
    for p in paths:
        if not Path(p).is_file():
            print(f"summary: {p} is missing (that line did not finish)")
            status = 1
            continue
        runs.append(json.loads(Path(p).read_text()))
    if not runs:
        return 1
    cases = list(dict.fromkeys(r["case"] for run in runs for r in run["methods"]))
    head = [f"Blender {run['facts']['blender'].replace(' LTS', '')}" for run in runs]
    print(f"\n## Bakes against the reference at {runs[0]['resolution']}^2: worst p99 / max "
          f"degrees over Sphere, Torus, Plane, Transformed (bar 0.1 / 0.5)\n")
    print("| method | " + " | ".join(head) + " |")
    print("|---|" + "---|" * len(runs))
    for case in cases:
        cells = []
        for run in runs:
            row = next((r for r in run["methods"] if r["case"] == case), None)
            if row is None:
                cells.append("-")
            elif row["status"] == "n/a":
                cells.append("not available")
            else:
                cell = f"{row.get('p99_deg', float('nan')):.4f} / {row.get('max_deg', float('nan')):.4f}"
                if row["status"] != "pass":
                    cell += " FAIL"
                elif row.get("note"):
                    cell += " *"
                cells.append(cell)
        print(f"| {case} | " + " | ".join(cells) + " |")
    for run in runs:
        for c in run["checks"]:
            if not c["ok"]:
                print(f"- {run['facts']['blender']}: {c['name']} FAILED: {c['detail']}")
        for r in run["methods"]:
            if r.get("note") and r["status"] != "n/a":
                print(f"- * {run['facts']['blender']}, {r['case']}: {r['note']}")
    print()
    for run in runs:
        f = run["facts"]
        print(f"Blender {f['blender']}: {'PASS' if run['ok'] else 'FAIL'} in {run['seconds']:.0f} s "
              f"(Set Mesh Normal {'yes' if f['set_mesh_normal'] else 'no'}, Bump Filter Width "
              f"{'yes' if f['bump_filter_width'] else 'no'}, EEVEE id {f['eevee_engine_id']})")
        status |= 0 if run["ok"] else 1
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
