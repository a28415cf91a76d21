"""`python -m surfgrad_addon bench-render`: what surface-gradient groups cost in a render, against
Blender's own nodes for the same job (their twins).

One scene: a UV sphere filling the frame, Principled BSDF, one sun, Cycles on the CPU. Every
material is rendered in interleaved rounds (one render of each per round, so drift hits all
alike); the figures are medians. "Overhead" is the time above the same scene with no normal
perturbation, so the ratio of overheads is the ratio of what the two ways of bending the normal
cost. EEVEE (software GL here) is timed too: the first render of a material (its shader
compilation) and a later one. The look is checked by baking each material's normal: the SG
material against its twin where both mean the same thing, against the reference otherwise. The
graph behind each material is counted after expanding its groups (nodes, Normal Map nodes and
image lookups), and, what a sample really runs, Cycles' own SVM program size after its constant
folding (folded_cost.py: every material and each option on and off; deterministic, in the
line's unit).

Targets (issue 21) are ratios of whole render time to the twin, measured in one run.

On a GPU (--cycles-device CUDA or OPTIX, cycles_device.py) the same rounds and look bakes run
there, the CPU left out; --size and --samples scale the frame up so a render takes long enough
to time, --no-eevee skips EEVEE. The JSON names the device (cycles_device).
"""

import json
import statistics
import time
from pathlib import Path

import numpy as np

from ...addon.bake_request import SAMPLES_RANGE, whole_number_problem
from .. import cycles_device as D
from ..graph import Graph
from . import folded_cost
from . import render_materials as M

SIZE, SAMPLES, REPEATS = 320, 64, 3
SIZE_RANGE = (16, 8192)
QUICK = {"size": 96, "samples": 8, "repeats": 2, "eevee": False}
TARGETS = {"normal-map": 1.05, "height-forward": 1.05, "triplanar": 1.15, "second-uv": 1.10,
           "eevee": 1.3}


def build_scene(size, samples):
    import bpy
    from mathutils import Euler
    from .. import scenes
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = scenes.build(["Sphere"])["Sphere"]
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.seed = 0
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -3.2, 0.0)
    cam.rotation_euler = Euler((np.pi / 2, 0.0, 0.0))
    cam.data.lens = 50.0
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = Euler((0.7, 0.3, 0.4))
    scene.collection.objects.link(sun)
    ctx = M.images()
    return scene, obj, ctx



def node_counts(tree, seen=None):
    """Nodes after expanding groups (frames, reroutes and group sockets left out), Normal Map
    nodes and image lookups."""
    counts = {"nodes": 0, "normal_map_nodes": 0, "image_lookups": 0}
    for n in tree.nodes:
        if n.bl_idname in ("NodeFrame", "NodeReroute", "NodeGroupInput", "NodeGroupOutput",
                           "ShaderNodeOutputMaterial"):
            continue
        if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None:
            for k, v in node_counts(n.node_tree).items():
                counts[k] += v
            continue
        counts["nodes"] += 1
        counts["normal_map_nodes"] += n.bl_idname == "ShaderNodeNormalMap"
        counts["image_lookups"] += n.bl_idname == "ShaderNodeTexImage"
    return counts


def _render(scene, path):
    import bpy
    scene.render.filepath = str(path)
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    return time.perf_counter() - t0


def _look(obj, mats, key, look, ctx, log, device="CPU"):
    """Angle (mean, max degrees) between the SG material's normal and its twin's, or the
    bake-vs-reference figures of the method it uses; baked on `device` (scene.cycles.device)."""
    from .. import bake, compare
    if look == "twin":
        twin = next(c for c in M.cases() if c[0] == key)[3]
        px = {}
        for k in (key, twin):
            build = next(c for c in M.cases() if c[0] == k)[2]
            px[k], cov, _ = bake.bake_vector(obj, lambda nodes, links, b=build:
                                             b(Graph(nodes, links), ctx), 128, 128, "UVMap",
                                             device=device)
        both = cov
        err = compare.angle_deg(px[key][both].astype(np.float64),
                                px[twin][both].astype(np.float64))
        return {"against": "twin", "mean_deg": float(err.mean()), "max_deg": float(err.max())}
    report, _ = compare.compare_object(obj, look, 64, log=lambda *_: None, device=device)
    return {"against": f"reference ({look})", "mean_deg": report["mean_deg"],
            "max_deg": report["max_deg"]}


