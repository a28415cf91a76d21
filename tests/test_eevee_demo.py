"""The demo's exhibits render the same normals in EEVEE as in Cycles.

demo.build_demo() builds every exhibit in a child interpreter (this file run as a script,
like tests/test_eevee.py, whose context probe, skip reason and helpers this reuses: a GPU
context that cannot be made aborts the process inside Blender's GL loader). Every exhibit
material's Principled BSDF is replaced by an Emission of the normal that fed its Normal input,
as colour n * 0.5 + 0.5 (the Geometry normal where nothing was linked: the "displaced, normals
recomputed" side), labels are hidden, and each exhibit camera is rendered once with Cycles and
once with EEVEE. Each material's pixels (usual on the left, surface gradient on the right) are
compared. Where no OpenGL context can be made the test is skipped with the reason printed.

Set-up, as in tests/test_eevee.py (each measured there): samples 1, no pixel filter, no
shadows, no ray tracing, no world, 32-bit EXR, anisotropic filtering off (the preference, and
from 5.2 the scene's RenderSettings.anisotropic_filter, which alone decides there: both set by
configure_render). EEVEE's film stores half floats: ~0.05 deg between the engines on any normal.

Minification. The demo's images are 256 px (the detail tile on a UV map tiled twice, the
triplanar tile 1.2 times per unit), and EEVEE samples 'Linear' images through mipmaps where
they are minified (Cycles CPU never does). So each camera renders at a width where its images
are magnified in most of the view (render_size: at the front surface a pixel is at most half a
texel of the exhibit's densest image, TEXELS_PER_UNIT), in a band through the objects' centres
(the exhibit camera's horizontal field of view, cropped vertically: the sensor fits the
width), and pixels where an image is still minified are excluded and counted: a third,
Cycles-only render of the world position (a material override) gives each pixel's footprint,
the largest step to a 4-neighbour, and a pixel is compared only where footprint x texels per
unit <= 1 (the GPU samples mip level 0 alone there). Grazing pixels (more than MAX_VIEW_ANGLE
from facing the camera, by the position render's finite-difference normal), silhouettes and
occlusion edges (3 x 3 neighbourhood, and steps over 4 nominal pixel sizes) are excluded too.
The table printed by the test also gives every interior pixel's difference, minified and
grazing included (the mipmaps alone put up to 50 degrees between the engines there).
"""

import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from surfgrad_addon.addon.compat import new_material  # noqa: E402

pytestmark = pytest.mark.tier("eevee")


sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_eevee import (BPY_OK, _angle_deg, configure_render, probe_gpu_context,  # noqa: E402
                        run_eevee_child)

ROOT = Path(__file__).resolve().parents[1]
MAX_VIEW_ANGLE = 70.0         # degrees between the position render's normal and the view ray
FRONT_HALF_TEXEL = 2.0        # pixel <= half a texel at the front: magnified up to 60 degrees

# Texels of the exhibit's densest 'Linear' image per world unit, in the worst direction (an
# exhibit missing here fails the test: state its density):
# - layered: the 256 px detail tile on the turned second map (tiled 2 x 1): 2 * 256 / (2 pi)
#   = 256 / pi = 81.5 along either axis (the 128 px macro waves on UVMap: 41).
# - triplanar: SG Triplanar Coordinates and the Box projection at Scale 1.2: 1.2 * 256 = 307.
# - decal: the projector box is 2 x (0.8, 0.65) units for one 256 px image: 256 / 1.3 = 197.
# - height: the reference's 128 px normal map on a 0.72-scaled sphere: 128 / (0.72 pi) = 57
#   (the 16 px height image: 7; SG Height Map's taps are 'Closest' or at texel centres).
# - parallax: 256 px images on a 2.2-unit plane: 116.
# - noise, displacement: procedural, no image.
# - decal-shapes: the 128 px decal over a 2 x 0.62-unit projector: 128 / 1.24 = 103 (the
#   256 px detail tile on spheres of radius 0.8: 256 / (0.8 pi) = 102).
# - sampler (5.0+): 32 px height images on unit spheres: 32 / pi = 10.2.
TEXELS_PER_UNIT = {"layered": 82.0, "triplanar": 307.0, "decal": 197.0, "noise": 0.0,
                   "height": 57.0, "displacement": 0.0, "parallax": 116.0,
                   "decal-shapes": 103.0, "sampler": 10.2}
