"""Bake a method's node groups with Cycles and compare them texel by texel with the reference.

    python -m surfgrad_addon compare --blend FILE --object NAME --method METHOD \\
        --resolution N --json OUT [--uv-map NAME] [--image PATH] [--variant V]

Without --blend the procedural test scene (blender/scenes.py) is used. The bake and the
reference see the same mesh (the evaluated object, Blender's MikkTSpace tangents), the same
images (their pixels as Cycles reads them) and the same parameters. Angular error is measured
over interior texels (whose 3 x 3 neighbourhood is covered): texels at UV-island borders and
texels only one side covered are excluded and counted.
"""

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import reference as R
from ..addon import groups as G
from ..addon.normal_bake import resolution_problem
from ..reference import methods as M
from . import bake as B
from .mesh_data import MeshDataError, mesh_arrays_from_object
from .methods import METHODS, cases, resolve_sg, unavailable_reason
from .png import write_png

DETAIL_UV = "Detail"
NORMAL_IMAGE_SIZE = 128
HEIGHT_IMAGE_SIZE = 32       # small: bakes magnify it, where the variants differ


RESOLUTION_RANGE = (8, 8192)


class CompareError(ValueError):
    """Bad input for a comparison: the message names the thing and the fix."""


@dataclass
class Inputs:
    """Everything a method needs, shared by its node graph and its reference."""
    obj: object
    uv_map: str
    detail_uv: str
    images: dict = field(default_factory=dict)      # name -> (numpy pixels (H, W, C), bpy image)
    variant: str = "hq"
    projector: object = None                         # a temporary decal projector (an empty)
    modifier: object = None                          # a temporary SG Displace modifier

    def pixels(self, name):
        return self.images[name][0]

    def bpy_image(self, name):
        return self.images[name][1]


# Inputs -----------------------------------------------------------------------------------------

def bpy_float_image(name, pixels):
    import bpy
    px = np.asarray(pixels, dtype=np.float32)
    if px.ndim == 2:
        px = np.repeat(px[..., None], 3, axis=-1)
    h, w = px.shape[:2]
    if px.shape[2] == 3:
        px = np.concatenate([px, np.ones((h, w, 1), np.float32)], axis=-1)
    img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(px.ravel())
    img.pack()
    return img


def _load_image(path):
    """An image file as Cycles will read it (Non-Color), and its pixels for the reference."""
    import bpy
    path = Path(path)
    if not path.is_file():
        raise CompareError(f"image {str(path)!r} does not exist; give an existing file to "
                           f"--image")
    try:
        img = bpy.data.images.load(str(path.resolve()), check_existing=False)
    except RuntimeError as err:
        raise CompareError(f"image {str(path)!r} could not be read ({err})") from err
    img.colorspace_settings.name = "Non-Color"
    w, h = img.size
    if w == 0 or h == 0:
        raise CompareError(f"image {str(path)!r} is empty")
    px = np.empty(w * h * img.channels, dtype=np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, img.channels).astype(np.float64)
    if not np.all(np.isfinite(px)):
        raise CompareError(f"image {str(path)!r} has non-finite pixels (NaN or Inf); fix "
                           f"or clamp them before using it as a bump map")
    return px[..., :3] if img.channels >= 3 else px[..., 0], img


