"""surfgrad on one Blender line: run by tools/versions.sh inside .venv-bpy42 / .venv-bpy45 (it
works in any bpy environment, 5.0 included). Not a pytest module: the main suite never runs it.

    PYTHONPATH=. .venv-bpy42/bin/python tests/versions/check.py [--resolution 32] [--json OUT]

1. Facts the code depends on, as this Blender has them (pinned in docs/versions.md).
2. The add-on registers and unregisters; every menu group builds (groups.build_all(), twice:
   idempotent), with a description and valid links; SG Displace builds and matches the
   reference (positions and normals, tests/test_displace.py's bar) where Set Mesh Normal
   exists, and elsewhere is refused with a FeatureUnavailable naming the node and version.
3. Every method of compare.METHODS (each height-map variant separately) baked by Cycles on the
   four procedural test objects and compared with the reference, with tests/test_bake_compare.py's
   assertions: p99 <= 0.1 and max <= 0.5 degrees over interior texels, enough texels, finite
   unit normals, the method really bends the normals and the bake bends them as much. Where the
   Bump node has no Filter Width input (4.2) its forward differences step one bake differential
   (half a texel) instead of SG Height Map Forward's two: that variant is held to the bar against
   the reference with the 4.2 step, and its distance from the 5.0 result is pinned.
4. SG Normal Map against Blender's Normal Map node (0.05 degrees) and a bake that leaves the
   scene as it was (with this line's EEVEE engine id).

Prints a table; exit status 1 if anything fails.
"""

import argparse
import contextlib
import ctypes
import json
import os
import sys
import time
import traceback

import numpy as np

import bpy

from surfgrad_addon import reference as R
from surfgrad_addon.blender import bake, compare, groups as G, test_scenes
from surfgrad_addon.reference import methods as M

P99_BAR, MAX_BAR = 0.1, 0.5          # tests/test_bake_compare.py
NORMAL_MAP_NODE_BAR = 0.05           # SG Normal Map against Blender's Normal Map node
# Pinned: on 4.2 SG Height Map Forward (half-texel steps) departs from the 5.0 result (one-texel
# steps) by this much at 32^2 on the test objects: measured max 0.83 .. 4.9 deg.
FORWARD_DEPARTURE_MAX = (0.5, 10.0)

_libc = ctypes.CDLL(None)


@contextlib.contextmanager
def quiet():
    """Silence file descriptor 1 (Cycles prints progress lines there before 5.0)."""
    sys.stdout.flush()
    _libc.fflush(None)
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    try:
        yield
    finally:
        sys.stdout.flush()
        _libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def say(*args):
    print(*args, flush=True)


# 1. Facts --------------------------------------------------------------------------------------

def facts():
    tree = bpy.data.node_groups.new(".versions probe", "ShaderNodeTree")
    bump = tree.nodes.new("ShaderNodeBump")
    mesh = bpy.data.meshes.new(".versions probe")
    mat = bpy.data.materials.new(".versions probe")
    engines = [e.identifier for e in
               bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items]
    out = {
        "blender": bpy.app.version_string,
        "version": list(bpy.app.version),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "bump_inputs": [s.name for s in bump.inputs],
        "bump_filter_width": "Filter Width" in bump.inputs,
        "set_mesh_normal": hasattr(bpy.types, "GeometryNodeSetMeshNormal"),
        "mesh_corner_normals": hasattr(mesh, "corner_normals"),
        "new_material_has_node_tree": mat.node_tree is not None,
        "eevee_engine_id": next((e for e in engines if e.startswith("BLENDER_EEVEE")), None),
        "capture_items": hasattr(bpy.types.GeometryNodeCaptureAttribute, "bl_rna")
        and "capture_items" in bpy.types.GeometryNodeCaptureAttribute.bl_rna.properties,
    }
    bpy.data.node_groups.remove(tree)
    bpy.data.meshes.remove(mesh)
    bpy.data.materials.remove(mat)
    return out


# 2. Groups and SG Displace ----------------------------------------------------------------------

