"""Gustavson's displacement, measured (issue 5).

1. Convergence: SG Displace's analytic normals against the normals Blender recomputes from the
   displaced vertices, at Catmull-Clark subdivision levels 0 to 6 of a coarse sphere, with the
   time each level takes to evaluate. The analytic route needs no dense mesh to be right; the
   recomputed normals only catch up once the mesh resolves the noise.
2. Bump against true displacement: on a unit sphere (radius of curvature 1) displaced by
   A h(w), the exact normal is n ~ (1 + A h) w - A grad_S h, while bump mapping (Blinn, the
   surface gradient with A) gives n ~ w - A grad_S h. The angle between them grows with A
   relative to the radius: Blinn's approximation, and Gustavson's "valid only if the local
   curvature of the surface is small". Measured on dense direction samples in float64, and
   with Cycles: the bump bake against Cycles' true displacement of a finely subdivided sphere.
"""

import statistics
import time

import numpy as np

from ... import reference as R
from ...addon import compat
from ..compare import angle_deg
from ..method_scene import add_displace_modifier

CONVERGENCE = {"Amount": 0.1, "Scale": 2.0, "Octaves": 3}
BUMP_SCALE, BUMP_OCTAVES = 2.0, 1
AMPLITUDES = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4)


def _stats(deg):
    return {"mean_deg": float(np.mean(deg)), "p95_deg": float(np.percentile(deg, 95)),
            "max_deg": float(np.max(deg))}


def convergence(levels=range(7), repeats=3, log=print):
    import bpy
    from .. import compare
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=1.0)
    obj = bpy.context.active_object
    obj.data.polygons.foreach_set("use_smooth", np.ones(len(obj.data.polygons), dtype=bool))
    sub = obj.modifiers.new("Subdivision", "SUBSURF")
    mod = add_displace_modifier(obj, CONVERGENCE)

    def evaluate(analytic):
        compat.set_input(mod, "Analytic Normals", analytic)
        seconds = []
        for _ in range(repeats):
            obj.update_tag()
            t0 = time.perf_counter()
            bpy.context.view_layer.update()
            seconds.append(time.perf_counter() - t0)
        ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        mesh = ev.to_mesh()
        try:
            nl, nv = len(mesh.loops), len(mesh.vertices)
            normals = np.empty(nl * 3)
            mesh.corner_normals.foreach_get("vector", normals)
            vertex = np.empty(nl, dtype=np.int64)
            mesh.loops.foreach_get("vertex_index", vertex)
        finally:
            ev.to_mesh_clear()
        per_vertex = np.zeros((nv, 3))
        per_vertex[vertex] = normals.reshape(-1, 3)
        return per_vertex, statistics.median(seconds)

    rows = []
    for level in levels:
        sub.levels = level
        analytic, t_analytic = evaluate(True)
        recomputed, t_recomputed = evaluate(False)   # Blender's normals of the displaced mesh
        deg = angle_deg(analytic, recomputed)
        rows.append({"level": level, "vertices": len(analytic),
                     "evaluate_seconds": t_analytic, "evaluate_seconds_recomputed": t_recomputed,
                     **_stats(deg)})
        log(f"    level {level}: {len(analytic):7d} vertices, {t_analytic:.3f} s, "
            f"recomputed vs analytic mean {rows[-1]['mean_deg']:.3f} max "
            f"{rows[-1]['max_deg']:.2f} deg")
    return rows


def fibonacci_sphere(n):
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = i * np.pi * (3 - np.sqrt(5))
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def bump_vs_exact(amplitudes=AMPLITUDES, samples=40000):
    """float64, on the unit sphere: the bump normal against the exact displaced normal."""
    w = fibonacci_sphere(samples)
    h, g = R.fractal_sum(w * BUMP_SCALE, octaves=BUMP_OCTAVES)
    g = BUMP_SCALE * g
    gs = g - np.sum(g * w, -1, keepdims=True) * w
    rows = []
    for a in amplitudes:
        exact = (1 + a * h)[:, None] * w - a * gs
        bump = w - a * gs
        rows.append({"amplitude": a, "amplitude_over_radius": a, **_stats(angle_deg(bump, exact))})
    return rows


