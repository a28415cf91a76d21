"""Benchmark of the reference evaluator (not a test): texels per second for rasterisation and
for each listing at several bake sizes, printed and written as JSON."""

import json
import platform
import time
from pathlib import Path

import numpy as np

from .. import reference as R

SIZES = (256, 512, 1024, 2048)


def _inputs(n, rng):
    unit = lambda v: v / np.linalg.norm(v, axis=-1, keepdims=True)
    nrm = unit(rng.normal(size=(n, 3)))
    v3 = [rng.normal(size=(n, 3)) for _ in range(3)]
    v2 = [rng.normal(size=(n, 2)) * 0.01 for _ in range(3)]
    m = unit(v3[0] * 0.3 + [0, 0, 1])
    st = rng.uniform(size=(n, 2))
    return nrm, v3, v2, m, st


def cases(n, rng):
    nrm, (a, b, c), (d, e, f), m, st = _inputs(n, rng)
    height = R.images.wave_height_image(512)
    w = R.determine_triplanar_weights(nrm)
    inv = np.linalg.inv(np.diag([300.0, 300.0, 0.5, 1.0]) @ np.eye(4))
    return {
        "L1 resolve": lambda: R.resolve_normal_from_surface_gradient(nrm, a * 0.1),
        "L2 tspace_normal_to_derivative": lambda: R.tspace_normal_to_derivative(m),
        "L3 surfgrad_from_tbn": lambda: R.surfgrad_from_tbn(d, a, b),
        "L4 gen_basis_tb": lambda: R.gen_basis_tb(nrm, a, b, d, e),
        "L5 surfgrad_from_perturbed_normal": lambda: R.surfgrad_from_perturbed_normal(nrm, m),
        "L6 surfgrad_scale_dependent": lambda: R.surfgrad_scale_dependent(nrm, a, b, d, e, f,
                                                                          (512, 512)),
        "L8 surfgrad_from_volume_gradient": lambda: R.surfgrad_from_volume_gradient(nrm, a),
        "L9 bump_prologue": lambda: R.bump_prologue(nrm, a, np.ones(n), b, c),
        "L10 screen_deriv_of_pos_no_ddxy": lambda: R.screen_deriv_of_pos_no_ddxy(
            a, nrm, inv, st[:, 0] * 512, st[:, 1] * 512),
        "L11 project_vec_to_texture_space": lambda: R.project_vec_to_texture_space(
            nrm, a, b, d, e, m, 0.05),
        "L12 tex_space_offs_to_surface": lambda: R.tex_space_offs_to_surface(a, b, d, e, f),
        "L13+L14 triplanar": lambda: R.surfgrad_from_triplanar_projection(
            nrm, R.determine_triplanar_weights(nrm), d, e, f),
        "L15 surfgrad_from_decal": lambda: R.surfgrad_from_decal(nrm, d, a, b),
        "L16 deriv_from_height_map": lambda: R.deriv_from_height_map(height, st),
        "L16 deriv_from_height_map hq": lambda: R.deriv_from_height_map(height, st, hq=True),
        "POM march 16 steps": lambda: R.parallax_occlusion_march(
            lambda q: R.sample_image(height, q), st, d, steps=16),
        "blend RNM": lambda: R.blend_rnm(m, m[::-1]),
        "blend UDN (SG form)": lambda: R.surfgrad_blend("udn", m, a, b, m[::-1], a, b),
        "gradient noise + gradient": lambda: R.gradient_noise(a * 4),
        "fractal sum 4 octaves": lambda: R.fractal_sum(a * 4, octaves=4),
        "image sample linear": lambda: R.sample_image(height, st),
        "Gustavson displaced normal": lambda: R.displaced_normal(nrm, a, 0.1),
        "baseline Perlin 1985": lambda: R.perturb_normal_perlin1985(nrm, a * 0.1),
        "baseline Geiss triplanar": lambda: R.triplanar_geiss(nrm, w, m, m, m),
    }


def _time(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def run(out_path, sizes=SIZES, log=print, overwrite=False):
    out_path = Path(out_path)
    if out_path.exists() and not overwrite:
        raise FileExistsError(f"{out_path} exists; pass --overwrite to replace it")
    rng = np.random.default_rng(0)
    mesh = R.meshes.uv_sphere(segments=64, rings=32)
    results = {"machine": {"python": platform.python_version(), "numpy": np.__version__,
                           "processor": platform.processor() or platform.machine()},
               "units": "texels per second (best of repeats)", "sizes": {}}
    for size in sizes:
        n = size * size
        repeats = 3 if n <= 512 * 512 else 1
        row = {}
        t = _time(lambda: R.rasterize(mesh, "UVMap", size, size), repeats)
        row["rasterize (UV sphere 64x32)"] = n / t
        td = R.rasterize(mesh, "UVMap", size, size)
        t = _time(lambda: (td.position, td.normal, td.uv(), td.texel_steps()), 1)
        row["texel attributes (position, normal, uv, steps)"] = len(td.pixel) / t
        for name, fn in cases(n, rng).items():
            row[name] = n / _time(fn, repeats)
        results["sizes"][str(size)] = row
        log(f"-- {size} x {size} ({n} texels)")
        for name, rate in row.items():
            log(f"   {name:48s} {rate / 1e6:9.2f} M texels/s")
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(json.dumps(results, indent=2))
    log(f"wrote {out_path}")
    return results