def _whole(value, name, lo, hi):
    """value if a whole number in [lo, hi], else a ValueError naming the option and the fix."""
    problem = whole_number_problem(name, value, lo, hi)
    if problem:
        raise ValueError(problem)
    return value


def run(out_dir, quick=False, overwrite=False, log=print, size=None, samples=None, eevee=True,
        cycles_device="CPU"):
    """The bench; size and samples (None: the defaults, or --quick's) override the frame,
    eevee=False skips EEVEE, cycles_device CPU, CUDA or OPTIX (refused before anything is
    written when Cycles finds no such device)."""
    import bpy
    out = Path(out_dir)
    if (out / "render_cost.json").exists() and not overwrite:
        raise FileExistsError(f"{out / 'render_cost.json'} exists; pass --overwrite to "
                              f"replace it")
    default_size, default_samples, repeats = (QUICK["size"], QUICK["samples"],
                                              QUICK["repeats"]) if quick \
        else (SIZE, SAMPLES, REPEATS)
    size = _whole(default_size if size is None else size, "--size", *SIZE_RANGE)
    samples = _whole(default_samples if samples is None else samples, "--samples",
                     *SAMPLES_RANGE)
    D.check(cycles_device)
    out.mkdir(parents=True, exist_ok=True)
    scene, obj, ctx = build_scene(size, samples)    # factory settings: the device after it
    with D.selected(scene, cycles_device) as chosen:
        result = _measure(scene, obj, ctx, out, size, samples, repeats, quick,
                          eevee and not quick, chosen, log)
    (out / "render_cost.json").write_text(json.dumps(result, indent=1))
    (out / "render_cost.md").write_text(markdown(result))
    _chart(result, out / "render_cost.png")
    log(markdown(result))
    return result


def _measure(scene, obj, ctx, out, size, samples, repeats, quick, with_eevee, chosen, log):
    """The interleaved Cycles rounds, EEVEE (with_eevee), the SVM counts and the look checks
    on the chosen device: the result written as render_cost.json."""
    import bpy
    mats = {key: M.material(f"RC {key}", build, ctx) for key, _, build, *_ in M.cases()}
    counts = {key: node_counts(m.node_tree) for key, m in mats.items()}
    frame = out / "frame.png"
    times = {key: [] for key in mats}
    t_start = time.perf_counter()
    for r in range(repeats + 1):                # round 0 warms caches and compiles
        for key, mat in mats.items():
            obj.data.materials.clear()
            obj.data.materials.append(mat)
            t = _render(scene, frame)
            if r:
                times[key].append(t)
        log(f"  Cycles round {r}/{repeats} done ({time.perf_counter() - t_start:.0f} s)")
    med = {k: statistics.median(v) for k, v in times.items()}
    eevee = {}
    if with_eevee:
        from ...reference.blender_lines import facts_for
        scene.render.engine = facts_for(bpy.app.version).eevee_engine
        scene.eevee.taa_render_samples = 4
        for key, mat in mats.items():
            obj.data.materials.clear()
            obj.data.materials.append(mat)
            first = _render(scene, frame)
            later = statistics.median(_render(scene, frame) for _ in range(2))
            eevee[key] = {"first_s": first, "later_s": later}
            log(f"  EEVEE {key}: first {first:.2f} s, later {later:.2f} s")
        scene.render.engine = "CYCLES"
    folded = folded_cost.counts()          # a child compiles the same materials
    svm = {r["key"]: r["svm"] for r in folded}
    rows = []
    for key, label, _, twin, target, look in M.cases():
        row = {"key": key, "label": label, "seconds": med[key], **counts[key], "svm": svm[key]}
        if twin:
            row["twin"] = twin
            row["ratio"] = med[key] / med[twin]
            row["svm_ratio"] = svm[key] / svm[twin]
            over_twin = med[twin] - med["none"]
            row["overhead_ratio"] = (med[key] - med["none"]) / over_twin if over_twin > 0 \
                else None
            if target:
                row["target"] = TARGETS[target]
            if eevee:
                row["eevee_first_ratio"] = eevee[key]["first_s"] / eevee[twin]["first_s"]
                row["eevee_later_ratio"] = eevee[key]["later_s"] / eevee[twin]["later_s"]
            if look:
                row["look"] = _look(obj, mats, key, look, ctx, log, chosen.scene_device)
        rows.append(row)
    # Marginal cost of a layer: (3 layers - 2 layers) in each chain.
    marginal = {"sg_s": med["layers3-sg"] - med["layers2-sg"],
                "builtin_s": med["layers3-builtin"] - med["layers2-builtin"]}
    return {"blender": bpy.app.version_string, "size": size, "samples": samples,
            "repeats": repeats, "quick": quick, "rows": rows, "marginal_layer": marginal,
            "eevee": eevee, "folded": folded, "seconds": time.perf_counter() - t_start,
            "cycles_device": chosen.description}


