"""`python -m surfgrad_addon bench-render`: what surface-gradient groups cost in a render, against
Blender's own nodes for the same job (their twins).

One scene: a UV sphere filling the frame, Principled BSDF, one sun, Cycles on the CPU. Every
material is rendered in interleaved rounds (one render of each per round, so drift hits all
alike); the figures are medians. "Overhead" is the time above the same scene with no normal
perturbation, so the ratio of overheads is the ratio of what the two ways of bending the normal
cost. EEVEE (software GL here) is timed too: the first render of a material (its shader
compilation) and a later one. The look is checked by baking each material's normal: the SG
material against its twin where both mean the same thing, against the reference otherwise. The
graph behind each material is counted after expanding its groups: nodes, Normal Map nodes and
image lookups, which is where the cost comes from (Cycles' SVM stack is not visible from Python).

Targets (issue 11) are ratios of whole render time to the twin, measured in one run.
"""

import json
import statistics
import time
from pathlib import Path

import numpy as np

from ... import reference as R
from ...addon import groups as G
from ...addon.compat import new_material
from ..graph import Graph

SIZE, SAMPLES, REPEATS = 320, 64, 3
QUICK = {"size": 96, "samples": 8, "repeats": 2, "eevee": False}
TARGETS = {"normal-map": 1.10, "height-forward": 1.05, "triplanar": 1.15, "second-uv": 1.10,
           "eevee": 1.3}
BUMP_DISTANCE = 0.05
NOISE_SCALE = 8.0


# The materials: build(g, ctx) returns the socket for the BSDF's Normal (None: unperturbed) -----

def _noise(g):
    n = g.node("ShaderNodeTexNoise")
    n.inputs["Scale"].default_value = NOISE_SCALE
    return n.outputs["Fac"]


def _nm_builtin(g, ctx, uv_map="UVMap"):
    nm = g.node("ShaderNodeNormalMap", space="TANGENT", uv_map=uv_map)
    g.link(g.image(ctx["normal"], g.uv(uv_map)), nm.inputs["Color"])
    return nm.outputs["Normal"]


def _nm_sg_layer(g, ctx, uv_map="UVMap"):
    node = g.group(G.normal_map_group(uv_map), Color=g.image(ctx["normal"], g.uv(uv_map)))
    return node.outputs["Surface Gradient"]


def _nm_sg(g, ctx):
    return g.resolve(_nm_sg_layer(g, ctx))


def _bump_builtin(g, ctx):
    bump = g.node("ShaderNodeBump")
    bump.inputs["Distance"].default_value = BUMP_DISTANCE
    if "Filter Width" in bump.inputs:
        bump.inputs["Filter Width"].default_value = G.FORWARD_FILTER_WIDTH
    g.link(_noise(g), bump.inputs["Height"])
    return bump.outputs["Normal"]


def _bump_sg(g, ctx):
    node = g.group(G.height_map_forward_group(), Height=_noise(g), Bump_Scale=BUMP_DISTANCE)
    return g.resolve(node.outputs["Surface Gradient"])


def _tri_builtin(g, ctx):
    tc = g.node("ShaderNodeTexCoord")
    color = g.image(ctx["normal"], tc.outputs["Object"], projection="BOX")
    color.node.projection_blend = 0.25
    nm = g.node("ShaderNodeNormalMap", space="TANGENT", uv_map="UVMap")
    g.link(color, nm.inputs["Color"])
    return nm.outputs["Normal"]


def _tri_sg(g, ctx):
    coords = g.group(G.triplanar_coordinates_group())
    tri = g.group(G.triplanar_group())
    for axis in "XYZ":
        g.link(g.image(ctx["normal"], coords.outputs[f"UV {axis}"]), tri.inputs[f"Color {axis}"])
    return g.resolve(tri.outputs["Surface Gradient"])


def _uv2_builtin(g, ctx):
    return _nm_builtin(g, ctx, "Detail")


