"""`python -m surfgrad_addon.harness.bench.noise_footprint [OUT] [--samples N] [--quick]`: what
SG Noise's Filter Footprint buys where it matters, a receding plane.

One scene: a 60 m plane under a low sun, the camera a metre above it looking at the horizon, SG
Noise -> SG Volume Gradient -> SG Resolve on a Principled BSDF, Cycles CPU, 160x90. Each way
(filter off, on) is rendered at 1 sample per pixel and compared with a many-sample render of the
unfiltered scene (the pixel-averaged truth of the same surface):
  error    RMSE of the 1-spp image against the truth (linear RGB, ground pixels),
  sparkle  the mean per-pixel variance over FRAMES 1-spp frames of a slow camera move (2 cm a
           frame; one seed, so the sampling pattern stays put and what changes is the surface),
  cost     the 1-spp render time (median of the frames; mostly a render's fixed costs), the
           many-sample render time of each (mostly shading), and Cycles' SVM program size
           (svm_counts, in the line's unit).
Writes OUT/noise_footprint.json and OUT/noise_footprint.png (the images, error maps and
figures); docs/noise_footprint.* are a copy.
"""

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

WIDTH, HEIGHT = 160, 90
TRUTH_SAMPLES = 1024
FRAMES = 8
STEP = 0.02                  # camera move per frame (metres)
NOISE_SCALE, AMOUNT = 4.0, 0.15
WAYS = ("off", "on")
KEYS = {"off": "noise-footprint-off", "on": "noise-footprint-on"}


def build_materials():
    """The two materials (filter off, on); also the svm_counts child's build."""
    from ...addon import groups as G
    from ..graph import Graph
    from ...addon.compat import new_material
    mats = {}
    for way in WAYS:
        mat = new_material(KEYS[way])
        tree = mat.node_tree
        tree.nodes.clear()
        g = Graph(tree.nodes, tree.links)
        out = g.node("ShaderNodeOutputMaterial")
        bsdf = g.node("ShaderNodeBsdfPrincipled")
        bsdf.inputs["Base Color"].default_value = (0.6, 0.6, 0.6, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.35
        g.link(bsdf.outputs[0], out.inputs["Surface"])
        noise = g.group(G.noise_group(), Scale=NOISE_SCALE)
        noise.inputs["Filter Footprint"].default_value = way == "on"
        vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                     Bump_Scale=AMOUNT)
        g.link(g.resolve(vg.outputs[0]), bsdf.inputs["Normal"])
        mats[way] = mat
    return mats


def build_scene():
    import bpy
    from mathutils import Euler
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=60.0)
    plane = bpy.context.active_object
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.seed = 0
    scene.cycles.max_bounces = 2
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.06, 0.08, 1)
    scene.world = world
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -29.0, 1.0)
    cam.rotation_euler = Euler((np.pi / 2 - 0.12, 0.0, 0.0))
    cam.data.lens = 35.0
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 4.0
    sun.rotation_euler = Euler((1.25, 0.0, 0.6))      # low: the bump shows
    scene.collection.objects.link(sun)
    return scene, plane, cam


def _render(scene, samples):
    """One render: (linear RGB float array (H, W, 3), seconds)."""
    import bpy
    scene.cycles.samples = samples
    t0 = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t0
    img = bpy.data.images["Render Result"]
    # The Render Result's pixels are read through a viewer copy: save and load as EXR.
    path = Path(bpy.app.tempdir or "/tmp") / "noise_footprint_frame.exr"
    img.save_render(str(path), scene=scene)
    loaded = bpy.data.images.load(str(path))
    px = np.array(loaded.pixels[:], dtype=np.float32).reshape(HEIGHT, WIDTH, 4)[::-1, :, :3]
    bpy.data.images.remove(loaded)
    return px, seconds


def _regions(ground):
    """The ground's far half (the rows nearer the horizon) and its near half."""
    rows = np.nonzero(ground.any(axis=1))[0]
    cut = (rows.min() + rows.max() + 1) // 2
    far, near = ground.copy(), ground.copy()
    far[cut:] = False
    near[:cut] = False
    return {"far": far, "near": near}