def prepare_inputs(obj, uv_map=None, image=None, variant="hq"):
    if obj.type != "MESH":
        raise CompareError(f"object {obj.name!r} is a {obj.type.lower()}, not a mesh")
    names = [uv.name for uv in obj.data.uv_layers]
    if not names:
        raise CompareError(f"object {obj.name!r} has no UV map; add one (UV > Unwrap)")
    if uv_map is None:
        active = [uv.name for uv in obj.data.uv_layers if uv.active_render]
        uv_map = active[0] if active else names[0]
    elif uv_map not in names:
        raise CompareError(f"object {obj.name!r} has no UV map named {uv_map!r}; it has "
                           f"{names}")
    detail = DETAIL_UV if DETAIL_UV in names else uv_map
    inp = Inputs(obj=obj, uv_map=uv_map, detail_uv=detail, variant=variant)
    if isinstance(image, np.ndarray):       # pixels given directly (the stability suite)
        inp.images["normal"] = (image[..., :3].astype(np.float32).astype(np.float64),
                                bpy_float_image("sg_normal", image))
    elif image is not None:
        px, img = _load_image(image)
        inp.images["normal"] = (px, img)
    else:
        px = R.images.hemisphere_tile_image(NORMAL_IMAGE_SIZE)
        inp.images["normal"] = (px.astype(np.float32).astype(np.float64),
                                bpy_float_image("sg_normal", px))
    px = R.images.hemisphere_tile_image(NORMAL_IMAGE_SIZE, tiles=8, radius=0.6)
    inp.images["detail"] = (px.astype(np.float32).astype(np.float64),
                            bpy_float_image("sg_detail", px))
    h = R.images.wave_height_image(HEIGHT_IMAGE_SIZE)
    inp.images["height"] = (h.astype(np.float32).astype(np.float64),
                            bpy_float_image("sg_height", h))
    return inp


# The comparison -----------------------------------------------------------------------------------