OBJECT_RADIUS = 1.0           # the exhibits' objects reach ~1 unit towards the camera
MIN_WIDTH = 480
BAND = 0.6                    # half-height (units, at the objects) of the rendered band
BAND_OVERRIDE = {"decal": 0.9,    # the whole decal
                 "decal-shapes": 2.3}   # both rows


# Angular difference EEVEE vs Cycles in degrees per material over the compared pixels: bounds
# on the mean, median, p99, max and the fraction of pixels over 1 degree. Measured with bpy
# 5.0.1 on Mesa 22.3 llvmpipe (mean / p50 / p99 / max / fraction over 1 degree):
TOLERANCES = {
    # Both engines get the same inputs: every surface-gradient material (SG Normal Map,
    # Procedural Basis, Tangent Normal, Combine, Triplanar, Decal, Volume Gradient, Noise,
    # Height Map one-texel and HQ, Rest Position) and the usual sides built from math nodes or
    # a Normal Map node on a plain sphere. 0.038-0.066 / - / 0.12-0.16 / 0.17-3.8 / <= 0.0003:
    # mean and p99 are EEVEE's half-float film (test_eevee.py's bare shading normal: 0.048 /
    # 0.116); the max is a pixel at a sharp edge of an image (the hemisphere tiles' rims, HQ's
    # 'Closest' taps) that Cycles' ~0.03 px sample offset puts on the other side. The bounds
    # are test_eevee.py's 'exact' family.
    # The decal shapes (both sides; bpy 5.2.3): 0.033-0.062 / - / 0.106-0.156 / 0.19-1.13 / 0.
    "floor": {"mean": 0.1, "p99": 0.25, "max": 8.0},
    # The usual triplanar: Blender's Box projection of Texture Coordinate > Object into a
    # Normal Map node. 2.2 / 0.088 / 54 / 84 / 0.063: EEVEE draws a one-pixel line along every
    # triangle edge where the image comes back as its coarsest mip (its mean colour, a flat
    # normal). It is EEVEE's texture LOD for the object's own Object coordinates on pixel
    # quads that straddle a triangle edge (measured: the same lookup with 'Closest'
    # interpolation, or on Geometry > Position, or the Object coordinates emitted as colour,
    # show no lines; Flat projection of the same coordinates shows them). Off the lines it
    # matches (median at the floor) apart from the engines' tangent frames on the displaced
    # rock (Cycles computes MikkTSpace on its triangles, Blender on the quads, which
    # displacement makes non-planar: 0.1-0.2 degrees). Bounds: the median, and the lines'
    # share of pixels.
    "object-coordinates": {"p50": 0.15, "over_1deg": 0.12},
    # Parallax occlusion (both sides are SG Parallax): 0.066-0.075 / 0.014-0.034 / 0.086 / 27
    # / 0.0062. The march's occlusion contour (the far rim of each dome) is a discontinuity;
    # Cycles' sample offset and float rounding move it by a pixel. Bounds: mean and p99 at the
    # floor, the contour's share of pixels.
    "pom-contour": {"mean": 0.15, "p99": 0.25, "over_1deg": 0.015},
    # SG Height Map Forward takes forward differences along the render's differentials
    # (Cycles: ray differentials; EEVEE: dFdx/dFdy of its 2 x 2 pixel quad), so the engines
    # sample the height at different points and differ by the method's discretisation error
    # at this pixel size. On the exhibit's magnified 16 px height image at Bump Scale 1.0 the
    # slope jumps at every texel edge, and each engine steps across an edge at its own
    # points (bpy 5.2.3): 2.0 / 0.70 / 17.1 / 32.7 / 0.35 (on the earlier 64 px image at 0.35:
    # 1.44 / 1.08 / 5.5 / 11.6 / 0.53; test_eevee.py: 0.75 / 3.3 / 6.2 at its size). Bounds:
    # twice the measured.
    "screen-derivative": {"mean": 4.0, "p99": 35.0, "max": 66.0},
    # The sampler exhibit's usual side: Blender's Bump node on 32 px height images. On the
    # waves it is the Forward height map's case above (0.26 / 0.08 / 5.8 / 11.5 / 0.043);
    # on the domes its forward differences straddle the domes' rims, where the height's slope
    # jumps, and each engine steps across a rim at its own points: 0.50 / 0.066 / 11.6 / 43.9 /
    # 0.040 (bpy 5.2.3). Bounds: twice the mean, p99 and share of pixels over 1 degree; a rim
    # pixel can differ by any angle, so no max. (Its surface-gradient side, SG Height Map HQ
    # (Sampler), is at the floor: 0.056-0.063 / - / 0.13-0.14 / 0.6-1.2.)
    "bump-node-rims": {"mean": 1.0, "p99": 23.0, "over_1deg": 0.08},
}


