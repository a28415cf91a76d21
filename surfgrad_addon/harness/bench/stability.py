"""Where methods fail: every method through degenerate and hostile cases.

For each case and method: the fraction of baked outputs that are finite unit vectors, the
fraction facing away from the geometric normal (and how many do where the truth does not),
and the error against the truth where one exists (the method's float64 reference on valid
input). Every texel the bake covers counts, island borders included.
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import compare as C
from .. import methods
from ..graph import Graph, surface_gradient
from ..method_scene import decal_projector
from ...addon import groups as G
from ...addon.node_vocabulary import Math
from ...reference import methods as M
from ...reference.method_registry import NOISE_AMOUNT, NOISE_OCTAVES, NOISE_SCALE
from ...reference import images as T


MIKKTSPACE_METHODS = tuple(m.name for m in methods.METHODS.values() if m.mikktspace) + \
    ("Blender Normal Map",)


@dataclass
class Case:
    name: str
    build: Callable            # () -> (object, image pixels or None, overrides dict)
    has_truth: bool = True
    no_truth_for: tuple = ()   # methods whose reference is not the truth in this case


def _scene(names=("Sphere",)):
    from .. import scenes
    return scenes.new_scene(list(names))


def _zero_area_uv():
    obj = _scene()["Sphere"]
    mesh = obj.data
    uv = np.empty(len(mesh.loops) * 2)
    mesh.uv_layers["Detail"].uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    for poly in list(mesh.polygons)[::5]:        # every fifth face collapses to a point
        uv[poly.loop_start:poly.loop_start + poly.loop_total] = uv[poly.loop_start]
    mesh.uv_layers["Detail"].uv.foreach_set("vector", uv.ravel())
    mesh.update()
    return obj, None, {}


def _mirrored():
    return _scene(["Torus"])["Torus"], None, {}


def _z_le_zero():
    img = T.hemisphere_tile_image(128)
    m = img * 2 - 1
    m[::3, ::2] = [0.8, -0.6, 0.0]                # z = 0
    m[1::3, ::2] = [0.3, 0.4, -0.866]             # z < 0
    return _scene()["Sphere"], 0.5 * m + 0.5, {}


def _back_faces():
    obj = _scene(["Plane"])["Plane"]
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.reverse_faces(bm, faces=bm.faces[:])
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()
    return obj, None, {}


def _grazing():
    obj = _scene()["Sphere"]
    mesh = obj.data
    normals = []
    for loop in mesh.loops:
        n = np.array(mesh.vertices[loop.vertex_index].normal)
        t = np.cross(n, [0.0, 0.0, 1.0])
        t = t / max(np.linalg.norm(t), 1e-9)
        g = n * np.cos(np.radians(85)) + t * np.sin(np.radians(85))   # 85 degrees off
        normals.append(g / np.linalg.norm(g))
    mesh.normals_split_custom_set(normals)
    mesh.update()
    return obj, None, {}


def _nan_pixels():
    img = T.hemisphere_tile_image(128).copy()
    img[10:40, 10:40, 0] = np.nan
    img[60:70, :, 1] = np.inf
    img[80:90, 5:50, 2] = -np.inf
    return _scene()["Sphere"], img, {}


def _huge_scale():
    return _scene()["Sphere"], None, {"huge": True}


def _far_away():
    obj = _scene()["Sphere"]
    obj.location = (10000.0, 0.0, 0.0)
    return obj, None, {}


def _extreme_scale():
    obj = _scene()["Sphere"]
    obj.scale = (50.0, 0.02, -1.0)
    return obj, None, {}


CASES = [
    Case("zero-area UV triangles (second UV map)", _zero_area_uv),
    Case("mirrored and rotated UV islands", _mirrored),
    Case("normal-map texels with z = 0 and z < 0", _z_le_zero),
    Case("back faces (reversed winding)", _back_faces),
    # Cycles runs MikkTSpace with the custom split normals; Blender's calc_tangents (which the
    # reference's tangents come from) does not see them, so with normals 85 degrees off the
    # two tangent frames differ (flip): no truth for the MikkTSpace methods here.
    Case("grazing base normals (85 deg)", _grazing, no_truth_for=MIKKTSPACE_METHODS),
    Case("NaN and Inf pixels in the image", _nan_pixels, has_truth=False),
    Case("huge bump scales", _huge_scale),
    Case("object 10 km from the origin", _far_away),
    Case("extreme non-uniform and negative scale", _extreme_scale),
]

SG_METHODS = [m.name for m in methods.METHODS.values() if m.stability]
HUGE = 200.0
# "huge bump scales": the parameters each method runs at in that case.
HUGE_VALUES = {"volume-noise": {"amount": HUGE}, "normal-map": {"strength": 10.0}}


def _blender_normal_map(inp, nodes, links):
    g = Graph(nodes, links)
    color = g.image(inp.bpy_image("normal"), g.uv(inp.uv_map))
    return g.set(g.node("ShaderNodeNormalMap", uv_map=inp.uv_map), Color=color).outputs["Normal"]


def _perlin(amount):
    def graph(inp, nodes, links):
        g = Graph(nodes, links)
        noise = g.group(G.noise_group(), Scale=NOISE_SCALE)
        return g.perlin(g.geometry("Normal"), g.scale(noise.outputs["Gradient"], amount))
    return graph


def _methods(overrides):
    """(label, family, graph, reference) for a case."""
    amount = HUGE if overrides.get("huge") else NOISE_AMOUNT
    out = []
    for name in SG_METHODS:
        m = methods.METHODS[name]
        if overrides.get("huge"):
            m = m.at(**HUGE_VALUES.get(name, {}))
        out.append((name, "sg", m.graph, m.reference))
    out.append(("Blender Normal Map", "blender", _blender_normal_map,
                methods.METHODS["normal-map"].reference))
    out.append(("Perlin 1985 noise", "baseline", _perlin(amount),
                lambda inp, td: M.volume_noise_surfgrad(td, NOISE_SCALE, amount,
                                                            NOISE_OCTAVES)))
    return out


def _non_finite(g, kind):
    """A vector socket (x, 0, 0) with x zero, NaN (inf - inf) or inf (exp(1000))."""
    if kind == "zero":
        return g.combine(0.0, 0.0)
    inf = g.math(Math.EXPONENT, 1000.0)
    return g.combine(g.math(Math.SUBTRACT, inf, inf) if kind == "nan" else inf, 0.0)


def _group_input_cases(resolution):
    """Zero-length and non-finite vectors fed to the groups' vector inputs."""
    import bpy
    obj = _scene()["Sphere"]
    rows = []
    specs = [("SG Resolve", G.resolve_group, ["Normal", "Surface Gradient"]),
             ("SG Volume Gradient", G.volume_gradient_group, ["Normal", "Gradient"]),
             ("SG Object Normal", G.object_normal_group, ["Normal", "Perturbed Normal"]),
             ("SG Tangent Normal", G.tangent_normal_group, ["Tangent", "Bitangent"]),
             ("SG Procedural Basis", G.procedural_basis_group, ["Normal", "UV"]),
             ("SG Combine", G.combine_group, ["A", "B"]),
             ("SG Triplanar", G.triplanar_group, ["Normal"])]
    for label, tree_fn, sockets in specs:
        for kind in ("zero", "nan", "inf"):
            def graph(inp, nodes, links, tree_fn=tree_fn, sockets=sockets, kind=kind):
                g = Graph(nodes, links)
                src = _non_finite(g, kind)
                node = g.group(tree_fn(), **{s: src for s in sockets})
                out = node.outputs[0]
                if out.name == "Normal":
                    return out
                if label == "SG Procedural Basis":      # a frame: feed it to a normal map
                    out = surface_gradient(g.group(
                        G.tangent_normal_group(), Color=(0.8, 0.3, 0.9, 1.0),
                        Tangent=node.outputs[0], Bitangent=node.outputs[1]))
                return g.resolve(out)
            inp = C.prepare_inputs(obj)
            try:
                report, _ = C.compare_graph(
                    inp, obj, graph, lambda inp, td: (M.unit_base_normal(td),
                                                      np.zeros((len(td.pixel), 3))), resolution)
            finally:
                for _, img in inp.images.values():
                    bpy.data.images.remove(img)
            rows.append(_row(f"{kind} into {', '.join(sockets)}", label, "sg", report, False))
    return rows