def measure(truth_samples=TRUTH_SAMPLES, frames=FRAMES, log=print):
    import bpy
    from . import svm_counts as S
    scene, plane, cam = build_scene()
    mats = build_materials()
    plane.data.materials.append(mats["off"])
    start = cam.location.y
    result = {"blender": bpy.app.version_string, "size": [WIDTH, HEIGHT],
              "truth_samples": truth_samples, "frames": frames, "step_m": STEP,
              "noise_scale": NOISE_SCALE, "amount": AMOUNT, "ways": {}}
    images = {}
    plane.material_slots[0].material = mats["off"]
    log(f"truth: {truth_samples} samples, filter off")
    truth, truth_s = _render(scene, truth_samples)
    result["truth_seconds"] = truth_s
    images["truth"] = truth
    ground = np.zeros((HEIGHT, WIDTH), dtype=bool)
    ground[int(HEIGHT * 0.25):] = True       # below the horizon (the camera pitches down)
    ground &= truth.sum(-1) > 0.3
    for way in WAYS:
        plane.material_slots[0].material = mats[way]
        seq, times = [], []
        for f in range(frames):
            cam.location.y = start + STEP * f
            px, s = _render(scene, 1)
            seq.append(px)
            times.append(s)
        cam.location.y = start
        first = seq[0]
        err = np.sqrt(np.mean((first - truth)[ground] ** 2))
        var = np.var(np.stack(seq), axis=0).mean(-1)
        images[way] = first
        images[f"{way}:err"] = np.abs(first - truth).mean(-1)
        images[f"{way}:var"] = var
        result["ways"][way] = {"rmse": float(err), "sparkle": float(var[ground].mean()),
                               "render_seconds": float(statistics.median(times)),
                               "frame_seconds": [float(t) for t in times]}
        for name, part in _regions(ground).items():
            result["ways"][way][name] = {
                "rmse": float(np.sqrt(np.mean((first - truth)[part] ** 2))),
                "sparkle": float(var[part].mean())}
        log(f"filter {way}: {result['ways'][way]}")
    if "on" in result["ways"]:
        on, off = result["ways"]["on"], result["ways"]["off"]
        result["time_ratio"] = on["render_seconds"] / off["render_seconds"]
    # Filtered truth too: what the filter converges to (its bias against the surface).
    plane.material_slots[0].material = mats["on"]
    ftruth, ftruth_s = _render(scene, truth_samples)
    result["filtered_truth_seconds"] = ftruth_s
    # At many samples the shading dominates (at 1 spp a render's fixed costs do).
    result["truth_time_ratio"] = ftruth_s / truth_s
    result["filtered_truth_rmse"] = float(np.sqrt(np.mean((ftruth - truth)[ground] ** 2)))
    counts = S.svm_counts(list(KEYS.values()),
                          build="surfgrad_addon.harness.bench.noise_footprint:build_materials")
    result["svm"] = {way: counts[KEYS[way]].nodes for way in WAYS}
    result["svm_unit"] = counts[KEYS["off"]].unit
    result["ground_pixels"] = int(ground.sum())
    return result, images


def chart(result, images, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def show(ax, img, title):
        ax.imshow(np.clip(img / (1 + img), 0, 1) ** (1 / 2.2), interpolation="nearest")
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    fig, axes = plt.subplots(3, 3, figsize=(11, 5.6))
    w = result["ways"]
    show(axes[0, 0], images["truth"], f"truth: {result['truth_samples']} spp, filter off")
    show(axes[0, 1], images["off"], f"1 spp, filter off (RMSE {w['off']['rmse']:.4f})")
    show(axes[0, 2], images["on"], f"1 spp, filter on (RMSE {w['on']['rmse']:.4f})")
    vmax = max(images["off:err"].max(), 1e-6)
    for col, way in ((1, "off"), (2, "on")):
        axes[1, col].imshow(images[f"{way}:err"], cmap="magma", vmin=0, vmax=vmax)
        axes[1, col].set_title(f"|1 spp - truth|, filter {way}", fontsize=8)
        axes[1, col].axis("off")
        axes[2, col].imshow(images[f"{way}:var"], cmap="magma", vmin=0,
                            vmax=max(images["off:var"].max(), 1e-9))
        axes[2, col].set_title(f"variance over {result['frames']} frames, filter {way} "
                               f"(mean {w[way]['sparkle']:.2e})", fontsize=8)
        axes[2, col].axis("off")
    ax = axes[1, 0]
    labels = ["RMSE", "sparkle", "time 1 spp", f"time {result['truth_samples']} spp",
              f"SVM ({result['svm_unit']})"]
    ratios = [w["on"]["rmse"] / w["off"]["rmse"], w["on"]["sparkle"] / w["off"]["sparkle"],
              result["time_ratio"], result["truth_time_ratio"],
              result["svm"]["on"] / result["svm"]["off"]]
    ax.barh(range(5), ratios, color=["#4c8", "#4c8", "#d94", "#d94", "#d94"])
    ax.axvline(1.0, color="0.4", ls="--", lw=1)
    ax.set_yticks(range(5), labels, fontsize=8)
    ax.invert_yaxis()
    ax.set_title("filter on / off", fontsize=8)
    for i, r in enumerate(ratios):
        ax.text(r, i, f" {r:.2f}", va="center", fontsize=7)
    axes[2, 0].axis("off")
    axes[2, 0].text(0, 0.5, f"Blender {result['blender']}, Cycles CPU {WIDTH}x{HEIGHT}\n"
                    f"SG Noise scale {NOISE_SCALE}, 4 octaves,\nfade 1 - smoothstep(1/4, 1/2,"
                    f" 2^i F)\nfiltered truth vs truth: RMSE "
                    f"{result['filtered_truth_rmse']:.4f}", fontsize=8, va="center")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def run(out_dir, truth_samples=TRUTH_SAMPLES, frames=FRAMES, log=print):
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result, images = measure(truth_samples, frames, log)
    (out / "noise_footprint.json").write_text(json.dumps(result, indent=1))
    chart(result, images, out / "noise_footprint.png")
    log(f"wrote {out / 'noise_footprint.json'} and {out / 'noise_footprint.png'}")
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m surfgrad_addon.harness.bench.noise_footprint")
    parser.add_argument("out", nargs="?", default="out/noise_footprint")
    parser.add_argument("--samples", type=int, default=TRUTH_SAMPLES,
                        help="samples of the truth render")
    parser.add_argument("--frames", type=int, default=FRAMES)
    args = parser.parse_args(argv)
    run(args.out, args.samples, args.frames)


if __name__ == "__main__":
    sys.exit(main())
