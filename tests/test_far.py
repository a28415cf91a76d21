"""Far from the origin (issue 12): the coordinate sources the groups rely on, pinned by Cycles
bakes 10 km out; the groups on world positions within the bake-compare bar there; the limit of
the methods built on the Bump node, with its cause; the bench-far command.

Why (Cycles' kernel, geom/triangle_intersect.h and svm/tex_coord.h): a bake's shading point is
P = a + u (b - a) + v (c - a) from the triangle's vertices; for a mesh used by one object Cycles
stores those vertices in world space (SD_OBJECT_TRANSFORM_APPLIED), float32. At 10 km the
float32 grid is 2^-10 m, so P and everything made from it (Geometry Position, Texture
Coordinate Object = the inverse transform of P, the Bump node's dP/dx and Ng) carries ~1e-3 m of
rounding. An interpolated attribute (UV, 'position') is interpolated from small numbers and stays
exact, Object Info Location is the float32 matrix translation itself, and Vector Transform
Object to World of a direction uses the 3 x 3 part only.
"""

from contextlib import contextmanager

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.child import run_python  # noqa: E402
from surfgrad_addon import reference as R  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.harness import bake as B, compare as C, scenes  # noqa: E402
from surfgrad_addon.harness.bench.far import DIRECTION  # noqa: E402
from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object  # noqa: E402

pytestmark = pytest.mark.tier("bake")


FAR = 10000.0
RES = 48


@pytest.fixture(scope="module")
def objects():
    return scenes.new_scene(("Sphere", "Transformed"))


@contextmanager
def moved(obj, distance):
    home = obj.matrix_world.copy()
    obj.location = tuple(np.array(home.translation) + distance * DIRECTION)
    bpy.context.view_layer.update()
    try:
        yield obj
    finally:
        obj.matrix_world = home
        bpy.context.view_layer.update()


def _bake(obj, build, res=RES):
    """Baked vectors on the interior texels, and the reference's texel data."""
    td = R.rasterize(mesh_arrays_from_object(obj), "UVMap", res, res, facts=B.running_line())
    px, cov, _ = B.bake_vector(obj, build, res, res, uv_map="UVMap")
    keep = cov[td.pixel[:, 1], td.pixel[:, 0]] & td.interior()
    return px[td.pixel[keep, 1], td.pixel[keep, 0]].astype(np.float64), td, keep


def _attribute_position(nodes):
    a = nodes.new("ShaderNodeAttribute")
    a.attribute_type, a.attribute_name = "GEOMETRY", G.common.POSITION_ATTRIBUTE
    return a.outputs["Vector"]


def test_cycles_coordinate_sources_far_from_the_origin(objects):
    obj = objects["Transformed"]
    with moved(obj, FAR):
        m = np.array(obj.matrix_world, dtype=np.float64)
        world, td, k = _bake(obj, lambda n, l: n.new("ShaderNodeNewGeometry").outputs["Position"])
        err_world = np.abs(world - td.position[k]).max()
        tc, _, _ = _bake(obj, lambda n, l: n.new("ShaderNodeTexCoord").outputs["Object"])
        err_object = np.abs(tc - td.position_object[k]).max()
        attr, _, _ = _bake(obj, lambda n, l: _attribute_position(n))
        err_attr = np.abs(attr - td.position_object[k]).max()
        loc, _, _ = _bake(obj, lambda n, l: n.new("ShaderNodeObjectInfo").outputs["Location"])

        def turned(nodes, links):
            vt = nodes.new("ShaderNodeVectorTransform")
            vt.vector_type, vt.convert_from, vt.convert_to = "VECTOR", "OBJECT", "WORLD"
            links.new(_attribute_position(nodes), vt.inputs[0])
            return vt.outputs[0]
        offset, _, _ = _bake(obj, turned)
    # float32 world positions: off by more than a 1e-4 m at 10 km, less than the 2^-10 grid
    # step times a few (the rounding of vertices and of the interpolation).
    assert 2e-4 < err_world < 4e-3, err_world
    assert 2e-4 < err_object < 8e-3, err_object
    # The 'position' attribute: the object-space position, as exact as at the origin.
    assert err_attr < 1e-5, err_attr
    # Object Info Location: the object's float32 translation, bit for bit.
    np.testing.assert_array_equal(loc, np.broadcast_to(np.float32(m[:3, 3]), loc.shape))
    # Vector Transform Object -> World, Vector: the 3 x 3 part only (no 10 km in it).
    np.testing.assert_allclose(offset, td.position_object[k] @ m[:3, :3].T, atol=1e-5)