def family(exhibit, label):
    """The tolerance family of an exhibit's material (label: the material name after ': ')."""
    if exhibit == "triplanar" and label == "usual":
        return "object-coordinates"
    if exhibit == "parallax":
        return "pom-contour"
    if exhibit == "height" and label == "forward":
        return "screen-derivative"
    if exhibit == "sampler" and label.endswith("usual"):
        return "bump-node-rims"               # Blender's Bump node: forward differences
    return "floor"


def render_size(name, cam_distance, fov):
    """(width, height) for an exhibit camera: at the front surface a pixel is at most
    1 / FRONT_HALF_TEXEL texels of the densest image (magnified up to 60 degrees from facing
    the camera); the height is a band of +- BAND units through the objects' centres (same
    horizontal field of view: the sensor fits the width)."""
    if name not in TEXELS_PER_UNIT:
        raise KeyError(f"exhibit {name!r}: add its image density to TEXELS_PER_UNIT")
    span = 2.0 * math.tan(fov / 2.0)
    width = span * (cam_distance - OBJECT_RADIUS) * FRONT_HALF_TEXEL * TEXELS_PER_UNIT[name]
    width = max(MIN_WIDTH, 16 * math.ceil(width / 16))
    height = 2 * BAND_OVERRIDE.get(name, BAND) / (span * cam_distance) * width
    return width, 8 * math.ceil(height / 8)


# The child: build, convert to emission of the normal, render, save ------------------------------

def emit_normals(bpy):
    """Every material with a Principled BSDF on its output: Emission of the normal that fed
    the BSDF's Normal (the Geometry normal where nothing was linked), as n * 0.5 + 0.5.
    Returns {material name: the node that made the normal (or 'Geometry')}."""
    made = {}
    for mat in bpy.data.materials:
        tree = mat.node_tree
        if tree is None:
            continue
        outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
        if not outputs or not outputs[0].inputs["Surface"].is_linked:
            continue
        output = outputs[0]
        bsdf = output.inputs["Surface"].links[0].from_node
        if bsdf.bl_idname != "ShaderNodeBsdfPrincipled":
            continue
        normal_in = bsdf.inputs["Normal"]
        if normal_in.is_linked:
            normal = normal_in.links[0].from_socket
            made[mat.name] = normal.node.label or normal.node.name
        else:
            normal = tree.nodes.new("ShaderNodeNewGeometry").outputs["Normal"]
            made[mat.name] = "Geometry"
        colour = tree.nodes.new("ShaderNodeVectorMath")
        colour.operation = "MULTIPLY_ADD"
        tree.links.new(normal, colour.inputs[0])
        colour.inputs[1].default_value = (0.5, 0.5, 0.5)
        colour.inputs[2].default_value = (0.5, 0.5, 0.5)
        emit = tree.nodes.new("ShaderNodeEmission")
        emit.inputs["Strength"].default_value = 1.0
        tree.links.new(colour.outputs[0], emit.inputs["Color"])
        tree.links.new(emit.outputs[0], output.inputs["Surface"])
    return made


def _position_material(bpy):
    mat = new_material("SG position override")
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    geo = nodes.new("ShaderNodeNewGeometry")
    emit = nodes.new("ShaderNodeEmission")
    links.new(geo.outputs["Position"], emit.inputs["Color"])
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(emit.outputs[0], out.inputs["Surface"])
    return mat


