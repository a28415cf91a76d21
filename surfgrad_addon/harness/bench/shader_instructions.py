"""What a shading sample runs, in CPU instructions: every bench-render material rendered once in
a child process under valgrind's callgrind, which counts only inside Cycles' shader interpreter
(`svm_eval_nodes`, with every node and lookup it calls). The count is the same on every run,
whatever else the machine is doing, where render times on a shared 2-core machine move by 0.1
in a ratio (docs/performance.md): it tells two versions of a group apart to the node.

    python -m surfgrad_addon.harness.bench.shader_instructions [--out FILE] [--before-root DIR]
        [--keys KEY ...] [--jobs N] [--parts]

The scene is bench-render's (render_cost.build_scene: the UV sphere, Principled BSDF, the sun)
at 32 x 32 pixels and 4 samples on one thread. `--before-root` counts the same materials with
another checkout's groups too (its render_cost and render_materials), for a before/after table.
Instruction counts leave out what a count cannot see (cache misses, branch mispredictions in
the interpreter's dispatch), so they rank and size differences; render time stays the measure
of the targets.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
SIZE, SAMPLES = 32, 4
INTERPRETER = "*svm_eval_nodes*"        # Cycles' kernel/svm/svm.h, one instance per shader type
RENDERED = "SG-INSTRUCTIONS-RENDERED"

# Run in the child with the checkout to count (argv[1]) first on sys.path: only modules every
# checkout since bench-render has, so that an older commit can be counted too.
CHILD = f"""
import sys
sys.path.insert(0, sys.argv[1])
from surfgrad_addon.harness.bench import render_cost as RC, render_materials as M
import bpy  # after the checkout's modules: a checkout that cannot run fails before bpy loads
key, size, samples = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
scene, obj, ctx = RC.build_scene(size, samples)
scene.render.threads_mode = "FIXED"
scene.render.threads = 1
cases = M.cases()
try:                                    # the parts of --parts, where the checkout has them
    from surfgrad_addon.harness.bench import cost_parts
    cases = cases + cost_parts.cases()
except ImportError:
    pass