def _uv2_sg(g, ctx):
    uv = g.uv("Detail")
    basis = g.group(G.procedural_basis_group(), UV=uv)
    tn = g.group(G.tangent_normal_group(), Color=g.image(ctx["normal"], uv),
                 Tangent=basis.outputs["Tangent"], Bitangent=basis.outputs["Bitangent"])
    return g.resolve(tn.outputs["Surface Gradient"])


def _layers_builtin(count):
    def build(g, ctx):
        total = None
        for k in range(count):
            n = _nm_builtin(g, ctx, ("UVMap", "Detail")[k % 2])
            total = n if total is None else g.add(total, n)
        return g.normalize(total) if count > 1 else total
    return build


def _layers_sg(count):
    def build(g, ctx):
        total = None
        for k in range(count):
            sg = _nm_sg_layer(g, ctx, ("UVMap", "Detail")[k % 2])
            if total is None:
                total = sg
            else:
                comb = g.group(G.combine_group(), A=total, B=sg)
                total = comb.outputs["Surface Gradient"]
        return g.resolve(total)
    return build


# Sampler groups (5.0+) against the per-image groups they stand for: same taps, the image a
# closure evaluated per tap instead of an Image Texture node bound inside the group.
HEIGHT_BUMP = 0.05


def _sampler(g, image):
    from ..methods import sampler_socket
    return sampler_socket(g.nodes, g.links, image)


def _hq_image(g, ctx):
    node = g.group(G.height_map_group(ctx["height"], "hq"), UV=g.uv("UVMap"),
                   Bump_Scale=HEIGHT_BUMP)
    return g.resolve(node.outputs[0])


def _hq_sampler(g, ctx):
    w, h = ctx["height"].size[:2]
    node = g.group(G.height_map_sampler_group("hq"), UV=g.uv("UVMap"), Bump_Scale=HEIGHT_BUMP,
                   Sampler=_sampler(g, ctx["height"]), Width=w, Height=h)
    return g.resolve(node.outputs[0])


def _tri_sampler(g, ctx):
    node = g.group(G.triplanar_sampler_group(), Sampler=_sampler(g, ctx["normal"]))
    return g.resolve(node.outputs["Surface Gradient"])


def _tri_height_image(g, ctx):
    node = g.group(G.triplanar_height_group(ctx["height"]), Bump_Scale=HEIGHT_BUMP)
    return g.resolve(node.outputs[0])


def _tri_height_sampler(g, ctx):
    w, h = ctx["height"].size[:2]
    node = g.group(G.triplanar_height_sampler_group(), Bump_Scale=HEIGHT_BUMP,
                   Sampler=_sampler(g, ctx["height"]), Width=w, Height=h)
    return g.resolve(node.outputs[0])


def _parallax(sampler):
    def build(g, ctx):
        if sampler:
            par = g.group(G.parallax_sampler_group(), UV=g.uv("UVMap"), Bump_Scale=0.1,
                          Sampler=_sampler(g, ctx["height"]))
        else:
            par = g.group(G.parallax_group(ctx["height"]), UV=g.uv("UVMap"), Bump_Scale=0.1)
        nm = g.group(G.normal_map_group("UVMap"), Color=g.image(ctx["normal"],
                                                                 par.outputs["UV"]))
        return g.resolve(nm.outputs[0])
    return build


