"""Benchmark of the reference evaluator (not a test), printed and written as JSON:

1. listings: M texels/s of each listing and building block, evaluated block by block
   (reference/raster.BLOCK_TEXELS) on inputs in the reference's component layout;
2. methods: M texels/s of every compare method's whole reference (rasterise the test sphere,
   texel attributes, the method, the resolve), in process, 256^2 .. 4096^2;
3. compare: `python -m surfgrad_addon compare` in a child process per method and size (needs
   bpy): the Cycles bake's and the reference's seconds in the same run, their ratio, and the
   child's peak resident memory (the whole compare, Cycles' bake buffers included; read from
   /proc while it runs, Linux);
4. the bandwidth floor: a plain numpy copy's GB/s on this machine and the time 64 bytes per
   texel (position, normal, tangent and sign, UV in; the result out) take at that speed.

Timings on a shared machine are noisy: every figure is the median of `repeats` runs, and the
reference/bake ratio is taken per run (bake and reference of the same child) before the
median.
"""

import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ... import reference as R
from ...reference import methods as M
from ...reference.raster import BLOCK_TEXELS

SIZES = (256, 512, 1024, 2048)
METHOD_SIZES = (256, 1024, 2048, 4096)
COMPARE_SIZES = (1024, 2048)
MEMORY_SIZES = (1024, 2048, 4096)
TEXEL_BYTES = 64            # position, normal, tangent + sign, UV in; the result out
ROOT = Path(__file__).resolve().parents[3]


# 1. Listings ------------------------------------------------------------------------------------

def _inputs(n, rng):
    """Random per-texel inputs (N, k), each component contiguous (the reference's layout)."""
    unit = lambda v: v / np.linalg.norm(v, axis=-1, keepdims=True)
    f = np.asfortranarray
    nrm = f(unit(rng.normal(size=(n, 3))))
    a, b, c = (f(rng.normal(size=(n, 3))) for _ in range(3))
    d, e, g = (f(rng.normal(size=(n, 2)) * 0.01) for _ in range(3))
    m = f(unit(a * 0.3 + [0, 0, 1]))
    st = f(rng.uniform(size=(n, 2)))
    return dict(nrm=nrm, a=a, b=b, c=c, d=d, e=e, f=g, m=m, st=st,
                w=f(R.determine_triplanar_weights(nrm)), m2=f(m[::-1]))


def listing_cases():
    """name -> fn(x) with x the inputs of one block (a dict of arrays)."""
    height = R.images.wave_height_image(512)
    inv = np.linalg.inv(np.diag([300.0, 300.0, 0.5, 1.0]))
    return {
        "L1 resolve": lambda x: R.resolve_normal_from_surface_gradient(x["nrm"], x["a"] * 0.1),
        "L2 tspace_normal_to_derivative": lambda x: R.tspace_normal_to_derivative(x["m"]),
        "L3 surfgrad_from_tbn": lambda x: R.surfgrad_from_tbn(x["d"], x["a"], x["b"]),
        "L4 gen_basis_tb": lambda x: R.gen_basis_tb(x["nrm"], x["a"], x["b"], x["d"], x["e"]),
        "L5 surfgrad_from_perturbed_normal": lambda x: R.surfgrad_from_perturbed_normal(
            x["nrm"], x["m"]),
        "L6 surfgrad_scale_dependent": lambda x: R.surfgrad_scale_dependent(
            x["nrm"], x["a"], x["b"], x["d"], x["e"], x["f"], (512, 512)),
        "L8 surfgrad_from_volume_gradient": lambda x: R.surfgrad_from_volume_gradient(
            x["nrm"], x["a"]),
        "L9 bump_prologue": lambda x: R.bump_prologue(x["nrm"], x["a"], np.ones(len(x["a"])),
                                                      x["b"], x["c"]),
        "L10 screen_deriv_of_pos_no_ddxy": lambda x: R.screen_deriv_of_pos_no_ddxy(
            x["a"], x["nrm"], inv, x["st"][:, 0] * 512, x["st"][:, 1] * 512),
        "L11 project_vec_to_texture_space": lambda x: R.project_vec_to_texture_space(
            x["nrm"], x["a"], x["b"], x["d"], x["e"], x["m"], 0.05),
        "L12 tex_space_offs_to_surface": lambda x: R.tex_space_offs_to_surface(
            x["a"], x["b"], x["d"], x["e"], x["f"]),
        "L13+L14 triplanar": lambda x: R.surfgrad_from_triplanar_projection(
            x["nrm"], R.determine_triplanar_weights(x["nrm"]), x["d"], x["e"], x["f"]),
        "L15 surfgrad_from_decal": lambda x: R.surfgrad_from_decal(x["nrm"], x["d"], x["a"],
                                                                   x["b"]),
        "L16 deriv_from_height_map": lambda x: R.deriv_from_height_map(height, x["st"]),
        "L16 deriv_from_height_map hq": lambda x: R.deriv_from_height_map(height, x["st"],
                                                                          hq=True),
        "POM march 16 steps": lambda x: R.parallax_occlusion_march(
            lambda q: R.sample_image(height, q), x["st"], x["d"], steps=16),
        "blend RNM": lambda x: R.blend_rnm(x["m"], x["m2"]),
        "blend UDN (SG form)": lambda x: R.surfgrad_blend("udn", x["m"], x["a"], x["b"],
                                                          x["m2"], x["a"], x["b"]),
        "gradient noise + gradient": lambda x: R.gradient_noise(x["a"] * 4),
        "fractal sum 4 octaves": lambda x: R.fractal_sum(x["a"] * 4, octaves=4),
        "image sample linear": lambda x: R.sample_image(height, x["st"]),
        "Gustavson displaced normal": lambda x: R.displaced_normal(x["nrm"], x["a"], 0.1),
        "baseline Perlin 1985": lambda x: R.perturb_normal_perlin1985(x["nrm"], x["a"] * 0.1),
        "baseline Geiss triplanar": lambda x: R.triplanar_geiss(x["nrm"], x["w"], x["m"],
                                                                x["m"], x["m"]),
    }