@pytest.mark.parametrize("scale", [1.0, 2.7, 0.013])
def test_triplanar_coordinates_exact_modulo_a_repeat_far_away(objects, scale):
    """SG Triplanar Coordinates' unlinked Position, 10 km out: UV Z is frac((x, y) * Scale) of
    the float64 world position to 2e-5 of a repeat, where float32 world positions times Scale
    are off by more than 1e-4 (the numpy model of what the old node chain computed)."""
    obj = objects["Transformed"]

    def build(nodes, links):
        node = nodes.new("ShaderNodeGroup")
        node.node_tree = G.triplanar_coordinates_group()
        node.inputs["Scale"].default_value = scale
        return node.outputs["UV Z"]
    with moved(obj, FAR):
        got, td, k = _bake(obj, build)
    # The socket holds float32(Scale): 2.7 - float32(2.7) is 5e-8, 4e-4 of a repeat at 8 km.
    want = td.position[k][:, :2] * float(np.float32(scale))
    diff = np.abs((got[:, :2] - want + 0.5) % 1.0 - 0.5)
    assert diff.max() < 2e-5, diff.max()
    naive = np.float32(np.float32(td.position[k][:, :2]) * np.float32(scale))
    naive_diff = np.abs((naive - want + 0.5) % 1.0 - 0.5).max()
    assert naive_diff > 5 * max(diff.max(), 2e-6) or scale < 0.1, naive_diff


def test_triplanar_coordinates_near_the_origin_and_linked_unchanged(objects):
    """Near the origin the unlinked Position is the world position itself (not wrapped), and a
    linked Position is used as given."""
    obj = objects["Sphere"]

    def unlinked(nodes, links):
        node = nodes.new("ShaderNodeGroup")
        node.node_tree = G.triplanar_coordinates_group()
        node.inputs["Scale"].default_value = 3.0
        return node.outputs["UV Y"]

    def linked(nodes, links):
        node = nodes.new("ShaderNodeGroup")
        node.node_tree = G.triplanar_coordinates_group()
        links.new(nodes.new("ShaderNodeTexCoord").outputs["UV"], node.inputs["Position"])
        node.inputs["Scale"].default_value = 2.0
        return node.outputs["UV Z"]
    with moved(obj, 5.0):
        got, td, k = _bake(obj, unlinked)
        np.testing.assert_allclose(got[:, :2], td.position[k][:, [0, 2]] * 3.0, atol=1e-5)
        assert got[:, 0].max() > 1.5          # not wrapped to [0, 1)
        got, td, k = _bake(obj, linked)
        np.testing.assert_allclose(got[:, :2], td.uv("UVMap")[k] * 2.0, atol=1e-5)


# Methods on world or object positions, and controls on UV maps and tangents.
FAR_METHODS = [("triplanar", "hq"), ("triplanar-height", "hq"), ("decal", "box"),
               ("decal", "cone"), ("decal", "wedge"), ("decal", "capsule"),
               ("triplanar-sampler", "hq"), ("triplanar-height-sampler", "hq"),
               ("volume-noise", "hq"), ("displace-bump", "hq"), ("post-resolve", "hq"),
               ("normal-map", "hq"), ("object-normal", "hq")]


@pytest.mark.parametrize("method,variant", FAR_METHODS)
@pytest.mark.parametrize("obj_name", ["Sphere", "Transformed"])
def test_methods_within_the_bar_10_km_out(objects, obj_name, method, variant):
    if C.unavailable_reason(method):
        pytest.skip(C.unavailable_reason(method))
    with moved(objects[obj_name], FAR) as obj:
        report, _ = C.compare_object(obj, method, RES, variant=variant, log=lambda *_: None)
    assert report["p99_deg"] <= 0.1, report
    assert report["max_deg"] <= 0.5, report
    assert report["tilt_mean_deg"] > 1.0           # the method really bends the normals
    assert abs(report["bake_tilt_mean_deg"] - report["tilt_mean_deg"]) < 0.01


# The Bump node's differentials come from the triangle's world-space float32 vertices: measured
# at 64^2 on the two objects, 10 km out (README, "Far from the origin"). The bound is 1.5 x the
# worst measured figure; parallax's max is a few texels where the rounding moves a ray march
# across a layer (9.1 deg on 5.2, 18.4 on 5.0): its bound is wider.
BUMP_LIMITS = {("height-map", "hq"): (0.25, 0.35), ("height-map", "forward"): (0.25, 0.35),
               ("procedural-basis", "hq"): (0.3, 0.7), ("parallax", "hq"): (1.5, 30.0)}