class Checks:
    def __init__(self):
        self.rows = []          # (name, ok, detail)

    def run(self, name, fn):
        try:
            with quiet():
                detail = fn()
            ok = True
        except Exception as ex:      # a failed check is reported, the rest still run
            ok, detail = False, f"{type(ex).__name__}: {ex}"
            traceback.print_exc()
        self.rows.append((name, ok, detail or ""))
        say(f"  {'ok  ' if ok else 'FAIL'} {name}: {detail}")
        return ok


def check_register():
    import surfgrad_addon
    surfgrad_addon.register()
    try:
        assert hasattr(bpy.types, "NODE_MT_surfgrad_add"), "the Add menu class is not registered"
    finally:
        surfgrad_addon.unregister()
    return "register() and unregister() run"


def check_build_all():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    trees = G.build_all()
    assert len(trees) == len(G.MENU_GROUPS), (len(trees), len(G.MENU_GROUPS))
    for name, tree in trees.items():
        assert tree.description, f"{name} has no description"
        outputs = [it for it in tree.interface.items_tree
                   if it.item_type == "SOCKET" and it.in_out == "OUTPUT"]
        assert outputs, f"{name} has no output"
        bad = [ln for ln in tree.links if not ln.is_valid]
        assert not bad, f"{name} has {len(bad)} invalid links"
    counts = {n: len(t.nodes) for n, t in trees.items()}
    again = G.build_all()
    assert all(again[n] == trees[n] and len(again[n].nodes) == counts[n] for n in trees), \
        "building twice changed a group"
    hidden = [t.name for t in bpy.data.node_groups if t.name.startswith(".")]
    return (f"{len(trees)} menu groups and {len(hidden)} hidden helpers, "
            f"{sum(counts.values())} nodes; idempotent")


DISPLACE_CASES = [("Sphere", {"Amount": 0.1, "Scale": 2.0, "Octaves": 1}),
                  ("Transformed", {"Amount": 0.25, "Scale": 3.0, "Octaves": 3}),
                  ("Torus", {"Amount": -0.05, "Scale": 5.0, "Octaves": 4})]


def _vertex_data(mesh):
    p = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", p)
    n = np.empty(len(mesh.vertices) * 3)
    mesh.vertex_normals.foreach_get("vector", n)
    return p.reshape(-1, 3), n.reshape(-1, 3)


def check_displace():
    """SG Displace against the reference (tests/test_displace.py), or its refusal."""
    reason = G.unavailable_reason("SG Displace")
    if reason is not None:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        try:
            G.displace_group()
        except G.FeatureUnavailable as ex:
            assert "Set Mesh Normal" in str(ex) and "4.5" in str(ex), str(ex)
        else:
            raise AssertionError("SG Displace was built although Set Mesh Normal is missing")
        assert "SG Displace" not in bpy.data.node_groups, "a half-built SG Displace was left"
        from surfgrad_addon.blender import ui
        gn = bpy.data.node_groups.new("Modifier", "GeometryNodeTree")
        try:
            ui.add_group_node(gn, "SG Displace")
        except ValueError as ex:
            assert str(ex) == reason, str(ex)
        else:
            raise AssertionError("the Add menu added SG Displace without Set Mesh Normal")
        obj = test_scenes.new_scene(["Plane"])["Plane"]
        try:
            compare.compare_object(obj, "displace-bump", 16, log=lambda *_: None)
        except compare.CompareError as ex:
            assert reason in str(ex)
        else:
            raise AssertionError("displace-bump ran without Set Mesh Normal")
        assert "displace-bump" not in [m for m, _ in compare.compare_cases()]
        return f"refused as designed: {reason}"
    worst_pos, worst_p99, worst_max = 0.0, 0.0, 0.0
    for name, settings in DISPLACE_CASES:
        obj = test_scenes.new_scene([name])[name]
        p0, n0 = _vertex_data(obj.data)
        compare.add_displace_modifier(obj, settings)
        ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        mesh = ev.to_mesh()
        try:
            p, _ = _vertex_data(mesh)
            cn = np.empty(len(mesh.loops) * 3)
            mesh.corner_normals.foreach_get("vector", cn)
            vertex = np.empty(len(mesh.loops), dtype=np.int64)
            mesh.loops.foreach_get("vertex_index", vertex)
            rest = np.empty(len(mesh.vertices) * 3)
            mesh.attributes[G.REST_ATTRIBUTE].data.foreach_get("vector", rest)
        finally:
            ev.to_mesh_clear()
        h, g = R.fractal_sum(p0 * settings["Scale"], octaves=settings["Octaves"])
        p_ref = R.displace_along_normal(p0, n0, h, settings["Amount"])
        n_ref = R.displaced_normal(n0, settings["Scale"] * g, settings["Amount"])
        rel = np.linalg.norm(p - p_ref, axis=1) / np.linalg.norm(p_ref, axis=1)
        ang = compare.angle_deg(cn.reshape(-1, 3), n_ref[vertex])
        assert rel.max() < 1e-5, (name, rel.max())
        assert np.percentile(ang, 99) <= P99_BAR and ang.max() < MAX_BAR, (name, ang.max())
        assert compare.angle_deg(n_ref, n0).mean() > 2.0, "the normals did not change"
        np.testing.assert_allclose(rest.reshape(-1, 3), p0, atol=1e-6)
        worst_pos = max(worst_pos, float(rel.max()))
        worst_p99 = max(worst_p99, float(np.percentile(ang, 99)))
        worst_max = max(worst_max, float(ang.max()))
    return (f"positions to {worst_pos:.1e} relative, analytic normals p99 {worst_p99:.5f} "
            f"max {worst_max:.5f} deg on {len(DISPLACE_CASES)} objects")


