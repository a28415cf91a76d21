"""Far from the origin: every method's bake against the float64 reference with the test object
moved 0, 1 km and 10 km away, beside Blender's built-in node for the same job.

    python -m surfgrad_addon bench-far [--out DIR] [--resolution N] [--distances M ...]

Ours: compare.compare_object at each distance (the reference works in float64 from the same
float32 object matrix, so it carries no float32 position error; beyond 100 m compare gives the
mesh a temporary second user, addon/precise_bake.py, so Cycles keeps it in object space). Built-in: there is no float64
model of Blender's nodes, so each built-in is fed object-space coordinates (its texture does
not move with the object) and its bake at distance d is compared with its own bake at the
origin, texel by texel: whatever differs is float32 position error (the geometry, UVs and
normals are the same; only the translation changed).
"""

import json
import time
from pathlib import Path

import numpy as np

from .. import bake as B
from .. import compare as C
from .. import scenes
from ...addon.node_vocabulary import VMath
from ..graph import Graph
from ..methods import DECAL_FALLOFF, HEIGHT_BUMP_SCALE, NOISE_AMOUNT, NOISE_SCALE, METHODS
from ..methods import cases, decal_projector

DISTANCES = (0.0, 1000.0, 10000.0)
DIRECTION = np.array([1.0, 0.6, 0.3]) / np.linalg.norm([1.0, 0.6, 0.3])   # off every axis
FAR_OBJECTS = ("Sphere", "Transformed")
BAR = {"p99_deg": 0.1, "max_deg": 0.5}           # tests/test_bake_compare.py's agreement bar


# Blender's own nodes for each method's job, fed object-space (or UV) coordinates -------------

def _normal_map_node(g, color, uv_map, space="TANGENT"):
    nm = g.node("ShaderNodeNormalMap", space=space, uv_map=uv_map if space == "TANGENT" else "")
    g.link(color, nm.inputs["Color"])
    return nm.outputs["Normal"]


def _bump_node(g, height, distance):
    bump = g.node("ShaderNodeBump")
    bump.inputs["Distance"].default_value = distance
    g.link(height, bump.inputs["Height"])
    return bump.outputs["Normal"]


def _builtin_normal_map(inp, g):
    return _normal_map_node(g, g.image(inp.bpy_image("normal"), g.uv(inp.uv_map)), inp.uv_map)


def _builtin_detail_normal_map(inp, g):
    color = g.image(inp.bpy_image("detail"), g.uv(inp.detail_uv))
    return _normal_map_node(g, color, inp.detail_uv)


def _builtin_object_normal_map(inp, g):
    return _normal_map_node(g, g.image(inp.bpy_image("normal"), g.uv(inp.uv_map)), "",
                            space="OBJECT")


def _builtin_noise_bump(inp, g):
    noise = g.node("ShaderNodeTexNoise", noise_dimensions="3D")
    g.link(g.node("ShaderNodeTexCoord").outputs["Object"], noise.inputs["Vector"])
    noise.inputs["Scale"].default_value = NOISE_SCALE
    noise.inputs["Detail"].default_value = 3.0
    return _bump_node(g, noise.outputs["Fac"], NOISE_AMOUNT)


def _builtin_height_bump(inp, g):
    height = g.first(g.image(inp.bpy_image("height"), g.uv(inp.uv_map)))
    return _bump_node(g, height, HEIGHT_BUMP_SCALE)


def _box(inp, g, image):
    color = g.image(inp.bpy_image(image), g.node("ShaderNodeTexCoord").outputs["Object"],
                    projection="BOX")
    color.node.projection_blend = 0.3
    return color


def _builtin_box_normal_map(inp, g):
    return _normal_map_node(g, _box(inp, g, "normal"), inp.uv_map)


def _builtin_box_bump(inp, g):
    return _bump_node(g, g.first(_box(inp, g, "height")), HEIGHT_BUMP_SCALE)


def _builtin_projector_normal_map(inp, g):
    q = g.node("ShaderNodeTexCoord", object=inp.projector).outputs["Object"]
    uv = g.vmath(VMath.MULTIPLY_ADD, q, (0.5, 0.5, 0.0), (0.5, 0.5, 0.0))
    return _normal_map_node(g, g.image(inp.bpy_image("normal"), uv, extension="CLIP"),
                            inp.uv_map)