build = next(c for c in cases if c[0] == key)[2]
obj.data.materials.clear()
obj.data.materials.append(M.material("SG instructions " + key, build, ctx))
bpy.ops.render.render(write_still=False)
print({RENDERED!r}, key)
"""


class InstructionCountError(RuntimeError):
    """A count could not be had; the message names the material and why."""


def valgrind():
    """The valgrind executable, or InstructionCountError saying how to get it."""
    found = shutil.which("valgrind")
    if not found:
        raise InstructionCountError("valgrind is not installed: install it (Debian: apt install "
                                    "valgrind) to count shader instructions")
    return found


def summary_of(callgrind_out):
    """The instruction total a callgrind output file records ("summary:" line)."""
    for line in Path(callgrind_out).read_text().splitlines():
        if line.startswith("summary:"):
            return int(line.split()[1])
    raise InstructionCountError(f"{callgrind_out} holds no summary line")


def count(key, root=ROOT, python=None, size=SIZE, samples=SAMPLES, timeout=900):
    """Instructions inside the shader interpreter for one bench-render material `key`, rendered
    with the groups of checkout `root` by `python` (this interpreter by default)."""
    with tempfile.TemporaryDirectory(prefix="sg-instructions-") as tmp:
        out = Path(tmp) / "callgrind.out"
        cmd = [valgrind(), "--tool=callgrind", "--collect-atstart=no",
               f"--toggle-collect={INTERPRETER}", f"--callgrind-out-file={out}",
               python or sys.executable, "-c", CHILD, str(root), key, str(size), str(samples)]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                  cwd=tmp)
        except subprocess.TimeoutExpired:
            raise InstructionCountError(f"{key}: the render under valgrind took over {timeout} s")
        if done.returncode != 0 or f"{RENDERED} {key}" not in done.stdout:
            # The child's own last lines, not valgrind's summary (its lines start with ==pid==).
            tail = [line for line in (done.stderr + done.stdout).strip().splitlines()
                    if not line.startswith("==")][-3:]
            raise InstructionCountError(f"{key}: the child failed (exit {done.returncode}): "
                                        + " | ".join(tail))
        total = summary_of(out)
    if total == 0:
        raise InstructionCountError(f"{key}: nothing counted inside {INTERPRETER}: this "
                                    f"Blender's module has no symbol by that name")
    return total


def counts(keys, root=ROOT, jobs=None, **kw):
    """{key: instructions} for `keys`, `jobs` children at a time (default: the cores)."""
    keys = list(keys)
    with ThreadPoolExecutor(max_workers=jobs or os.cpu_count() or 1) as pool:
        return dict(zip(keys, pool.map(lambda k: count(k, root, **kw), keys)))


def rows_of(cases, now, before=None):
    """Table rows: each material's count, its twin's, and what it runs above the twin and above
    no perturbation at all ("none"), now and (given `before`) then."""
    rows = []
    for key, label, _, twin, *_ in cases:
        if key not in now:
            continue
        row = {"key": key, "label": label, "instructions": now[key]}
        if before is not None and key in before:
            row["instructions_before"] = before[key]
        if twin and twin in now:
            row["twin"] = twin
            row["ratio"] = now[key] / now[twin]
            if "none" in now and now[twin] > now["none"]:
                row["overhead_ratio"] = (now[key] - now["none"]) / (now[twin] - now["none"])
            if before is not None and key in before and twin in before:
                row["ratio_before"] = before[key] / before[twin]
        rows.append(row)
    return rows


def _commit(root):
    done = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True)
    return done.stdout.strip() or str(root)


def default_keys(cases):
    """Every material with a twin, its twin, and the scene without perturbation."""
    keys = ["none"]
    for key, _, _, twin, *_ in cases:
        if twin:
            keys += [k for k in (twin, key) if k not in keys]
    return keys


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m surfgrad_addon.harness.bench.shader_instructions",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="out/bench_render/shader_instructions.json")
    p.add_argument("--before-root", help="another checkout, counted the same way")
    p.add_argument("--keys", nargs="+", help="bench-render material keys (default: every "
                   "material with a twin, the twins and 'none')")
    p.add_argument("--jobs", type=int, help="children at a time (default: the cores)")
    p.add_argument("--parts", action="store_true", help="take the materials that miss their "
                   "target apart into their listings (cost_parts) instead")
    args = p.parse_args(argv)
    import bpy
    from . import cost_parts, render_materials as M
    cases = M.cases() + (cost_parts.cases() if args.parts else [])
    known = [c[0] for c in cases]
    keys = args.keys or (cost_parts.keys() if args.parts else default_keys(cases))
    unknown = [k for k in keys if k not in known]
    try:
        if unknown:
            raise InstructionCountError(f"no bench-render material {unknown}: choose from "
                                        f"{', '.join(known)}")
        valgrind()
        if args.before_root and not (Path(args.before_root) / "surfgrad_addon").is_dir():
            raise InstructionCountError(f"--before-root {args.before_root} is no surfgrad "
                                        f"checkout (it has no surfgrad_addon folder)")
        before = counts(keys, Path(args.before_root).resolve(), args.jobs) \
            if args.before_root else None
        now = counts(keys, ROOT, args.jobs)
    except InstructionCountError as ex:
        print(f"shader_instructions: {ex}", file=sys.stderr)
        return 2
    result = {"blender": bpy.app.version_string, "size": SIZE, "samples": SAMPLES,
              "counted": f"instructions inside {INTERPRETER} (valgrind callgrind), one thread",
              "commit": _commit(ROOT), "rows": rows_of(cases, now, before)}
    if args.parts:
        result["counts"] = now
        result["parts"] = cost_parts.rows(now)
    if before is not None:
        result["before_commit"] = _commit(args.before_root)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1) + "\n")
    for r in result["rows"]:
        ratio = f"  {r['ratio']:.3f}x its twin" if "ratio" in r else ""
        print(f"{r['instructions']:>12,}  {r['label']}{ratio}")
    for whole in result.get("parts", []):
        print(f"{whole['overhead']:>12,}  above its twin: {whole['label']}")
        for part in whole["parts"]:
            print(f"{part['instructions']:>16,}  {part['label']}")
        print(f"{whole['remainder']:>16,}  remainder")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