# (key, label, build, twin key, target key, look: "twin" | method name for the reference)
CASES = [
    ("none", "no perturbation", lambda g, ctx: None, None, None, None),
    ("nm-builtin", "Image Texture -> Normal Map node", _nm_builtin, None, None, None),
    ("nm-sg", "Image Texture -> SG Normal Map -> SG Resolve", _nm_sg, "nm-builtin",
     "normal-map", "twin"),
    ("bump-builtin", "Noise -> Bump node", _bump_builtin, None, None, None),
    ("bump-sg", "Noise -> SG Height Map Forward -> SG Resolve", _bump_sg, "bump-builtin",
     "height-forward", "twin"),
    ("tri-builtin", "Box-projected Image Texture -> Normal Map node", _tri_builtin, None, None,
     None),
    ("tri-sg", "3 Image Textures -> SG Triplanar -> SG Resolve", _tri_sg, "tri-builtin",
     "triplanar", "triplanar"),
    ("uv2-builtin", "Normal Map node on a second UV map", _uv2_builtin, None, None, None),
    ("uv2-sg", "SG Procedural Basis + SG Tangent Normal on a second UV map", _uv2_sg,
     "uv2-builtin", "second-uv", "procedural-basis"),
    ("layers2-builtin", "2 Normal Map nodes, added", _layers_builtin(2), None, None, None),
    ("layers3-builtin", "3 Normal Map nodes, added", _layers_builtin(3), None, None, None),
    ("layers2-sg", "2 SG Normal Map -> SG Combine -> SG Resolve", _layers_sg(2),
     "layers2-builtin", None, None),
    ("layers3-sg", "3 SG Normal Map -> 2 SG Combine -> SG Resolve", _layers_sg(3),
     "layers3-builtin", None, None),
]
# Blender 5.0+: each Sampler group against its per-image group (the twin).
SAMPLER_CASES = [
    ("hq-image", "SG Height Map HQ [image] (per-image)", _hq_image, None, None, None),
    ("hq-sampler", "SG Height Map HQ (Sampler)", _hq_sampler, "hq-image", None, "twin"),
    ("tri-sampler", "SG Triplanar (Sampler), one zone", _tri_sampler, "tri-sg", None, "twin"),
    ("triheight-image", "SG Triplanar Height [image] (per-image)", _tri_height_image, None,
     None, None),
    ("triheight-sampler", "SG Triplanar Height (Sampler)", _tri_height_sampler,
     "triheight-image", None, "twin"),
    ("parallax-image", "SG Parallax [image] (per-image) + SG Normal Map", _parallax(False),
     None, None, None),
    ("parallax-sampler", "SG Parallax (Sampler) + SG Normal Map", _parallax(True),
     "parallax-image", None, "twin"),
]


def cases():
    """The cases this Blender can render: the Sampler ones from 5.0."""
    from ...addon.sampler_zone import has_closures
    return CASES + (SAMPLER_CASES if has_closures() else [])


# Scene ------------------------------------------------------------------------------------------

def _float_image(name, pixels):
    from ..compare import bpy_float_image
    return bpy_float_image(name, pixels)


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
    ctx = {"normal": _float_image("rc_normal", R.images.hemisphere_tile_image(256)),
           "height": _float_image("rc_height", R.images.wave_height_image(64, (4.0, 2.0)))}
    return scene, obj, ctx