def bump_vs_cycles_displacement(amplitudes=AMPLITUDES, resolution=128, subdivision=4,
                                log=print):
    """Cycles: the SG bump bake on the undisplaced sphere against the shading normal of
    Cycles' true displacement (Displacement node, method Displacement only) of the same
    sphere subdivided `subdivision` times, texel by texel through the same UV map."""
    import bpy
    from .. import bake as B
    from ...addon import groups as G
    from ..graph import Graph
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0, calc_uvs=True)
    obj = bpy.context.active_object
    obj.data.polygons.foreach_set("use_smooth", np.ones(len(obj.data.polygons), dtype=bool))
    sub = obj.modifiers.new("Subdivision", "SUBSURF")
    sub.levels = sub.render_levels = subdivision
    rows = []
    for a in amplitudes:
        def bump(nodes, links, a=a):
            g = Graph(nodes, links)
            noise = g.group(G.noise_group(), Scale=BUMP_SCALE, Octaves=BUMP_OCTAVES)
            vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                         Bump_Scale=a)
            return g.resolve(vg.outputs[0])

        def geometry_normal(nodes, links):
            return Graph(nodes, links).geometry("Normal")

        def displacement(nodes, links, a=a):
            g = Graph(nodes, links)
            noise = g.group(G.noise_group(), Scale=BUMP_SCALE, Octaves=BUMP_OCTAVES)
            disp = g.set(g.node("ShaderNodeDisplacement"), Midlevel=0.0, Scale=a,
                         Height=noise.outputs["Value"])
            return disp.outputs[0]
        px_bump, cov_b, _ = B.bake_vector(obj, bump, resolution, resolution, "UVMap")
        px_true, cov_t, seconds = B.bake_vector(obj, geometry_normal, resolution, resolution,
                                                "UVMap", displacement=displacement)
        both = cov_b & cov_t
        # Exclude the poles, where the UV map collapses and the texel footprint is degenerate.
        rows_y = np.arange(resolution)[:, None].repeat(resolution, 1)
        both &= (rows_y > resolution // 16) & (rows_y < resolution - resolution // 16)
        deg = angle_deg(px_bump[both], px_true[both])
        rows.append({"amplitude": a, "amplitude_over_radius": a, "texels": int(both.sum()),
                     "bake_seconds": seconds, **_stats(deg)})
        log(f"    A = {a}: bump vs Cycles true displacement mean {rows[-1]['mean_deg']:.3f} "
            f"p95 {rows[-1]['p95_deg']:.3f} deg")
    return rows


def chart(path, conv, exact, cycles):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.4))
    lv = [r["level"] for r in conv]
    a1.plot(lv, [r["mean_deg"] for r in conv], "o-", label="mean")
    a1.plot(lv, [r["p95_deg"] for r in conv], "s--", label="p95")
    a1.set_yscale("log")
    a1.set_xlabel("subdivision level of the base sphere (16 x 8 quads at level 0)")
    a1.set_ylabel("recomputed vs analytic normal (deg)")
    a1.set_title("SG Displace: normals recomputed from the geometry converge\n"
                 "to the analytic ones as the mesh resolves the noise", fontsize=10)
    ax2 = a1.twinx()
    ax2.plot(lv, [r["evaluate_seconds"] for r in conv], "^:", color="gray",
             label="evaluation time")
    ax2.set_yscale("log")
    ax2.set_ylabel("evaluation seconds", color="gray")
    a1.legend(loc="upper center", fontsize=8)
    a1.grid(True, which="both", alpha=0.3)
    amps = [r["amplitude"] for r in exact]
    a2.plot(amps, [r["mean_deg"] for r in exact], "o-", label="exact displaced sphere (float64): mean")
    a2.plot(amps, [r["max_deg"] for r in exact], "o--", label="exact: max")
    if cycles:
        a2.plot([r["amplitude"] for r in cycles], [r["mean_deg"] for r in cycles], "s-",
                label="Cycles true displacement: mean")
        a2.plot([r["amplitude"] for r in cycles], [r["p95_deg"] for r in cycles], "s--",
                label="Cycles true displacement: p95")
    a2.set_xscale("log")
    a2.set_yscale("log")
    a2.set_xlabel("displacement amplitude / radius of curvature")
    a2.set_ylabel("bump-mapped vs truly displaced normal (deg)")
    a2.set_title("Bump mapping against true displacement:\nBlinn's approximation degrades as "
                 "the amplitude grows", fontsize=10)
    a2.legend(fontsize=8)
    a2.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def markdown(conv, exact, cycles):
    lines = ["## Gustavson's displacement", "",
             "### Analytic normals against normals recomputed from the displaced geometry", "",
             f"SG Displace (amount {CONVERGENCE['Amount']}, scale {CONVERGENCE['Scale']}, "
             f"{CONVERGENCE['Octaves']} octaves) on a 16 x 8 UV sphere under Catmull-Clark "
             "subdivision.", "",
             "| level | vertices | evaluate s (analytic) | evaluate s (recomputed) | mean deg | "
             "p95 deg | max deg |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['level']} | {r['vertices']} | {r['evaluate_seconds']:.4f} | "
              f"{r['evaluate_seconds_recomputed']:.4f} | {r['mean_deg']:.3f} | "
              f"{r['p95_deg']:.3f} | {r['max_deg']:.2f} |" for r in conv]
    catch = next((r["level"] for r in conv if r["mean_deg"] < 1.0), None)
    lines += ["", f"The recomputed normals come within 1 degree (mean) of the analytic ones at "
                  f"level {catch}." if catch is not None else "", "",
              "### Bump mapping against true displacement", "",
              f"Unit sphere, h = noise(scale {BUMP_SCALE} P), {BUMP_OCTAVES} octave; the angle "
              "between the bump-mapped normal and the normal of the really displaced surface.",
              "", "| amplitude / radius | exact sphere mean | exact max | Cycles true "
              "displacement mean | Cycles p95 |", "|---|---|---|---|---|"]
    cyc = {r["amplitude"]: r for r in cycles or []}
    for r in exact:
        c = cyc.get(r["amplitude"])
        lines.append(f"| {r['amplitude']} | {r['mean_deg']:.4f} | {r['max_deg']:.3f} | "
                     f"{c['mean_deg']:.3f} | {c['p95_deg']:.3f} |" if c else
                     f"| {r['amplitude']} | {r['mean_deg']:.4f} | {r['max_deg']:.3f} | | |")
    return "\n".join(lines) + "\n"


def run(out, quick=False, log=print):
    levels = range(5) if quick else range(7)
    log("  displacement: convergence over subdivision levels")
    conv = convergence(levels, repeats=1 if quick else 3, log=log)
    exact = bump_vs_exact(samples=10000 if quick else 40000)
    log("  displacement: bump against Cycles' true displacement")
    cycles = bump_vs_cycles_displacement(AMPLITUDES[::2] if quick else AMPLITUDES,
                                         resolution=64 if quick else 128,
                                         subdivision=3 if quick else 4, log=log)
    chart(out / "chart_displacement.png", conv, exact, cycles)
    return {"convergence": conv, "bump_vs_exact": exact, "bump_vs_cycles": cycles}, \
        markdown(conv, exact, cycles)