# 3. Bakes against the reference ---------------------------------------------------------------

@contextlib.contextmanager
def forward_step(width):
    """The reference's SG Height Map Forward step, in bake differentials."""
    saved = M.FORWARD_FILTER_WIDTH
    M.FORWARD_FILTER_WIDTH = width
    try:
        yield
    finally:
        M.FORWARD_FILTER_WIDTH = saved


def bar_failures(report, obj_name, resolution):
    """tests/test_bake_compare.py's assertions, as a list of what failed."""
    fails = []
    need = 0.6 * resolution ** 2 * (0.9 if obj_name != "Transformed" else 0.8)
    if not report["texels_compared"] > need:
        fails.append(f"{report['texels_compared']} texels compared")
    # 0.15 at the main suite's 48^2; island borders are a larger share of a coarser bake
    # (every line, 5.0 included, excludes 16% of the Transformed sphere's texels at 32^2).
    if not report["excluded_fraction"] < 0.15 * max(1.0, 48 / resolution):
        fails.append(f"excluded {report['excluded_fraction']:.2f}")
    if not report["p99_deg"] <= P99_BAR:
        fails.append(f"p99 {report['p99_deg']:.4f}")
    if not report["max_deg"] <= MAX_BAR:
        fails.append(f"max {report['max_deg']:.4f}")
    if report["finite_unit_fraction"] != 1.0:
        fails.append(f"finite unit {report['finite_unit_fraction']:.4f}")
    if not report["tilt_mean_deg"] > 1.0:
        fails.append(f"tilt {report['tilt_mean_deg']:.3f}")
    if not abs(report["bake_tilt_mean_deg"] - report["tilt_mean_deg"]) < 0.01:
        fails.append(f"bake tilt {report['bake_tilt_mean_deg']:.3f} vs "
                     f"{report['tilt_mean_deg']:.3f}")
    return fails


def all_cases():
    return [(m, "hq") for m in sorted(compare.METHODS) if m != "height-map"] + \
        [("height-map", v) for v in ("forward", "one-texel", "hq")]


KEYS = ("object", "texels_compared", "excluded_fraction", "mean_deg", "p99_deg", "max_deg",
        "tilt_mean_deg", "bake_tilt_mean_deg", "finite_unit_fraction", "bake_seconds")