def _render(bpy, path):
    rd = bpy.context.scene.render
    rd.filepath = str(path)
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t0
    img = bpy.data.images.load(str(path), check_existing=False)
    px = np.empty(rd.resolution_x * rd.resolution_y * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    path.unlink()
    return px.reshape(rd.resolution_y, rd.resolution_x, 4), seconds


def _child(out_dir, only=None):
    out_dir = Path(out_dir)
    t_start = time.perf_counter()
    import bpy
    print(BPY_OK, flush=True)
    eevee_id, renderer = probe_gpu_context(out_dir)
    t_probe = time.perf_counter() - t_start

    from surfgrad_addon.harness import demo
    t0 = time.perf_counter()
    cams = demo.build_demo(log=lambda *a: None)
    t_build = time.perf_counter() - t0
    scene = bpy.context.scene
    for obj in scene.objects:
        if obj.type == "FONT":
            obj.hide_render = True              # the labels
    on_meshes = {s.material.name for o in scene.objects if o.type == "MESH"
                 for s in o.material_slots if s.material is not None}
    made = {k: v for k, v in emit_normals(bpy).items() if k in on_meshes}
    scene.world = None
    rd = scene.render
    configure_render(scene)
    position = _position_material(bpy)
    view_layer = bpy.context.view_layer

    meshes = [o for o in scene.objects if o.type == "MESH"]
    meta = {"exhibits": {}, "renderer": renderer, "made": made, "cameras": sorted(cams),
            "seconds": {"probe": t_probe, "build": t_build}}
    arrays = {}
    for name, cam in cams.items():
        if only and name not in only:
            continue
        distance = abs(cam.location.y)           # cameras look along +Y at y = 0
        width, height = render_size(name, distance, cam.data.angle_x)
        rd.resolution_x, rd.resolution_y = width, height
        scene.camera = cam
        # The exhibit's objects: those whose centre is in the camera's horizontal view.
        half = math.tan(cam.data.angle_x / 2.0) * distance
        objs = sorted((o for o in meshes if abs(o.location.x - cam.location.x) < half),
                      key=lambda o: o.location.x)
        meta["exhibits"][name] = {
            "camera": cam.name, "size": [width, height],
            "objects": [{"name": o.name, "x": o.location.x, "z": o.location.z,
                         "material": o.data.materials[0].name} for o in objs],
            "camera_location": list(cam.location),
            "fov": cam.data.angle_x, "seconds": {}}
        for engine, key in (("CYCLES", "cycles"), (eevee_id, "eevee"), ("CYCLES", "position")):
            rd.engine = engine
            view_layer.material_override = position if key == "position" else None
            arrays[f"{name}/{key}"], seconds = _render(bpy, out_dir / f"{name}_{key}.exr")
            meta["exhibits"][name]["seconds"][key] = seconds
            print(f"rendered {name} {key} {width} x {height} in {seconds:.1f} s", flush=True)
        view_layer.material_override = None
    np.savez(out_dir / "renders.npz", **arrays)
    meta["seconds"]["child"] = time.perf_counter() - t_start
    (out_dir / "renders.json").write_text(json.dumps(meta, indent=1))
    print("SG_EEVEE_DONE", flush=True)


# Measuring ---------------------------------------------------------------------------------------

def _shift(a, dy, dx, fill):
    out = np.full_like(a, fill)
    h, w = a.shape[:2]
    out[max(dy, 0):h + min(dy, 0), max(dx, 0):w + min(dx, 0)] = \
        a[max(-dy, 0):h + min(-dy, 0), max(-dx, 0):w + min(-dx, 0)]
    return out


def pixel_geometry(pos, alpha, cam_location, fov, width):
    """Per pixel from the position render: covered 3 x 3 neighbourhood, footprint (largest
    world distance to a 4-neighbour), cosine of the view angle (finite-difference normal) and
    the nominal pixel size at that depth."""
    p = pos[..., :3].astype(np.float64)
    covered = alpha > 0.999
    inside = covered.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inside &= _shift(covered, dy, dx, False)
    steps = [np.linalg.norm(_shift(p, dy, dx, np.nan) - p, axis=-1)
             for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0))]
    footprint = np.nanmax(np.stack(steps), axis=0)
    du = _shift(p, 0, -1, np.nan) - _shift(p, 0, 1, np.nan)
    dv = _shift(p, -1, 0, np.nan) - _shift(p, 1, 0, np.nan)
    n = np.cross(du, dv)
    view = p - np.asarray(cam_location)
    depth = np.linalg.norm(view, axis=-1)
    cos_view = np.abs(np.sum(n * view, axis=-1)) / (np.linalg.norm(n, axis=-1) * depth + 1e-30)
    pixel = depth * 2.0 * math.tan(fov / 2.0) / width     # ~ at the image centre
    return inside, footprint, np.nan_to_num(cos_view), pixel