def _blocked(fn, inputs, n):
    with R.image_sampling.images_unchanged():
        for start in range(0, n, BLOCK_TEXELS):
            fn({k: v[start:start + BLOCK_TEXELS] for k, v in inputs.items()})


def run_seconds(fn, repeats):
    """Wall seconds of each of `repeats` calls of fn() (tools/bench_sampling.py too)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return times


def _median_time(fn, repeats):
    return float(np.median(run_seconds(fn, repeats)))


# 2. Whole methods in process ----------------------------------------------------------------------

# A fixed decal projector, skewed so that no axis lines up with the mesh.
PROJECTOR = np.array([[0.5, -0.1, 0.0, 0.1], [0.1, 0.4, -0.2, 0.0], [0.05, 0.2, 1.2, 0.2],
                      [0, 0, 0, 1.0]])


def reference_inputs(variant="hq", normal_size=None, height_size=None):
    """What compare's prepare_inputs gives a method's reference, without bpy: the same test
    images (float32-rounded; sizes: the registry's, harness/methods.py) and PROJECTOR."""
    from ..main_job import ReferenceInputs
    from ..methods import HEIGHT_IMAGE_SIZE, NORMAL_IMAGE_SIZE
    normal_size, height_size = normal_size or NORMAL_IMAGE_SIZE, height_size or HEIGHT_IMAGE_SIZE
    r32 = lambda a: a.astype(np.float32).astype(np.float64)  # noqa: E731
    images = {"normal": r32(R.images.hemisphere_tile_image(normal_size)),
              "detail": r32(R.images.hemisphere_tile_image(normal_size, tiles=8, radius=0.6)),
              "height": r32(R.images.wave_height_image(height_size))}
    return ReferenceInputs(images, variant, PROJECTOR)


def test_sphere():
    """The reference's UV sphere (32 x 16, like the compare scene's) with a rest position."""
    mesh = R.meshes.uv_sphere(segments=32, rings=16)
    mesh.point_attributes["sg_rest_position"] = np.asarray(mesh.positions) * 1.05
    return mesh


def method_seconds(method, variant, size, mesh=None):
    """Wall seconds of rasterize + the method's reference + resolve, block by block, as
    compare does it; the seconds without the rasteriser; and the number of texels."""
    from ..methods import METHODS
    mesh = mesh or test_sphere()
    inp = reference_inputs(variant)
    t0 = time.perf_counter()
    td = R.rasterize(mesh, "UVMap", size, size)
    t1 = time.perf_counter()
    # Block by block as compare consumes them (no image-sized result is gathered).
    for _ in M.evaluated_blocks(lambda b: M.resolve(METHODS[method].reference(inp, b)), td):
        pass
    t2 = time.perf_counter()
    return t2 - t0, t2 - t1, td.texel_count


# 3. Compare in a child process --------------------------------------------------------------------

def _peak_rss_gb(pid):
    """The high-water resident memory of a process's current image (VmHWM), GB, or 0."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 2 ** 20        # kB
    except OSError:
        pass
    return 0.0


def compare_child(method, size, python=None, root=ROOT, variant="hq"):
    """Run the compare command in a child; its report's bake and reference seconds and its
    peak resident memory (GB): the child's VmHWM, read while it runs (the kernel's
    ru_maxrss would include this process's memory, which a forked child starts with)."""
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "report.json"
        cmd = [python or sys.executable, "-m", "surfgrad_addon", "compare", "--object",
               "Sphere", "--method", method, "--resolution", str(size), "--json", str(report),
               "--variant", variant]
        with tempfile.TemporaryFile() as errors:
            proc = subprocess.Popen(cmd, cwd=root, stdout=subprocess.DEVNULL, stderr=errors)
            peak_gb = 0.0
            while proc.poll() is None:
                peak_gb = max(peak_gb, _peak_rss_gb(proc.pid))
                time.sleep(0.05)
            errors.seek(0)
            err = errors.read().decode(errors="replace")
        if proc.returncode != 0 or not report.exists():
            return {"error": err.strip().splitlines()[-1] if err.strip()
                    else f"exit {proc.returncode}"}
        r = json.loads(report.read_text())
    return {"bake_seconds": r["bake_seconds"], "reference_seconds": r["reference_seconds"],
            "compiled_load_seconds": r.get("compiled_load_seconds", 0.0),
            "ratio": r["reference_seconds"] / r["bake_seconds"], "peak_gb": peak_gb,
            "max_deg": r["max_deg"], "texels": r["texels_compared"]}


def _median_rows(rows):
    good = [r for r in rows if "error" not in r]
    if not good:
        return rows[0]
    out = {k: float(np.median([r[k] for r in good])) for k in good[0] if k != "texels"}
    out["texels"] = good[0]["texels"]
    out["peak_gb"] = max(r["peak_gb"] for r in good)
    out["runs"] = len(good)
    return out


# 4. Bandwidth floor --------------------------------------------------------------------------------

def copy_bandwidth(megabytes=256, repeats=5):
    """GB/s of a plain numpy copy (read + write counted) of a large array."""
    a = np.ones(megabytes * 2 ** 20 // 8)
    b = np.empty_like(a)
    t = min(_median_time(lambda: np.copyto(b, a), 1) for _ in range(repeats))
    return 2 * a.nbytes / t / 1e9


# The run ------------------------------------------------------------------------------------------

def _has_bpy():
    try:
        import bpy  # noqa: F401
    except ImportError:
        return False
    return True


def run(out_path, sizes=SIZES, log=print, overwrite=False, method_sizes=METHOD_SIZES,
        compare_sizes=COMPARE_SIZES, memory_sizes=MEMORY_SIZES, methods=None, repeats=3,
        python=None, root=ROOT):
    out_path = Path(out_path)
    if out_path.exists() and not overwrite:
        raise FileExistsError(f"{out_path} exists; pass --overwrite to replace it")
    from ..methods import METHODS, cases
    rng = np.random.default_rng(0)
    bandwidth = copy_bandwidth()
    results = {"machine": {"python": platform.python_version(), "numpy": np.__version__,
                           "processor": platform.processor() or platform.machine(),
                           "cpus": os.cpu_count(), "load_average": os.getloadavg()},
               "units": "M texels/s (median of repeats); seconds; GB",
               "block_texels": BLOCK_TEXELS, "copy_gb_per_s": bandwidth,
               "texel_bytes": TEXEL_BYTES, "listings": {}, "methods": {}, "compare": {},
               "memory": {}}
    load_seconds = R.raster.load_compiled()
    kernels = {"enabled": R.compiled.enabled(),
               "numba": getattr(R.compiled.numba, "__version__", None),
               "load_seconds": load_seconds, "threads": M.reference_threads()}
    results["compiled_kernels"] = kernels
    log(f"compiled kernels: {'on' if kernels['enabled'] else 'off'}"
        + (f" (numba {kernels['numba']}, loaded in {load_seconds:.3f} s)"
           if kernels["enabled"] else " (numba missing or SURFGRAD_REFERENCE_COMPILED=0)")
        + f"; blocks on {kernels['threads']} thread(s)")
    log(f"numpy copy: {bandwidth:.1f} GB/s; bandwidth floor at {TEXEL_BYTES} B/texel: "
        + ", ".join(f"{s}^2 {TEXEL_BYTES * s * s / bandwidth / 1e6:.1f} ms" for s in
                    sorted(set(sizes) | set(method_sizes))))
    cases_ = listing_cases()
    for size in sizes:
        n = size * size
        inputs = _inputs(n, rng)
        reps = repeats if n <= 1024 * 1024 else max(1, repeats // 2)
        row = {}
        mesh = R.meshes.uv_sphere(segments=64, rings=32)
        row["rasterize (UV sphere 64x32)"] = n / _median_time(
            lambda: R.rasterize(mesh, "UVMap", size, size), reps) / 1e6
        td = R.rasterize(mesh, "UVMap", size, size)
        row["texel attributes (position, normal, uv, steps)"] = td.texel_count / _median_time(
            lambda: M.evaluate_in_blocks(lambda b: (b.position, b.normal, b.uv(),
                                                    b.texel_steps())[0], td), reps) / 1e6
        for name, fn in cases_.items():
            row[name] = n / _median_time(lambda: _blocked(fn, inputs, n), reps) / 1e6
        results["listings"][str(size)] = row
        log(f"-- listings at {size} x {size} ({n} texels), M texels/s")
        for name, rate in row.items():
            log(f"   {name:48s} {rate:9.2f}")
    has_bpy = _has_bpy()
    # Without bpy no feature gate can be asked (groups need Blender): every method counts.
    all_cases = cases() if has_bpy else [(m.name, v) for m in sorted(
        METHODS.values(), key=lambda m: m.name) for v in m.variants]
    # A Sampler method's reference is its per-image twin's: timed once, under the twin.
    chosen = methods or [m for m, _ in all_cases if not METHODS[m].same_reference_as]
    variants = {m: v for m, v in all_cases}
    if not has_bpy:         # a scene-only reference reads what Blender's scene evaluates
        skipped = [m for m in chosen if METHODS[m].scene_only]
        chosen = [m for m in chosen if not METHODS[m].scene_only]
        if skipped:
            log(f"no bpy here: skipping {', '.join(dict.fromkeys(skipped))} (needs Blender)")
    sphere = test_sphere()
    if method_sizes:
        log("-- whole methods (rasterize + reference + resolve), M texels/s")
    if method_sizes:
        log("   " + f"{'method':24s}" + "".join(f"{s:>14d}" for s in method_sizes)
            + "   (with the rasteriser / without)")
    results["methods_without_rasterizer"] = {}
    for method in (dict.fromkeys(chosen) if method_sizes else ()):
        row, bare = {}, {}
        for size in method_sizes:
            times = [method_seconds(method, variants[method], size, sphere)
                     for _ in range(repeats)]
            n = times[0][2]
            row[str(size)] = n / float(np.median([t[0] for t in times])) / 1e6
            bare[str(size)] = n / float(np.median([t[1] for t in times])) / 1e6
        results["methods"][method] = row
        results["methods_without_rasterizer"][method] = bare
        log(f"   {method:24s}" + "".join(f"{row[str(s)]:7.2f}/{bare[str(s)]:6.2f}"
                                         for s in method_sizes))
    if not has_bpy:
        log("no bpy here: the compare ratios and memory need Blender (run with the 5.2 venv)")
    else:
        log("-- compare (child process per run): reference / bake seconds, peak memory")
        for size in compare_sizes:
            for method in dict.fromkeys(chosen):
                rows = [compare_child(method, size, python, root, variants[method])
                        for _ in range(repeats)]
                r = _median_rows(rows)
                results["compare"].setdefault(method, {})[str(size)] = r
                if "error" in r:
                    log(f"   {method:24s} {size:5d}^2  failed: {r['error']}")
                    continue
                log(f"   {method:24s} {size:5d}^2  bake {r['bake_seconds']:7.2f} s  reference "
                    f"{r['reference_seconds']:6.2f} s  ratio {r['ratio']:5.2f}  peak "
                    f"{r['peak_gb']:5.2f} GB  ({r['runs']} runs)")
        for size in memory_sizes:
            r = compare_child("normal-map", size, python, root)
            results["memory"][str(size)] = r
            if "error" in r:
                log(f"   memory {size}^2: failed: {r['error']}")
                continue
            floor = TEXEL_BYTES * r["texels"] / bandwidth / 1e9
            log(f"   normal-map {size:5d}^2: peak {r['peak_gb']:5.2f} GB, bake "
                f"{r['bake_seconds']:.2f} s, reference {r['reference_seconds']:.2f} s "
                f"(ratio {r['ratio']:.2f}; bandwidth floor {floor * 1e3:.0f} ms)")
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(json.dumps(results, indent=2))
    log(f"wrote {out_path}")
    return results