def angle_deg(a, b):
    """Angle between vectors in float64, accurate near zero (atan2 of |a x b| and a . b).
    A zero-length or non-finite vector has no direction: it scores 180 degrees, never 0."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                np.sum(a * b, axis=-1)))
    valid = (np.isfinite(a).all(-1) & np.isfinite(b).all(-1)
             & (np.linalg.norm(a, axis=-1) > 0) & (np.linalg.norm(b, axis=-1) > 0))
    return np.where(valid, ang, 180.0)


def compare_object(obj, method, resolution, uv_map=None, image=None, variant="hq", log=print):
    """Bake `method` on obj and compare with the reference. Returns (report dict, per-texel
    error image (H, W) with NaN where not compared)."""
    if method not in METHODS:
        raise CompareError(f"method {method!r} is not available; use one of "
                           f"{sorted(METHODS)}")
    problem = resolution_problem(resolution, *RESOLUTION_RANGE)
    if problem:     # interior texels need a 3 x 3 neighbourhood: 8 at least
        raise CompareError(problem)
    reason = unavailable_reason(method)
    if reason is not None:
        raise CompareError(f"method {method!r} is not available in this Blender: {reason}")
    m = METHODS[method]
    if variant not in m.variants and len(m.variants) > 1:
        raise CompareError(f"method {method!r} has no variant {variant!r}; use one of "
                           f"{list(m.variants)}")
    inp = prepare_inputs(obj, uv_map, image, variant)
    import bpy
    try:
        with m.scene(obj, inp):
            report, heat = compare_graph(inp, obj, m.graph, m.reference, resolution)
        report["method"] = method
        report["variant"] = inp.variant if len(m.variants) > 1 else None
        return report, heat
    finally:
        for _, img in inp.images.values():
            bpy.data.images.remove(img)


def compare_graph(inp, obj, graph, reference, resolution):
    """Bake graph(inp, nodes, links) on obj and compare with reference(inp, td): the report
    and the per-texel error image."""
    method = getattr(graph, "__name__", "graph")
    G.build_all()
    def build(nodes, links):
        out = graph(inp, nodes, links)
        # Graphs return a surface gradient to resolve against the shading normal, or (post-
        # resolve) an already resolved normal.
        return out if out.name == "Normal" else resolve_sg(nodes, links, out)
    pixels, covered, bake_seconds = B.bake_vector(obj, build, resolution, resolution,
                                                  uv_map=inp.uv_map)
    try:
        mesh = mesh_arrays_from_object(obj)
    except MeshDataError as err:
        raise CompareError(str(err)) from err
    t0 = time.perf_counter()
    td = R.rasterize(mesh, inp.uv_map, resolution, resolution, facts=B.running_line())
    reference_seconds = time.perf_counter() - t0
    # Block by block (reference/raster.py): the reference's working memory is one block's,
    # and so is the comparison's; only the per-texel errors and the heat map are whole.
    errors, sums = [], dict.fromkeys(("tilt_bake", "tilt_ref", "finite_interior", "both",
                                      "finite_unit", "away", "truth_away_strict",
                                      "away_not_truth"), 0.0)
    heat = np.full((resolution, resolution), np.nan, dtype=np.float32)
    interior_count = 0
    sampling = R.image_sampling.images_unchanged()
    sampling.__enter__()            # the inputs' images are laid out once for all blocks
    for _, _, block in td.blocks():
        t0 = time.perf_counter()
        ref = M.resolve(reference(inp, block))
        reference_seconds += time.perf_counter() - t0
        px, py = block.pixel[:, 0], block.pixel[:, 1]
        baked = pixels[py, px].astype(np.float64)
        in_bake = covered[py, px]
        interior = block.interior() & in_bake
        err = angle_deg(baked[interior], ref[interior])
        errors.append(err)
        heat[py[interior], px[interior]] = err
        interior_count += int(interior.sum())
        base = M.unit_base_normal(block)[interior]
        sums["tilt_bake"] += float(angle_deg(baked[interior], base).sum())
        sums["tilt_ref"] += float(angle_deg(ref[interior], base).sum())
        sums["finite_interior"] += int(np.sum(np.isfinite(baked[interior]).all(-1) & (
            np.abs(np.linalg.norm(baked[interior], axis=-1) - 1) < 1e-4)))
        # Over every texel both cover (borders included): the stability figures.
        ng = block.geometric_normal[in_bake]
        b_all, r_all = baked[in_bake], ref[in_bake]
        norms = np.linalg.norm(b_all, axis=-1)
        away = np.sum(b_all * ng, axis=-1) < -1e-3
        truth_dot = np.sum(r_all * ng, axis=-1)
        sums["both"] += len(b_all)
        sums["finite_unit"] += int(np.sum(np.isfinite(b_all).all(-1) & (np.abs(norms - 1) < 1e-3)))
        sums["away"] += int(away.sum())
        sums["truth_away_strict"] += int(np.sum(truth_dot < 0))
        sums["away_not_truth"] += int(np.sum(away & ~(truth_dot < 1e-3)))
    sampling.__exit__(None, None, None)
    err = np.concatenate(errors) if errors else np.zeros(0)
    excluded = int(len(td.pixel) - interior_count + (covered & ~td.covered).sum())
    both = max(sums["both"], 1)
    report_all = {
        "finite_unit_fraction_all": sums["finite_unit"] / both if sums["both"] else float("nan"),
        "facing_away_fraction": sums["away"] / both if sums["both"] else float("nan"),
        "truth_facing_away_fraction": (sums["truth_away_strict"] / both if sums["both"]
                                       else float("nan")),
        "faces_away_where_truth_does_not": int(sums["away_not_truth"]),
    }
    n = max(interior_count, 1)
    report = {
        **report_all,
        "method": method, "object": obj.name, "uv_map": inp.uv_map,
        "tilt_mean_deg": sums["tilt_ref"] / n, "bake_tilt_mean_deg": sums["tilt_bake"] / n,
        "resolution": resolution, "texels_compared": interior_count,
        "texels_excluded": excluded,
        "excluded_fraction": excluded / max(1, interior_count + excluded),
        "mean_deg": float(err.mean()), "p99_deg": float(np.percentile(err, 99)),
        "max_deg": float(err.max()), "bake_seconds": bake_seconds,
        "reference_seconds": reference_seconds,
        "finite_unit_fraction": sums["finite_interior"] / n,
    }
    return report, heat


def write_heat_map(path, heat, overwrite):
    """Error in degrees as a picture: black 0, white at the max (or 0.5 deg, whichever is
    larger), uncompared texels dark blue."""
    top = max(0.5, float(np.nanmax(heat)) if np.isfinite(heat).any() else 0.5)
    v = np.clip(np.nan_to_num(heat, nan=0.0) / top, 0, 1)
    rgb = np.stack([v, v ** 0.5 * 0.8, v ** 2], axis=-1)
    rgb[np.isnan(heat)] = (0.05, 0.05, 0.2)
    return write_png(path, rgb, overwrite=overwrite)


def run(blend, object_name, method, resolution, json_out, uv_map=None, image=None,
        variant="hq", overwrite=False, log=print, from_open_file=False):
    """The command: load, bake, compare, write the JSON and the heat map, print a summary."""
    import bpy
    json_out = Path(json_out)
    heat_path = json_out.with_name(json_out.stem + "_error.png")
    for p in (json_out, heat_path):
        if p.exists() and not overwrite:
            raise CompareError(f"{p} exists; pass --overwrite to replace it")
    if blend:
        if not Path(blend).is_file():
            raise CompareError(f".blend file {blend!r} does not exist")
        bpy.ops.wm.open_mainfile(filepath=str(blend))
    elif not from_open_file:
        from . import scenes
        scenes.new_scene()
    obj = bpy.data.objects.get(object_name)
    if obj is None:
        raise CompareError(f"no object named {object_name!r}; objects: "
                           f"{sorted(o.name for o in bpy.data.objects)}")
    from .. import api                  # the command goes through the public API
    report, heat = api.compare(obj, method, resolution, variant, uv_map, image,
                               with_heat_map=True)
    json_out.parent.mkdir(parents=True, exist_ok=True)
    json_out.write_text(json.dumps(report, indent=2))
    write_heat_map(heat_path, heat, overwrite)
    log(f"{method} on {obj.name} at {resolution}^2: {report['texels_compared']} texels, "
        f"mean {report['mean_deg']:.4f} p99 {report['p99_deg']:.4f} max "
        f"{report['max_deg']:.4f} deg; excluded {report['texels_excluded']}; bake "
        f"{report['bake_seconds']:.2f} s, reference {report['reference_seconds']:.2f} s")
    return report


def compare_cases():
    """(method, variant) for every method this Blender can run (methods.cases())."""
    return cases()


def run_all(out_dir, resolution=64, overwrite=False, log=print):
    """Every method on every object of the procedural test scene: JSON, a Markdown table and
    an error heat map per case."""
    from . import scenes
    out = Path(out_dir)
    table_md, table_json = out / "compare.md", out / "compare.json"
    for p in (table_md, table_json):
        if p.exists() and not overwrite:
            raise CompareError(f"{p} exists; pass --overwrite to replace it")
    (out / "heat").mkdir(parents=True, exist_ok=True)
    objects = scenes.new_scene()
    cases = compare_cases()
    for method in METHODS:
        if unavailable_reason(method) is not None:
            log(f"skipped {method}: {unavailable_reason(method)}")
    reports = []
    total = len(cases) * len(objects)
    for i, (method, variant) in enumerate(cases):
        for name, obj in objects.items():
            report, heat = compare_object(obj, method, resolution, variant=variant,
                                          log=lambda *_: None)
            reports.append(report)
            label = method + (f"-{variant}" if method == "height-map" else "")
            write_heat_map(out / "heat" / f"{label}_{name}.png", heat, overwrite=True)
            log(f"[{len(reports)}/{total}] {label:22s} {name:12s} p99 "
                f"{report['p99_deg']:.4f} max {report['max_deg']:.4f} deg, bake "
                f"{report['bake_seconds']:.3f} s, reference {report['reference_seconds']:.3f} s")
    table_json.write_text(json.dumps(reports, indent=2))
    lines = [f"# Bakes against the reference at {resolution}^2",
             "", "Angular error (degrees) between the Cycles bake of each method's node groups "
             "and the numpy reference, over interior texels.", "",
             "| method | scene | texels | excluded | mean | p99 | max | bake s | reference s |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in reports:
        label = r["method"] + (f" ({r['variant']})" if r["variant"] else "")
        lines.append(f"| {label} | {r['object']} | {r['texels_compared']} | "
                     f"{100 * r['excluded_fraction']:.1f}% | {r['mean_deg']:.5f} | "
                     f"{r['p99_deg']:.4f} | {r['max_deg']:.4f} | {r['bake_seconds']:.3f} | "
                     f"{r['reference_seconds']:.3f} |")
    worst = max(reports, key=lambda r: r["max_deg"])
    lines += ["", f"Worst case: {worst['method']} on {worst['object']}, max "
                  f"{worst['max_deg']:.4f} deg (bar: p99 0.1, max 0.5)."]
    table_md.write_text("\n".join(lines) + "\n")
    log(f"wrote {table_md}, {table_json} and {len(reports)} heat maps in {out / 'heat'}")
    return reports