def measure(arrays, meta):
    """Per exhibit and material: pixels compared, excluded as minified, EEVEE's fraction of
    unit normals, and the angle between the engines (mean, p99, max) over the compared
    pixels; also over every interior pixel (minified and grazing included)."""
    results = {}
    for name, ex in meta["exhibits"].items():
        cyc, eev, pos = (arrays[f"{name}/{k}"] for k in ("cycles", "eevee", "position"))
        width = ex["size"][0]
        inside, footprint, cos_view, pixel = pixel_geometry(
            pos, pos[..., 3], ex["camera_location"], ex["fov"], width)
        inside &= _interior_alpha(cyc) & _interior_alpha(eev)
        # Occlusion edges: a neighbour much farther than a grazing surface would put it.
        smooth = footprint <= 4.0 * pixel
        front = cos_view >= math.cos(math.radians(MAX_VIEW_ANGLE))
        magnified = footprint * TEXELS_PER_UNIT[name] <= 1.0
        nc = cyc[..., :3].astype(np.float64) * 2 - 1
        ne = eev[..., :3].astype(np.float64) * 2 - 1
        # Each pixel belongs to the nearest object centre in x and z (exhibits in rows, like
        # the decal shapes, share an x).
        xz = pos[..., [0, 2]]
        centres = np.array([[o["x"], o.get("z", 1.1)] for o in ex["objects"]])
        dist = np.linalg.norm(xz[..., None, :] - centres, axis=-1)
        nearest = np.argmin(dist, axis=-1)
        nearest[np.min(dist, axis=-1) > 1.4] = -1                               # not ours
        for mat in dict.fromkeys(o["material"] for o in ex["objects"]):
            ids = [i for i, o in enumerate(ex["objects"]) if o["material"] == mat]
            mine = inside & np.isin(nearest, ids)
            usable = mine & smooth & front
            compared = usable & magnified
            ang = _angle_deg(nc[compared], ne[compared]) if compared.any() else np.array([180.])
            ang_all = _angle_deg(nc[mine], ne[mine]) if mine.any() else np.array([180.0])
            length_e = np.linalg.norm(ne[mine], axis=-1)
            label = mat.split(": ", 1)[-1]
            results[(name, label)] = {
                "material": mat, "family": family(name, label),
                "pixels": int(compared.sum()), "interior": int(mine.sum()),
                "minified": int((usable & ~magnified).sum()),
                "minified_fraction": float((usable & ~magnified).sum() / max(usable.sum(), 1)),
                "eevee_unit_fraction": float(np.mean(np.abs(length_e - 1.0) < 0.01))
                if mine.any() else 0.0,
                "mean_deg": float(ang.mean()), "p99_deg": float(np.percentile(ang, 99)),
                "max_deg": float(ang.max()), "p50_deg": float(np.median(ang)),
                "over_1deg": float(np.mean(ang > 1.0)),
                "all_mean_deg": float(ang_all.mean()),
                "all_p99_deg": float(np.percentile(ang_all, 99)),
                "all_max_deg": float(ang_all.max())}
    return results


def _interior_alpha(rgba):
    covered = rgba[..., 3] > 0.999
    out = covered.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            out &= _shift(covered, dy, dx, False)
    return out


def _tolerance_text(tol):
    return " ".join(f"{k}<={v:g}" for k, v in tol.items())


