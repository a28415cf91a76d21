"""The main job (reference stage): evaluate every method of the registry (harness/methods.py,
with its references and parameters) and the baselines on procedural scenes, and write normal
maps (PNG and NPY), an overview picture and a summary (JSON and Markdown).

Later stages add the Cycles bakes and their comparison; this stage needs numpy only
(matplotlib for the overview picture, skipped with a note if it is missing).
"""

import json
import time
from pathlib import Path

import numpy as np

from .. import reference as R
from ..reference import methods as M
from .methods import HEIGHT_BUMP_SCALE, METHODS
from .pictures import write_png

# The main job's own images: finer than the bake comparison's (its maps are looked at).
REFERENCE_IMAGE_SIZE = 256


class ReferenceInputs:
    """What a method's reference reads (harness/methods.py), without Blender: the images'
    pixels, the UV maps, the height-map variant and a decal projector's matrix."""

    def __init__(self, images, variant="hq", projector_matrix=None):
        self.images, self.variant = images, variant
        self.uv_map, self.detail_uv = "UVMap", "Detail"
        self.projector = type("Projector", (), {"matrix_world": projector_matrix})()

    def pixels(self, name):
        return self.images[name]


def _angles_deg(a, b):
    c = np.sum(a * b, axis=-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def _stats(deg):
    return {"mean_deg": float(np.mean(deg)), "p99_deg": float(np.percentile(deg, 99)),
            "max_deg": float(np.max(deg))}


def scenes():
    """The procedural scenes: a UV sphere, and a torus under a rotated, non-uniformly scaled
    transform (so world-space derivatives differ from object space)."""
    a = np.radians(35.0)
    m = np.eye(4)
    m[:3, :3] = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0],
                          [-np.sin(a), 0, np.cos(a)]]) @ np.diag([1.3, 0.8, 1.0])
    m[:3, 3] = [0.5, -0.25, 0.1]
    return {"sphere": R.meshes.uv_sphere(segments=48, rings=24),
            "torus": R.meshes.torus(matrix_world=m)}


def method_table(normal_img, detail_img, height_img):
    """name -> (function of TexelData giving unit normals (N, 3), the method it is a baseline
    for, or None): every registry method whose reference needs no Blender scene, each variant
    on its own, then the baselines."""
    projector = np.diag([0.6, 0.6, 2.0, 1.0])
    projector[:3, 3] = [0.0, 0.0, 0.5]
    images = {"normal": normal_img, "detail": detail_img, "height": height_img}
    table = {}
    for m in METHODS.values():
        if m.scene_only or m.same_reference_as:     # a Sampler method: its twin's maps
            continue
        for variant in m.variants:
            name = m.name if len(m.variants) == 1 else f"{m.name}-{variant}"
            inp = ReferenceInputs(images, variant, projector)
            table[name] = (lambda td, m=m, inp=inp: M.resolve(m.reference(inp, td)), None)
    table.update({
        "baseline-perlin1985-noise": (lambda td: M.volume_noise_perlin1985(td), "volume-noise"),
        "baseline-geiss-triplanar": (lambda td: M.triplanar_geiss_normal(td, normal_img),
                                     "triplanar"),
        "baseline-lxengine-height": (lambda td: M.height_map_lxengine(td, height_img,
                                                                      HEIGHT_BUMP_SCALE),
                                     "height-map-forward"),
    })
    return table