def compare_all(resolution, bump_filter_width):
    objects = test_scenes.new_scene()
    rows = []
    for method, variant in all_cases():
        label = method + (f" ({variant})" if method == "height-map" else "")
        row = {"case": label, "method": method, "variant": variant, "objects": [],
               "status": "pass", "note": ""}
        reason = compare.unavailable_reason(method)
        if reason is not None:
            row.update(status="n/a", note=reason)       # its refusal: check_displace
            rows.append(row)
            say(f"  n/a  {label:22s} {reason}")
            continue
        own_step = (method == "height-map" and variant == "forward" and not bump_filter_width)
        for name, obj in objects.items():
            try:
                with quiet(), forward_step(1.0 if own_step else M.FORWARD_FILTER_WIDTH):
                    report, _ = compare.compare_object(obj, method, resolution,
                                                       variant=variant, log=lambda *_: None)
                fails = bar_failures(report, name, resolution)
                entry = {k: report[k] for k in KEYS}
                if own_step:
                    # The same group against the 5.0 semantics (one-texel steps): pinned.
                    with quiet():
                        r50, _ = compare.compare_object(obj, method, resolution,
                                                        variant=variant, log=lambda *_: None)
                    entry["vs_5_0"] = {k: r50[k] for k in ("mean_deg", "p99_deg", "max_deg")}
                    lo, hi = FORWARD_DEPARTURE_MAX
                    if not lo <= r50["max_deg"] <= hi:
                        fails.append(f"departure from 5.0 max {r50['max_deg']:.3f} outside "
                                     f"the pinned {lo}..{hi}")
            except Exception as ex:
                traceback.print_exc()
                entry, fails = {"object": name}, [f"{type(ex).__name__}: {ex}"]
            entry["fails"] = fails
            row["objects"].append(entry)
            if fails:
                row["status"] = "FAIL"
        done = [o for o in row["objects"] if "p99_deg" in o]
        if done:
            row["p99_deg"] = max(o["p99_deg"] for o in done)
            row["max_deg"] = max(o["max_deg"] for o in done)
            row["tilt_mean_deg"] = float(np.mean([o["tilt_mean_deg"] for o in done]))
        if own_step and done and all("vs_5_0" in o for o in done):
            v = [o["vs_5_0"] for o in done]
            row["note"] = ("4.2 step (no Filter Width: half a texel); against the 5.0 "
                           f"one-texel step mean {min(x['mean_deg'] for x in v):.2f}.."
                           f"{max(x['mean_deg'] for x in v):.2f}, max "
                           f"{min(x['max_deg'] for x in v):.2f}.."
                           f"{max(x['max_deg'] for x in v):.2f} deg")
        fails = [f"{o['object']}: {', '.join(o['fails'])}" for o in row["objects"] if o["fails"]]
        if fails:
            row["note"] = "; ".join(fails)
        passed = sum(not o["fails"] for o in row["objects"])
        say(f"  {row['status']:4s} {label:22s} {passed}/{len(row['objects'])} objects, p99 "
            f"{row.get('p99_deg', float('nan')):.4f} max {row.get('max_deg', float('nan')):.4f}"
            f" deg {row['note']}")
        rows.append(row)
    return rows


# 4. Extras -------------------------------------------------------------------------------------

def check_normal_map_node(resolution):
    test_scenes.new_scene()
    worst = 0.0
    for obj_name in test_scenes.SCENE_OBJECTS:
        obj = bpy.data.objects[obj_name]
        inp = compare.prepare_inputs(obj)
        try:
            def sg(nodes, links):
                return compare._resolve(nodes, links,
                                        compare._normal_map_graph(inp, nodes, links))

            def blender(nodes, links):
                color = compare._image_node(nodes, links, inp.bpy_image("normal"),
                                            compare._uv(nodes, inp.uv_map))
                nm = nodes.new("ShaderNodeNormalMap")
                nm.uv_map = inp.uv_map
                links.new(color, nm.inputs["Color"])
                return nm.outputs["Normal"]
            a, cov_a, _ = bake.bake_vector(obj, sg, resolution, resolution, inp.uv_map)
            b, cov_b, _ = bake.bake_vector(obj, blender, resolution, resolution, inp.uv_map)
        finally:
            for _, img in inp.images.values():
                bpy.data.images.remove(img)
        both = cov_a & cov_b
        assert both.mean() > 0.8
        err = compare.angle_deg(a[both], b[both])
        worst = max(worst, float(err.max()))
        assert err.max() <= NORMAL_MAP_NODE_BAR, (obj_name, float(err.max()))
    return f"max {worst:.2e} deg (bar {NORMAL_MAP_NODE_BAR})"