def _row(case, method, family, report, has_truth):
    return {"case": case, "method": method, "family": family,
            "finite_unit_fraction": report["finite_unit_fraction_all"],
            "facing_away_fraction": report["facing_away_fraction"],
            "truth_facing_away_fraction": report["truth_facing_away_fraction"] if has_truth else None,
            "faces_away_where_truth_does_not": report["faces_away_where_truth_does_not"]
            if has_truth else None,
            "mean_deg": report["mean_deg"] if has_truth else None,
            "max_deg": report["max_deg"] if has_truth else None}


def run(quick=False, log=print, resolution=None):
    import bpy
    resolution = resolution or (32 if quick else 64)
    rows = []
    for case in CASES:
        obj, pixels, overrides = case.build()
        for label, family, graph, ref in _methods(overrides):
            inp = C.prepare_inputs(obj, image=pixels)
            try:
                if label == "decal":
                    inp.projector = decal_projector(obj)
                # NaN pixels make the reference's own output NaN: expected, not a warning.
                with np.errstate(invalid="ignore", divide="ignore"):
                    report, _ = C.compare_graph(inp, obj, graph, ref, resolution)
            finally:
                for _, img in inp.images.values():
                    bpy.data.images.remove(img)
                if inp.projector is not None:
                    bpy.data.objects.remove(inp.projector)
            rows.append(_row(case.name, label, family, report,
                             case.has_truth and label not in case.no_truth_for))
        worst = min(r["finite_unit_fraction"] for r in rows if r["case"] == case.name)
        log(f"  stability: {case.name}: lowest finite-unit fraction {worst:.4f}")
    rows += _group_input_cases(resolution)
    log("  stability: zero and non-finite vectors into the groups' inputs done")
    return rows


def markdown(rows):
    lines = ["## Stability: where methods fail", "",
             "Every texel the bake covers. finite unit: outputs that are finite unit vectors; "
             "away: outputs facing away from the geometric normal (in brackets: the truth's); "
             "error against the truth where the input defines one.", "",
             "| case | method | kind | finite unit | away (truth) | away where truth is not | "
             "mean deg | max deg |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        truth = (f" ({100 * r['truth_facing_away_fraction']:.2f}%)"
                 if r["truth_facing_away_fraction"] is not None else "")
        fmt = (lambda v: "" if v is None else f"{v:.3f}")
        lines.append(f"| {r['case']} | {r['method']} | {r['family']} | "
                     f"{100 * r['finite_unit_fraction']:.2f}% | "
                     f"{100 * r['facing_away_fraction']:.2f}%{truth} | "
                     f"{'' if r['faces_away_where_truth_does_not'] is None else r['faces_away_where_truth_does_not']} | "
                     f"{fmt(r['mean_deg'])} | {fmt(r['max_deg'])} |")
    return "\n".join(lines) + "\n"