# label, builder(inputs, graph) -> a Normal socket, whether it needs a decal projector
BUILTINS = {
    "Normal Map node": (_builtin_normal_map, False),
    "Normal Map node (Detail UV)": (_builtin_detail_normal_map, False),
    "Normal Map node (Object space)": (_builtin_object_normal_map, False),
    "Noise Texture + Bump (Object)": (_builtin_noise_bump, False),
    "Image Texture + Bump (UV)": (_builtin_height_bump, False),
    "Box projection + Normal Map (Object)": (_builtin_box_normal_map, False),
    "Box projection + Bump (Object)": (_builtin_box_bump, False),
    "Projector Texture Coordinate + Normal Map": (_builtin_projector_normal_map, True),
}

# Each method's job, done by a built-in node.
BUILTIN_FOR = {
    "normal-map": "Normal Map node", "parallax": "Normal Map node",
    "post-resolve": "Normal Map node", "layered": "Normal Map node",
    "blend-pd": "Normal Map node", "blend-whiteout": "Normal Map node",
    "blend-udn": "Normal Map node", "blend-rnm": "Normal Map node",
    "procedural-basis": "Normal Map node (Detail UV)",
    "object-normal": "Normal Map node (Object space)",
    "volume-noise": "Noise Texture + Bump (Object)",
    "displace-bump": "Noise Texture + Bump (Object)",
    "height-map": "Image Texture + Bump (UV)",
    "triplanar": "Box projection + Normal Map (Object)",
    "triplanar-height": "Box projection + Bump (Object)",
    "decal": "Projector Texture Coordinate + Normal Map",
}


def bake_builtin(obj, label, resolution):
    """Bake built-in `label` on obj: (pixels, coverage)."""
    import bpy
    build, needs_projector = BUILTINS[label]
    inp = C.prepare_inputs(obj)
    try:
        if needs_projector:
            inp.projector = decal_projector(obj)
        pixels, covered, _ = B.bake_vector(obj, lambda nodes, links: build(inp, Graph(nodes, links)),
                                           resolution, resolution, uv_map=inp.uv_map)
        return pixels, covered
    finally:
        if inp.projector is not None:
            bpy.data.objects.remove(inp.projector)
        for _, img in inp.images.values():
            bpy.data.images.remove(img)


def _stats(err):
    return {"mean_deg": float(err.mean()), "p99_deg": float(np.percentile(err, 99)),
            "max_deg": float(err.max())}


def measure(objects, distances=DISTANCES, resolution=64, methods=None, log=print):
    """Rows {method, variant, object, distance_m, ours: stats, builtin, builtin_stats}: ours
    against the float64 reference at each distance, the built-in against its own bake at the
    origin. The objects are put back where they were."""
    import bpy
    todo = [(m, v) for m, v in cases() if methods is None or m in methods]
    rows = []
    for name, obj in objects.items():
        home = obj.matrix_world.copy()
        origin_builtin = {}
        try:
            for d in distances:
                obj.matrix_world = home.copy()
                obj.location = tuple(np.array(home.translation) + d * DIRECTION)
                bpy.context.view_layer.update()
                builtin_here = {}
                for method, variant in todo:
                    t0 = time.perf_counter()
                    report, _ = C.compare_object(obj, method, resolution, variant=variant,
                                                 log=lambda *_: None)
                    label = BUILTIN_FOR.get(method)
                    stats = None
                    if label is not None:
                        if label not in builtin_here:
                            builtin_here[label] = bake_builtin(obj, label, resolution)
                        if d == distances[0]:
                            origin_builtin.setdefault(label, builtin_here[label])
                        here, there = builtin_here[label], origin_builtin.get(label)
                        if there is not None:
                            both = here[1] & there[1]
                            stats = _stats(C.angle_deg(here[0][both], there[0][both]))
                    row = {"method": method, "variant": variant if len(METHODS[method].variants)
                           > 1 else None, "object": name, "distance_m": d,
                           "ours": {k: report[k] for k in ("mean_deg", "p99_deg", "max_deg",
                                                           "texels_compared")},
                           "builtin": label, "builtin_stats": stats}
                    rows.append(row)
                    b = (f", built-in max {stats['max_deg']:.4f}" if stats else "")
                    log(f"{_label(row):24s} {name:12s} {d:>8.0f} m: ours p99 "
                        f"{report['p99_deg']:.4f} max {report['max_deg']:.4f} deg{b} "
                        f"({time.perf_counter() - t0:.1f} s)")
        finally:
            obj.matrix_world = home
            bpy.context.view_layer.update()
    return rows