def run(out_dir, resolution=256, overwrite=False, log=print):
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    normal_img = R.images.hemisphere_tile_image(REFERENCE_IMAGE_SIZE)
    detail_img = R.images.hemisphere_tile_image(REFERENCE_IMAGE_SIZE, tiles=8, radius=0.6)
    height_img = R.images.wave_height_image(REFERENCE_IMAGE_SIZE)
    table = method_table(normal_img, detail_img, height_img)
    all_scenes = scenes()
    if not overwrite:
        planned = [out / f"{sc}_{name}.{ext}" for sc in all_scenes for name in table
                   for ext in ("npy", "png")]
        planned += [out / n for n in ("summary.json", "summary.md", "overview.png")]
        for path in planned:
            _fresh(path, overwrite)          # refuse before writing anything
    summary = {"resolution": resolution, "scenes": {},
               # Compiled kernels load once per process, before the timings below.
               "compiled_load_seconds": R.raster.load_compiled()}
    pictures = {}
    for scene_name, mesh in all_scenes.items():
        t0 = time.perf_counter()
        td = R.rasterize(mesh, "UVMap", resolution, resolution)
        raster_s = time.perf_counter() - t0
        base = M.unit_base_normal(td)
        interior = td.interior()
        log(f"[{scene_name}] rasterised {td.texel_count} texels "
            f"({interior.sum()} interior) in {raster_s:.3f} s")
        scene = {"texels": int(td.texel_count), "interior_texels": int(interior.sum()),
                 "raster_seconds": raster_s, "methods": {}}
        normals = {}
        for name, (fn, sg_method) in table.items():
            t0 = time.perf_counter()
            nrm = fn(td)
            seconds = time.perf_counter() - t0
            normals[name] = nrm
            unit_ok = np.isfinite(nrm).all(axis=-1) & (np.abs(np.linalg.norm(nrm, axis=-1) - 1) < 1e-9)
            entry = {"seconds": seconds, "finite_unit_fraction": float(unit_ok.mean()),
                     "tilt_from_base": _stats(_angles_deg(nrm[interior], base[interior]))}
            if sg_method is not None:
                entry["versus"] = sg_method
                entry["difference_from_sg"] = _stats(
                    _angles_deg(nrm[interior], normals[sg_method][interior]))
            scene["methods"][name] = entry
            img = td.to_image(nrm.astype(np.float32))
            np.save(_fresh(out / f"{scene_name}_{name}.npy", overwrite), img)
            rgba = np.concatenate([0.5 * np.nan_to_num(img) + 0.5,
                                   td.covered[..., None].astype(np.float64)], axis=-1)
            write_png(out / f"{scene_name}_{name}.png", rgba, overwrite=overwrite)
            pictures[(scene_name, name)] = rgba
            log(f"[{scene_name}] {name:28s} {seconds:7.3f} s  tilt mean "
                f"{entry['tilt_from_base']['mean_deg']:6.2f} deg"
                + (f"  differs from {sg_method} by mean "
                   f"{entry['difference_from_sg']['mean_deg']:.2f} / max "
                   f"{entry['difference_from_sg']['max_deg']:.2f} deg" if sg_method else ""))
        summary["scenes"][scene_name] = scene
    _fresh(out / "summary.json", overwrite).write_text(json.dumps(summary, indent=2))
    _fresh(out / "summary.md", overwrite).write_text(summary_markdown(summary))
    _overview(pictures, list(table), out / "overview.png", overwrite, log)
    log(f"wrote {out}/summary.md, summary.json, overview.png and per-method PNG/NPY maps")
    return summary


def _fresh(path, overwrite):
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass --overwrite to replace it, or choose "
                              f"another --out")
    return path


def summary_markdown(summary):
    lines = [f"# Reference evaluation at {summary['resolution']}^2", ""]
    for scene_name, scene in summary["scenes"].items():
        lines += [f"## {scene_name}: {scene['texels']} texels ({scene['interior_texels']} "
                  f"interior), rasterised in {scene['raster_seconds']:.3f} s", "",
                  "| method | seconds | finite unit | tilt mean (deg) | tilt max (deg) "
                  "| vs SG: mean / p99 / max (deg) |", "|---|---|---|---|---|---|"]
        for name, e in scene["methods"].items():
            diff = e.get("difference_from_sg")
            vs = (f"{e['versus']}: {diff['mean_deg']:.2f} / {diff['p99_deg']:.2f} / "
                  f"{diff['max_deg']:.2f}" if diff else "")
            lines.append(f"| {name} | {e['seconds']:.3f} | {e['finite_unit_fraction']:.4f} | "
                         f"{e['tilt_from_base']['mean_deg']:.2f} | "
                         f"{e['tilt_from_base']['max_deg']:.2f} | {vs} |")
        lines.append("")
    return "\n".join(lines)


def _overview(pictures, names, path, overwrite, log):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        log("matplotlib is not installed: skipping overview.png")
        return
    _fresh(path, overwrite)
    scene_names = sorted({s for s, _ in pictures})
    fig, axes = plt.subplots(len(scene_names), len(names),
                             figsize=(1.6 * len(names), 1.9 * len(scene_names)), squeeze=False)
    for r, scene_name in enumerate(scene_names):
        for c, name in enumerate(names):
            ax = axes[r, c]
            ax.imshow(np.clip(pictures[(scene_name, name)], 0, 1), origin="lower")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(name.replace("baseline-", "baseline\n"), fontsize=7)
            if c == 0:
                ax.set_ylabel(scene_name, fontsize=9)
    fig.suptitle("Reference normals baked into each UV layout (world-space normal as colour)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