def check_bake_restores(eevee):
    objects = test_scenes.new_scene(["Sphere"])
    obj = objects["Sphere"]
    sc = bpy.context.scene
    sc.cycles.samples = 37
    sc.render.engine = eevee
    sc.render.bake.margin = 5
    mat = bpy.data.materials.new("UserMat")
    obj.data.materials.append(mat)
    before = (len(bpy.data.materials), len(bpy.data.images), len(bpy.data.meshes))
    compare.compare_object(obj, "normal-map", 16, log=lambda *_: None)
    assert sc.cycles.samples == 37 and sc.render.engine == eevee, sc.render.engine
    assert sc.render.bake.margin == 5
    assert obj.material_slots[0].material == mat
    assert (len(bpy.data.materials), len(bpy.data.images), len(bpy.data.meshes)) == before
    return f"engine {eevee}, samples, margin, material slot and data-blocks restored"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--resolution", type=int, default=32)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    f = facts()
    say(f"== surfgrad on Blender {f['blender']} (bpy wheel, Python {f['python']}, "
        f"numpy {f['numpy']}) ==")
    say(f"  facts: Bump inputs {f['bump_inputs']}; Set Mesh Normal "
        f"{'yes' if f['set_mesh_normal'] else 'no'}; Mesh.corner_normals "
        f"{'yes' if f['mesh_corner_normals'] else 'no'}; new material has a node tree "
        f"{'yes' if f['new_material_has_node_tree'] else 'no (use_nodes)'}; EEVEE id "
        f"{f['eevee_engine_id']}")
    checks = Checks()
    say("groups:")
    checks.run("add-on register/unregister", check_register)
    checks.run("build_all", check_build_all)
    checks.run("SG Displace", check_displace)
    say(f"bakes against the reference at {args.resolution}^2 on "
        f"{', '.join(test_scenes.SCENE_OBJECTS)} (bar: p99 <= {P99_BAR}, max <= {MAX_BAR} deg):")
    rows = compare_all(args.resolution, f["bump_filter_width"])
    say("extras:")
    checks.run("SG Normal Map vs Normal Map node", lambda: check_normal_map_node(args.resolution))
    checks.run("bake leaves the scene as it was",
               lambda: check_bake_restores(f["eevee_engine_id"]))
    seconds = time.perf_counter() - t0

    ok = all(c[1] for c in checks.rows) and all(r["status"] != "FAIL" for r in rows)
    say("")
    say(f"| Blender {f['blender']} | objects | p99 deg | max deg | status | note |")
    say("|---|---|---|---|---|---|")
    for r in rows:
        passed = sum(not o["fails"] for o in r["objects"])
        p99 = f"{r['p99_deg']:.4f}" if "p99_deg" in r else "-"
        mx = f"{r['max_deg']:.4f}" if "max_deg" in r else "-"
        say(f"| {r['case']} | {passed}/{len(r['objects'])} | {p99} | {mx} | {r['status']} | "
            f"{r['note']} |")
    for name, passed, detail in checks.rows:
        say(f"| {name} | | | | {'pass' if passed else 'FAIL'} | {detail} |")
    n_pass = sum(r["status"] == "pass" for r in rows)
    n_na = sum(r["status"] == "n/a" for r in rows)
    say(f"\nBlender {f['blender']}: {n_pass}/{len(rows)} methods pass, {n_na} not available "
        f"(gated), {len(rows) - n_pass - n_na} fail; checks "
        f"{sum(c[1] for c in checks.rows)}/{len(checks.rows)}; {seconds:.0f} s -> "
        f"{'PASS' if ok else 'FAIL'}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"facts": f, "resolution": args.resolution, "seconds": seconds,
                       "ok": ok, "methods": rows,
                       "checks": [{"name": n, "ok": o, "detail": d} for n, o, d in checks.rows]},
                      fh, indent=2)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
