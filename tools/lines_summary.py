"""The supported Blender lines side by side, after `bash run.sh test` ran the suite on each:
whether each line passed and how long it took, every method's worst p99 / max angular error
against the reference over the four test objects, the suite's tests and seconds per tier,
and whether the group interfaces are the same everywhere. Reads out/lines/*.json (written by
run.sh and the tests through tests/conftest.py), writes out/lines/summary.md, prints it, and ends with a plain
'lines: N passed, M failed' line. Exit status 1 if a line failed or a report is missing.

    python tools/lines_summary.py out/lines 5.2 5.0 4.5 4.2
"""

import json
import sys
from pathlib import Path


def _load(folder, name, line):
    path = folder / f"{name}-{line}.json"
    return json.loads(path.read_text()) if path.is_file() else None


def _menus_as_integers(groups):
    """The documented difference: a Menu socket (5.0 and later) is compared as the integer
    that lines without Menu sockets build (reference/group_interfaces.py)."""
    root = str(Path(__file__).resolve().parents[1])
    if root not in sys.path:
        sys.path.insert(0, root)
    from surfgrad_addon.reference.group_interfaces import expected_signatures
    plain = json.loads(json.dumps(expected_signatures(menu_sockets=False)))
    return {name: {**sig, "sockets": [
        plain[name]["sockets"][k] if row["type"] == "NodeSocketMenu" else row
        for k, row in enumerate(sig["sockets"])]} for name, sig in groups.items()}


def _interfaces_note(folder, lines):
    """Differences between the lines' group interfaces beyond absent (gated) groups and the
    enumerations (Menu sockets from 5.0, integers before)."""
    dumps = {line: _load(folder, "interfaces", line) for line in lines}
    dumps = {line: _menus_as_integers(d["groups"]) for line, d in dumps.items() if d}
    if len(dumps) < 2:
        return [], sorted(dumps)
    problems = []
    base_line = next(iter(dumps))
    for line, groups in dumps.items():
        for name in set(groups) & set(dumps[base_line]):
            if groups[name] != dumps[base_line][name]:
                problems.append(f"{name}: {line} differs from {base_line}")
    return problems, sorted(dumps)


TIERS = ("numpy", "blender", "bake", "child", "eevee")     # tests/support/tiers.py


def _durations_table(folder, lines):
    """Tests and seconds per tier on each line (durations-<line>.json, from the tiers' hooks
    in tests/conftest.py): the figures the docs quote."""
    runs = {line: _load(folder, "durations", line) for line in lines}
    runs = {line: d for line, d in runs.items() if d}
    if not runs:
        return []
    out = ["## Suite time per tier: tests / seconds (set-up, call and teardown)\n",
           "| line | " + " | ".join(TIERS) + " | wall |", "|---|" + "---|" * (len(TIERS) + 1)]
    for line, d in runs.items():
        cells = [f"{t['tests']} / {t['seconds']:.1f} s" if (t := d["tiers"].get(name))
                 else "-" for name in TIERS]
        out.append(f"| {line} | " + " | ".join(cells) + f" | {d['wall_seconds']:.1f} s |")
    picked = {line: d["markexpr"] for line, d in runs.items() if d.get("markexpr")}
    if picked:
        out.append("")
        out.extend(f"- {line}: only the tests `-m {expr}` picks" for line, expr in picked.items())
    out.append("")
    return out


def main(argv):
    folder = Path(argv[0])
    lines = argv[1:]
    out, status, passed, failed = [], 0, 0, 0
    out.append("# surfgrad on every supported Blender line\n")
    out.append("| line | Blender | suite | seconds |")
    out.append("|---|---|---|---|")
    compares = {}
    for line in lines:
        run = _load(folder, "run", line) or {}
        bake = _load(folder, "bake-compare", line)
        compares[line] = bake
        ok = run.get("exit") == 0
        passed += ok
        failed += not ok
        durations = _load(folder, "durations", line) or {}
        version = bake["blender"] if bake else durations.get("blender") or "?"
        out.append(f"| {line} | {version} | "
                   f"{'passed' if ok else 'FAILED' if run else 'did not run'} | "
                   f"{run.get('seconds', '?')} |")
        if not ok:
            status = 1
    out.append("")
    have = [line for line in lines if compares.get(line)]
    if have:
        res = compares[have[0]]["resolution"]
        out.append(f"## Bakes against the reference ({res} x {res}): worst p99 / max degrees "
                   f"over Sphere, Torus, Plane, Transformed (bar 0.1 / 0.5)\n")
        out.append("| method | " + " | ".join(have) + " |")
        out.append("|---|" + "---|" * len(have))
        cases = []
        for line in have:
            for row in compares[line]["rows"]:
                case = row["method"] + ("" if row["method"] != "height-map"
                                        else f" {row['variant']}")
                if case not in cases:
                    cases.append(case)
        for case in cases:
            cells = []
            for line in have:
                rows = [r for r in compares[line]["rows"]
                        if r["method"] + ("" if r["method"] != "height-map"
                                          else f" {r['variant']}") == case]
                if rows:
                    cells.append(f"{max(r['p99_deg'] for r in rows):.4f} / "
                                 f"{max(r['max_deg'] for r in rows):.4f}")
                elif case.split()[0] in compares[line].get("skipped", {}):
                    cells.append("gated")
                else:
                    cells.append("-")
            out.append(f"| {case} | " + " | ".join(cells) + " |")
        for line in have:
            for method, why in compares[line].get("skipped", {}).items():
                out.append(f"\n- {line}, {method}: {why}")
        out.append("")
    out.extend(_durations_table(folder, lines))
    problems, compared = _interfaces_note(folder, lines)
    if len(compared) >= 2:
        out.append(f"## Group interfaces: {'identical' if not problems else 'DIFFERENT'} "
                   f"on {', '.join(compared)} (gated groups aside)\n")
        out.extend(f"- {p}" for p in problems)
        if problems:
            status = 1
    text = "\n".join(out) + "\n"
    (folder / "summary.md").write_text(text)
    print(text)
    print(f"lines: {passed} passed, {failed} failed")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
