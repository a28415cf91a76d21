"""What the proof costs beside the bake (not a test), written as JSON:

    python -m surfgrad_addon bench-compare [--sizes 2048 4096] [--repeats 3] [--out FILE]

For each size, `repeats` pairs of child processes run one after the other (interleaved, the
order alternating, so the load of a shared machine falls on both alike):
- **bake alone**: a child that does what compare does up to its bake and nothing after: the
  test scene, the method's images and node graph, the same bake (bake_vector_in_pieces) read
  back into memory, then leaving as compare's command line does (command_line.leave)
  (`python -m <this module> --bake-alone ...`);
- **compare**: `python -m surfgrad_addon compare --object Sphere ...`, start to JSON and heat
  map written.
Each child is timed from launch to exit, wall and CPU (user + system, all its threads). Per
pair three ratios, then the median over the pairs:
- `compare / bake alone`: the two processes' walls;
- `compare / bake operator`: compare's wall over the bake alone child's Cycles bake
  (bpy.ops.object.bake) seconds: the stricter figure, every start-up cost on compare's side;
- `compare CPU / bake alone CPU`: the work each did, which other processes on a shared
  machine change much less than the walls (they stretch a wall by the time they hold a core).
"""

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SIZES = (2048, 4096)
METHOD = "normal-map"
OBJECT = "Sphere"
# The checkout: the folder holding the package (wherever in it this module lives).
ROOT = next(p.parent for p in Path(__file__).resolve().parents if p.name == "surfgrad_addon")
MODULE = __spec__.name if __spec__ else __name__       # this module, wherever it lives
RATIOS = ("compare_over_bake_alone", "compare_over_bake_operator",
          "compare_cpu_over_bake_alone_cpu")


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(cmd, root):
    """(wall seconds, CPU seconds, stdout) of a child; raises RuntimeError with its last error
    line."""
    cpu0 = _children_cpu()
    t0 = time.perf_counter()
    # Both children allocate as compare's command line does (surfgrad_addon/__main__.py).
    env = dict(os.environ, NUMPY_MADVISE_HUGEPAGE=os.environ.get("NUMPY_MADVISE_HUGEPAGE", "0"))
    proc = subprocess.run(cmd, cwd=root, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - cpu0              # the waited-for child's (and its children's)
    if proc.returncode != 0:
        lines = (proc.stderr or proc.stdout).strip().splitlines()
        raise RuntimeError(f"{' '.join(cmd[1:4])} failed (exit {proc.returncode}): "
                           f"{lines[-1] if lines else 'no output'}")
    return wall, cpu, proc.stdout


def bake_alone_child(method, size, python=None, root=ROOT):
    """{wall_seconds, cpu_seconds, bake_seconds} of a child that only bakes."""
    wall, cpu, out = _timed([python or sys.executable, "-m", MODULE, "--bake-alone", method,
                             str(size)], root)
    return {"wall_seconds": wall, "cpu_seconds": cpu,
            "bake_seconds": json.loads(out.strip().splitlines()[-1])}


def compare_child(method, size, python=None, root=ROOT):
    """{wall_seconds, cpu_seconds, bake_seconds, reference_seconds, max_deg} of a compare
    child."""
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "report.json"
        wall, cpu, _ = _timed([python or sys.executable, "-m", "surfgrad_addon", "compare",
                               "--object", OBJECT, "--method", method, "--resolution",
                               str(size), "--json", str(report)], root)
        r = json.loads(report.read_text())
    return {"wall_seconds": wall, "cpu_seconds": cpu, "bake_seconds": r["bake_seconds"],
            "reference_seconds": r["reference_seconds"], "max_deg": r["max_deg"]}


def _pair(b, c):
    """One pair's children and ratios."""
    return {"bake_alone": b, "compare": c,
            "compare_over_bake_alone": c["wall_seconds"] / b["wall_seconds"],
            "compare_over_bake_operator": c["wall_seconds"] / b["bake_seconds"],
            "compare_cpu_over_bake_alone_cpu": c["cpu_seconds"] / b["cpu_seconds"]}


def _medians(pairs):
    return {key: float(np.median([p[key] for p in pairs])) for key in RATIOS} | \
        {"pairs": pairs}


def measure(size, method=METHOD, repeats=3, python=None, root=ROOT, compare_root=None,
            log=print, before_root=None):
    """The interleaved pairs at one size and their median ratios. before_root: a second
    checkout whose compare runs in the same rounds (the order rotating), each timed against
    the same bake alone child: before and now under the same load ("before")."""
    kinds = ("bake", "compare") + (("before",) if before_root else ())
    roots = {"compare": compare_root or root, "before": before_root}
    pairs, before = [], []
    for i in range(repeats):
        order = kinds[i % len(kinds):] + kinds[:i % len(kinds)]
        if len(kinds) == 2 and i % 2:
            order = ("compare", "bake")
        load = os.getloadavg()[0]
        got = {}
        for kind in order:
            got[kind] = (bake_alone_child(method, size, python, root) if kind == "bake" else
                         compare_child(method, size, python, roots[kind]))
        for kind, out in (("compare", pairs), ("before", before)):
            if kind not in got:
                continue
            out.append(_pair(got["bake"], got[kind]) | {"load_average": load})
            p, c, b = out[-1], got[kind], got["bake"]
            log(f"{size}^2 {kind} {i + 1}/{repeats}: compare {c['wall_seconds']:.2f} s, bake "
                f"alone {b['wall_seconds']:.2f} s (operator {b['bake_seconds']:.2f} s): "
                f"{p['compare_over_bake_alone']:.2f}x / {p['compare_over_bake_operator']:.2f}x;"
                f" CPU {c['cpu_seconds']:.2f} s against {b['cpu_seconds']:.2f} s: "
                f"{p['compare_cpu_over_bake_alone_cpu']:.2f}x (load {load:.1f})")
    result = _medians(pairs)
    if before:
        result["before"] = _medians(before) | {"compare_root": str(before_root)}
    return result


def run(out_path, sizes=SIZES, method=METHOD, repeats=3, overwrite=False, python=None,
        root=ROOT, compare_root=None, log=print, before_root=None):
    out_path = Path(out_path)
    if out_path.exists() and not overwrite:
        raise FileExistsError(f"{out_path} exists; pass --overwrite to replace it")
    results = {"method": method, "object": OBJECT, "repeats": repeats,
               "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                           "load_average": os.getloadavg()},
               "compare_root": str(compare_root or root), "sizes": {}}
    for size in sizes:
        results["sizes"][str(size)] = measure(size, method, repeats, python, root,
                                              compare_root, log, before_root)
        r = results["sizes"][str(size)]
        for name, figures in (("now", r), ("before", r.get("before"))):
            if figures:
                log(f"{size}^2 {name}: compare / bake alone "
                    f"{figures['compare_over_bake_alone']:.2f}x, compare / bake operator "
                    f"{figures['compare_over_bake_operator']:.2f}x, CPU "
                    f"{figures['compare_cpu_over_bake_alone_cpu']:.2f}x (median of {repeats})")
    results["machine"]["load_average_after"] = os.getloadavg()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(json.dumps(results, indent=2))
    log(f"wrote {out_path}")
    return results


def _bake_alone(method, size):
    """The child: compare's way to its bake and read-back, then nothing; prints the bake
    operator's seconds (JSON)."""
    import bpy

    # Absolute: the same wherever in the harness this module lives.
    from surfgrad_addon.harness import bake as B, compare as C, scenes
    from surfgrad_addon.harness.methods import METHODS, resolve_sg
    scenes.new_scene()
    obj = bpy.data.objects[OBJECT]
    m = METHODS[method]
    inp = C.prepare_inputs(obj, variant="hq" if "hq" in m.variants else m.variants[0])

    def build(nodes, links):
        out = m.graph(inp, nodes, links)
        return out if out.name == "Normal" else resolve_sg(nodes, links, out)
    with m.scene(obj, inp):
        _, _, seconds = B.bake_vector_in_pieces(obj, build, size, size, uv_map=inp.uv_map,
                                                rgba=True)
    print(json.dumps(seconds))


def _main():
    """The bake alone child (--bake-alone), or the bench with a before checkout timed in the
    same rounds (--before-root, also on the command line's bench-compare)."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--bake-alone", nargs=2, metavar=("METHOD", "SIZE"))
    parser.add_argument("--out", default="out/bench_compare.json")
    # The command line's types (addon/number_options.py): --repeats 0 wrote NaN medians.
    from ...addon import number_options as NO
    parser.add_argument("--sizes", type=NO.whole(*NO.COMPARE_RESOLUTION_RANGE), nargs="+",
                        default=list(SIZES), action=NO.Distinct)
    parser.add_argument("--repeats", type=NO.whole(*NO.REPEATS_RANGE), default=3)
    parser.add_argument("--before-root", default=None,
                        help="an earlier checkout whose compare runs in the same rounds")
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args()
    if args.bake_alone:
        _bake_alone(args.bake_alone[0], int(args.bake_alone[1]))
    else:
        run(args.out, tuple(args.sizes), repeats=args.repeats, overwrite=args.overwrite,
            before_root=args.before_root)


if __name__ == "__main__":
    _main()
    # Both children leave the same way (compare's does through its command line).
    from surfgrad_addon.addon.command_line import leave
    sys.exit(leave(0))