def material(name, build, ctx):
    mat = new_material(name)
    tree = mat.node_tree
    tree.nodes.clear()
    g = Graph(tree.nodes, tree.links)
    out = g.node("ShaderNodeOutputMaterial")
    bsdf = g.node("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.4
    g.link(bsdf.outputs[0], out.inputs["Surface"])
    normal = build(g, ctx)
    if normal is not None:
        g.link(normal, bsdf.inputs["Normal"])
    return mat


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


def _look(obj, mats, key, look, ctx, log):
    """Angle (mean, max degrees) between the SG material's normal and its twin's, or the
    bake-vs-reference figures of the method it uses."""
    from .. import bake, compare
    if look == "twin":
        twin = next(c for c in cases() if c[0] == key)[3]
        px = {}
        for k in (key, twin):
            build = next(c for c in cases() if c[0] == k)[2]
            px[k], cov, _ = bake.bake_vector(obj, lambda nodes, links, b=build:
                                             b(Graph(nodes, links), ctx), 128, 128, "UVMap")
        both = cov
        err = compare.angle_deg(px[key][both].astype(np.float64),
                                px[twin][both].astype(np.float64))
        return {"against": "twin", "mean_deg": float(err.mean()), "max_deg": float(err.max())}
    report, _ = compare.compare_object(obj, look, 64, log=lambda *_: None)
    return {"against": f"reference ({look})", "mean_deg": report["mean_deg"],
            "max_deg": report["max_deg"]}


def run(out_dir, quick=False, overwrite=False, log=print):
    import bpy
    out = Path(out_dir)
    if (out / "render_cost.json").exists() and not overwrite:
        raise FileExistsError(f"{out / 'render_cost.json'} exists; pass --overwrite to "
                              f"replace it")
    out.mkdir(parents=True, exist_ok=True)
    size, samples, repeats = (QUICK["size"], QUICK["samples"], QUICK["repeats"]) if quick \
        else (SIZE, SAMPLES, REPEATS)
    scene, obj, ctx = build_scene(size, samples)
    mats = {key: material(f"RC {key}", build, ctx) for key, _, build, *_ in cases()}
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
    if not quick:
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
    rows = []
    for key, label, _, twin, target, look in cases():
        row = {"key": key, "label": label, "seconds": med[key], **counts[key]}
        if twin:
            row["twin"] = twin
            row["ratio"] = med[key] / med[twin]
            over_twin = med[twin] - med["none"]
            row["overhead_ratio"] = (med[key] - med["none"]) / over_twin if over_twin > 0 \
                else None
            if target:
                row["target"] = TARGETS[target]
            if eevee:
                row["eevee_first_ratio"] = eevee[key]["first_s"] / eevee[twin]["first_s"]
                row["eevee_later_ratio"] = eevee[key]["later_s"] / eevee[twin]["later_s"]
            if look:
                row["look"] = _look(obj, mats, key, look, ctx, log)
        rows.append(row)
    # Marginal cost of a layer: (3 layers - 2 layers) in each chain.
    marginal = {"sg_s": med["layers3-sg"] - med["layers2-sg"],
                "builtin_s": med["layers3-builtin"] - med["layers2-builtin"]}
    result = {"blender": bpy.app.version_string, "size": size, "samples": samples,
              "repeats": repeats, "quick": quick, "rows": rows, "marginal_layer": marginal,
              "eevee": eevee, "seconds": time.perf_counter() - t_start}
    (out / "render_cost.json").write_text(json.dumps(result, indent=1))
    (out / "render_cost.md").write_text(markdown(result))
    _chart(result, out / "render_cost.png")
    log(markdown(result))
    return result


def markdown(result):
    lines = [f"Render cost, Cycles CPU, {result['size']} x {result['size']}, "
             f"{result['samples']} samples, median of {result['repeats']} interleaved rounds "
             f"(Blender {result['blender']})", "",
             "| material | render s | ratio to twin | target | overhead ratio | EEVEE first / "
             "later ratio | nodes (Normal Map, images) | look |",
             "|---|---|---|---|---|---|---|---|"]
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
        lines.append(f"| {r['label']} | {r['seconds']:.2f} | {ratio} | {target} | {over} | {ee} "
                     f"| {r['nodes']} ({r['normal_map_nodes']}, {r['image_lookups']}) | {look} |")
    m = result["marginal_layer"]
    lines += ["", f"One more normal-map layer: SG {m['sg_s']:.3f} s, built-in "
                  f"{m['builtin_s']:.3f} s."]
    return "\n".join(lines) + "\n"


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
    ax.barh(y, [r["ratio"] for r in rows], color=["#4c8" if r["ratio"] <= r.get("target", 9)
                                                  else "#d64" for r in rows])
    for i, r in enumerate(rows):
        if "target" in r:
            ax.plot([r["target"]] * 2, [i - 0.4, i + 0.4], color="k", lw=2)
    ax.axvline(1.0, color="0.5", lw=1, ls="--")
    ax.set_yticks(y, [r["label"] for r in rows], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("render time / Blender's own nodes (black: target)")
    ax.set_title(f"Render cost, Cycles CPU {result['size']}^2, {result['samples']} samples",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