def _label(row):
    return row["method"] + (f" ({row['variant']})" if row["variant"] else "")


def _km(d):
    return "0" if d == 0 else (f"{d / 1000:g} km" if d >= 1000 else f"{d:g} m")


def markdown(rows, resolution):
    """One table per method: distance by object, ours (p99 / max against the reference) beside
    the built-in (p99 / max against its own origin bake)."""
    lines = [f"# Far from the origin ({resolution}^2 bakes)", "",
             "Ours: angular error (deg) of the Cycles bake against the float64 reference at the "
             "same place. Built-in: the built-in node's bake at that distance against its own "
             "bake at the origin (object-space or UV coordinates, so only float32 position "
             "error differs). Bar: p99 <= 0.1, max <= 0.5. Direction of travel: "
             f"{tuple(round(float(x), 3) for x in DIRECTION)}.", ""]
    for label in dict.fromkeys(_label(r) for r in rows):
        mine = [r for r in rows if _label(r) == label]
        lines += [f"## {label}", "", f"Built-in: {mine[0]['builtin'] or 'none'}", "",
                  "| object | distance | ours p99 | ours max | within bar | built-in p99 | "
                  "built-in max |", "|---|---|---|---|---|---|---|"]
        for r in mine:
            o, b = r["ours"], r["builtin_stats"]
            ok = o["p99_deg"] <= BAR["p99_deg"] and o["max_deg"] <= BAR["max_deg"]
            bs = (f"{b['p99_deg']:.4f} | {b['max_deg']:.4f}" if b else "- | -")
            lines.append(f"| {r['object']} | {_km(r['distance_m'])} | {o['p99_deg']:.4f} | "
                         f"{o['max_deg']:.4f} | {'yes' if ok else 'NO'} | {bs} |")
        lines.append("")
    return "\n".join(lines)


def run(out_dir, resolution=64, distances=DISTANCES, objects=FAR_OBJECTS, methods=None,
        overwrite=False, log=print):
    """The command: build the test scene, measure, write far.json and far.md."""
    problem = C.resolution_problem(resolution, *C.RESOLUTION_RANGE)
    if problem:
        raise C.CompareError(problem)
    unknown = sorted(set(methods or ()) - set(METHODS))
    if unknown:
        raise C.CompareError(f"unknown method(s) {unknown}; use any of {sorted(METHODS)}")
    bad = sorted(set(objects) - set(scenes.SCENE_OBJECTS))
    if bad:
        raise C.CompareError(f"unknown test object(s) {bad}; use any of "
                             f"{list(scenes.SCENE_OBJECTS)}")
    if any(not np.isfinite(d) or d < 0 for d in distances):
        raise C.CompareError(f"distances must be finite and >= 0 metres, got {list(distances)}")
    distances = tuple(sorted(set(float(d) for d in distances) | {0.0}))  # 0: built-ins' base
    out = Path(out_dir)
    paths = out / "far.json", out / "far.md"
    for p in paths:
        if p.exists() and not overwrite:
            raise C.CompareError(f"{p} exists; pass --overwrite to replace it")
    out.mkdir(parents=True, exist_ok=True)
    made = scenes.new_scene(tuple(objects))
    rows = measure(made, distances, resolution, methods, log)
    import bpy
    paths[0].write_text(json.dumps({"resolution": resolution, "distances_m": list(distances),
                                    "direction": DIRECTION.tolist(), "bar": BAR,
                                    "blender": bpy.app.version_string, "rows": rows},
                                   indent=2))
    paths[1].write_text(markdown(rows, resolution))
    log(f"wrote {paths[0]} and {paths[1]}")
    return rows