def within(r, tol):
    """Which bounds of `tol` the result `r` exceeds (empty: within)."""
    keys = {"mean": "mean_deg", "p99": "p99_deg", "max": "max_deg", "p50": "p50_deg",
            "over_1deg": "over_1deg"}
    return [k for k, bound in tol.items() if not r[keys[k]] <= bound]


def _table(results):
    lines = [f"{'exhibit':12s} {'material':30s} {'family':17s} {'pixels':>7s} {'minif':>5s} "
             f"{'unit':>5s} {'mean':>6s} {'p50':>6s} {'p99':>6s} {'max':>6s} {'>1deg':>6s}  "
             f"tolerance | all interior: mean p99 max"]
    for (name, label), r in results.items():
        lines.append(
            f"{name:12s} {label[:30]:30s} {r['family']:17s} {r['pixels']:7d} "
            f"{r['minified_fraction']:5.3f} {r['eevee_unit_fraction']:5.3f} "
            f"{r['mean_deg']:6.3f} {r['p50_deg']:6.3f} {r['p99_deg']:6.3f} {r['max_deg']:6.2f} "
            f"{r['over_1deg']:6.4f}  {_tolerance_text(TOLERANCES[r['family']])} | "
            f"{r['all_mean_deg']:.3f} {r['all_p99_deg']:.3f} {r['all_max_deg']:.2f}")
    return "\n".join(lines)


# The test -----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    pytest.importorskip("bpy")
    from surfgrad_addon.addon import groups as G
    if G.unavailable_reason("SG Displace"):        # 4.2: the demo is refused (docs/versions.md)
        pytest.skip(f"the demo needs SG Displace: {G.unavailable_reason('SG Displace')}")
    out_dir = tmp_path_factory.mktemp("eevee_demo")
    wall, errors = run_eevee_child(__file__, out_dir, "demo render")
    meta = json.loads((out_dir / "renders.json").read_text())
    meta["wall_seconds"] = wall
    data = np.load(out_dir / "renders.npz")
    arrays = {k: data[k] for k in data.files}
    return {"arrays": arrays, "meta": meta, "shader_errors": errors, "out_dir": out_dir,
            "results": measure(arrays, meta)}


def test_every_exhibit_material_emits_its_normal(renders):
    """Every exhibit camera was rendered, every exhibit material was converted and is seen by
    a camera, EEVEE compiled them without errors, and they render unit normals in EEVEE on
    enough magnified, front-facing pixels."""
    meta, results = renders["meta"], renders["results"]
    assert sorted(meta["exhibits"]) == sorted(meta["cameras"]) and len(meta["cameras"]) >= 7
    # Every converted material is on an object some exhibit camera sees.
    seen = {r["material"] for r in results.values()}
    assert sorted(meta["made"]) == sorted(seen), (sorted(meta["made"]), sorted(seen))
    assert not renders["shader_errors"], "\n".join(renders["shader_errors"][:20])
    table = _table(results)
    thin = {k: r["pixels"] for k, r in results.items() if r["pixels"] < 2000}
    assert not thin, f"too few compared pixels: {thin}\n{table}"
    bad = {k: r["eevee_unit_fraction"] for k, r in results.items()
           if r["eevee_unit_fraction"] < 0.99}
    assert not bad, f"EEVEE did not render unit normals: {bad}\n{table}"


def test_demo_eevee_matches_cycles(renders):
    meta, results = renders["meta"], renders["results"]
    table = _table(results)
    print(f"\nDemo exhibits, EEVEE against Cycles ({meta['renderer']}; seconds "
          f"{json.dumps({k: round(v, 1) for k, v in meta['seconds'].items()})}, wall "
          f"{meta['wall_seconds']:.1f}):\n{table}")
    (renders["out_dir"] / "compare.json").write_text(json.dumps(
        {f"{a} | {b}": r for (a, b), r in results.items()}, indent=1))
    over = {f"{name} | {label}": within(r, TOLERANCES[r["family"]])
            for (name, label), r in results.items()}
    over = {k: v for k, v in over.items() if v}
    assert not over, f"EEVEE differs from Cycles beyond the tolerance in {over}:\n{table}"


if __name__ == "__main__":
    _child(sys.argv[1], sys.argv[2].split(",") if len(sys.argv) > 2 else None)