@pytest.mark.parametrize("method,variant", sorted(BUMP_LIMITS))
def test_bump_node_methods_limit_far_away_is_cycles_world_space_vertices(objects, method,
                                                                           variant,
                                                                           monkeypatch):
    """Single-user mesh 10 km out (the precise route switched off): the error stays under the
    measured bound. Its cause is not the group: with a second user of the mesh (Cycles then
    keeps it in object space, SD_OBJECT_TRANSFORM_APPLIED unset), which compare now adds
    itself (addon/precise_bake.py), the very same bake is back within the bar."""
    from surfgrad_addon.addon import precise_bake
    obj = objects["Transformed"]
    p99_bound, max_bound = BUMP_LIMITS[(method, variant)]
    with moved(obj, FAR):
        shared, _ = C.compare_object(obj, method, 64, variant=variant, log=lambda *_: None)
        monkeypatch.setattr(precise_bake, "FAR_METRES", float("inf"))
        single, _ = C.compare_object(obj, method, 64, variant=variant, log=lambda *_: None)
    assert single["p99_deg"] <= p99_bound and single["max_deg"] <= max_bound, single
    assert single["p99_deg"] > 0.05, single         # the limit is real: not within 2x the bar
    assert shared["p99_deg"] <= 0.1 and shared["max_deg"] <= 0.5, shared


@pytest.mark.tier("child")
def test_bench_far_command(tmp_path):
    out = tmp_path / "far"
    args = ["-m", "surfgrad_addon", "bench-far", "--out", str(out), "--resolution", "16",
            "--objects", "Sphere", "--methods", "volume-noise", "--distances", "10000"]
    done = run_python(args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    import json
    data = json.loads((out / "far.json").read_text())
    assert [r["distance_m"] for r in data["rows"]] == [0.0, 10000.0]
    far = data["rows"][1]
    assert far["builtin"] == "Noise Texture + Bump (Object)"
    assert far["ours"]["max_deg"] <= 0.5 and far["builtin_stats"]["max_deg"] > 0.0
    assert "## volume-noise" in (out / "far.md").read_text()
    again = run_python(args, cwd=tmp_path)
    assert again.returncode == 2 and "pass --overwrite" in again.stderr
    bad = run_python(args[:-1] + ["-5"], cwd=tmp_path)
    assert bad.returncode == 2 and "distances must be finite" in bad.stderr
    assert "Traceback" not in bad.stderr + again.stderr


def test_projector_coordinates_routes(objects):
    """SG Projector Coordinates: near the origin its linked Texture Coordinate passes through
    bit for bit; unlinked with Precise Far From Origin on, the precise route gives the same
    coordinates (to 1e-5); 10 km out (where the bake switches Precise Far From Origin on, as the
    operators do) the precise route holds where the Texture Coordinate node is off by more than
    1e-4."""
    from surfgrad_addon.harness.graph import Graph
    from surfgrad_addon.harness.method_graphs.projection import projector_coordinates
    from surfgrad_addon.harness.method_scene import decal_projector
    obj = objects["Transformed"]

    def chain(proj, link_tc, only_tc=False):
        def build(nodes, links):
            g = Graph(nodes, links)
            if only_tc:
                return g.node("ShaderNodeTexCoord", object=proj).outputs["Object"]
            q = projector_coordinates(g, proj)
            if not link_tc:         # the precise route, which Precise Far From Origin enables
                links.remove(q.node.inputs["Decal Coordinates"].links[0])
                q.node.inputs["Precise Far From Origin"].default_value = True
            return q
        return build
    for distance in (0.0, FAR):
        with moved(obj, distance):
            proj = decal_projector(obj)
            try:
                m = np.linalg.inv(np.array(proj.matrix_world, dtype=np.float64))
                linked, td, k = _bake(obj, chain(proj, True))
                unlinked, _, _ = _bake(obj, chain(proj, False))
                texco, _, _ = _bake(obj, chain(proj, True, only_tc=True))
            finally:
                bpy.data.objects.remove(proj)
        truth = td.position[k] @ m[:3, :3].T + m[:3, 3]
        np.testing.assert_allclose(unlinked, truth, atol=1e-5)
        np.testing.assert_allclose(linked, truth, atol=1e-5)
        if distance == 0.0:
            np.testing.assert_array_equal(linked, texco)
        else:
            assert np.abs(texco - truth).max() > 1e-4
