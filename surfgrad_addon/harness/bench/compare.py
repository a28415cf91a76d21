"""What the proof costs beside the bake (not a test), written as JSON:

    python -m surfgrad_addon bench-compare [--sizes 2048 4096] [--repeats 3] [--out FILE]

For each size, `repeats` pairs of child processes run one after the other (interleaved, the
order alternating, so the load of a shared machine falls on both alike):
- **bake alone**: a child that does what compare does up to its bake and nothing after: the
  test scene, the method's images and node graph, the same bake (bake_vector_in_pieces) read
  back into memory (`python -m surfgrad_addon.harness.bench.compare --bake-alone ...`);
- **compare**: `python -m surfgrad_addon compare --object Sphere ...`, start to JSON and heat
  map written.
Each child is timed from launch to exit. Per pair two ratios, then the median over the pairs:
- `compare / bake alone`: the two processes' walls;
- `compare / bake operator`: compare's wall over the bake alone child's Cycles bake
  (bpy.ops.object.bake) seconds: the stricter figure, every start-up cost on compare's side.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SIZES = (2048, 4096)
METHOD = "normal-map"
OBJECT = "Sphere"
ROOT = Path(__file__).resolve().parents[3]


def _timed(cmd, root):
    """(wall seconds, stdout) of a child; raises RuntimeError with its last error line."""
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=root, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        lines = (proc.stderr or proc.stdout).strip().splitlines()
        raise RuntimeError(f"{' '.join(cmd[1:4])} failed (exit {proc.returncode}): "
                           f"{lines[-1] if lines else 'no output'}")
    return wall, proc.stdout


def bake_alone_child(method, size, python=None, root=ROOT):
    """{wall_seconds, bake_seconds} of a child that only bakes."""
    wall, out = _timed([python or sys.executable, "-m", "surfgrad_addon.harness.bench.compare",
                        "--bake-alone", method, str(size)], root)
    return {"wall_seconds": wall, "bake_seconds": json.loads(out.strip().splitlines()[-1])}


def compare_child(method, size, python=None, root=ROOT):
    """{wall_seconds, bake_seconds, reference_seconds, max_deg} of a compare child."""
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "report.json"
        wall, _ = _timed([python or sys.executable, "-m", "surfgrad_addon", "compare",
                          "--object", OBJECT, "--method", method, "--resolution", str(size),
                          "--json", str(report)], root)
        r = json.loads(report.read_text())
    return {"wall_seconds": wall, "bake_seconds": r["bake_seconds"],
            "reference_seconds": r["reference_seconds"], "max_deg": r["max_deg"]}


def measure(size, method=METHOD, repeats=3, python=None, root=ROOT, compare_root=None,
            log=print):
    """The interleaved pairs at one size and their median ratios."""
    pairs = []
    for i in range(repeats):
        order = ("bake", "compare") if i % 2 == 0 else ("compare", "bake")
        got = {}
        for kind in order:
            if kind == "bake":
                got[kind] = bake_alone_child(method, size, python, root)
            else:
                got[kind] = compare_child(method, size, python, compare_root or root)
        b, c = got["bake"], got["compare"]
        pairs.append({"bake_alone": b, "compare": c,
                      "compare_over_bake_alone": c["wall_seconds"] / b["wall_seconds"],
                      "compare_over_bake_operator": c["wall_seconds"] / b["bake_seconds"]})
        log(f"{size}^2 pair {i + 1}/{repeats}: compare {c['wall_seconds']:.2f} s, bake alone "
            f"{b['wall_seconds']:.2f} s (operator {b['bake_seconds']:.2f} s): "
            f"{pairs[-1]['compare_over_bake_alone']:.2f}x / "
            f"{pairs[-1]['compare_over_bake_operator']:.2f}x")
    med = lambda key: float(np.median([p[key] for p in pairs]))
    return {"compare_over_bake_alone": med("compare_over_bake_alone"),
            "compare_over_bake_operator": med("compare_over_bake_operator"), "pairs": pairs}


def run(out_path, sizes=SIZES, method=METHOD, repeats=3, overwrite=False, python=None,
        root=ROOT, compare_root=None, log=print):
    out_path = Path(out_path)
    if out_path.exists() and not overwrite:
        raise FileExistsError(f"{out_path} exists; pass --overwrite to replace it")
    results = {"method": method, "object": OBJECT, "repeats": repeats,
               "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                           "load_average": os.getloadavg()},
               "compare_root": str(compare_root or root), "sizes": {}}
    for size in sizes:
        results["sizes"][str(size)] = measure(size, method, repeats, python, root,
                                              compare_root, log)
        r = results["sizes"][str(size)]
        log(f"{size}^2: compare / bake alone {r['compare_over_bake_alone']:.2f}x, compare / "
            f"bake operator {r['compare_over_bake_operator']:.2f}x (median of {repeats})")
    results["machine"]["load_average_after"] = os.getloadavg()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(json.dumps(results, indent=2))
    log(f"wrote {out_path}")
    return results


def _bake_alone(method, size):
    """The child: compare's way to its bake and read-back, then nothing; prints the bake
    operator's seconds (JSON)."""
    import bpy

    from .. import bake as B
    from .. import compare as C
    from .. import scenes
    from ..methods import METHODS, resolve_sg
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


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--bake-alone", nargs=2, metavar=("METHOD", "SIZE"), required=True)
    args = parser.parse_args()
    _bake_alone(args.bake_alone[0], int(args.bake_alone[1]))