def markdown(result):
    lines = [f"Render cost, Cycles {result.get('cycles_device', 'CPU')}, "
             f"{result['size']} x {result['size']}, "
             f"{result['samples']} samples, median of {result['repeats']} interleaved rounds "
             f"(Blender {result['blender']})", "",
             "| material | render s | ratio to twin | target | overhead ratio | EEVEE first / "
             "later ratio | nodes (Normal Map, images) | SVM after folding (ratio) | look |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        ratio = f"{r['ratio']:.2f}x" if "ratio" in r else ""
        target = (f"<= {r['target']:.2f}x " + ("met" if r["ratio"] <= r["target"] else
                                               f"missed by {r['ratio'] - r['target']:.2f}"))\
            if "target" in r else ""
        over = f"{r['overhead_ratio']:.1f}x" if r.get("overhead_ratio") is not None else ""
        ee = (f"{r['eevee_first_ratio']:.2f} / {r['eevee_later_ratio']:.2f}"
              if "eevee_first_ratio" in r else "")
        look = (f"{r['look']['mean_deg']:.3f} / {r['look']['max_deg']:.3f} deg vs "
                f"{r['look']['against']}" if "look" in r else "")
        svm = f"{r['svm']}" + (f" ({r['svm_ratio']:.2f}x)" if "svm_ratio" in r else "")
        lines.append(f"| {r['label']} | {r['seconds']:.2f} | {ratio} | {target} | {over} | {ee} "
                     f"| {r['nodes']} ({r['normal_map_nodes']}, {r['image_lookups']}) | {svm} "
                     f"| {look} |")
    m = result["marginal_layer"]
    lines += ["", f"One more normal-map layer: SG {m['sg_s']:.3f} s, built-in "
                  f"{m['builtin_s']:.3f} s.", ""]
    return "\n".join(lines) + "\n" + folded_cost.markdown(result["folded"], result["blender"])


def _chart(result, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    rows = [r for r in result["rows"] if "ratio" in r]
    fig, ax = plt.subplots(figsize=(9, 4.2))
    y = np.arange(len(rows))
    # Green: its target met, orange: missed, grey: no target (a comparison shown for scale).
    ax.barh(y, [r["ratio"] for r in rows],
            color=["0.7" if "target" not in r else "#4c8" if r["ratio"] <= r["target"]
                   else "#d64" for r in rows])
    for i, r in enumerate(rows):
        if "target" in r:
            ax.plot([r["target"]] * 2, [i - 0.4, i + 0.4], color="k", lw=2)
    ax.axvline(1.0, color="0.5", lw=1, ls="--")
    ax.set_yticks(y, [r["label"] for r in rows], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("render time / Blender's own nodes\n(black: target; green: met, orange: "
                  "missed, grey: no target)")
    # The device on a line of its own: a GPU's name ("OPTIX: NVIDIA H100 80GB HBM3") ran the
    # title off the picture.
    ax.set_title(f"Render cost, Cycles {result.get('cycles_device', 'CPU')}\n"
                 f"{result['size']}\u00b2 pixels, {result['samples']} samples",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
