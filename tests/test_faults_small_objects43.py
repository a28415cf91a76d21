"""Red team 43b: very small objects (harness/scale_limits.py, SMALL_LIMITS).

The methods whose height derivative comes from the bake's texel steps (SG Height Map's
variants, height-blend, SG Noise's filtered footprint, the procedural basis, the overwriting
decal, parallax) lose precision in Cycles' float32 as the object shrinks, at any resolution.
Before: compare baked and called the group wrong with exit 0 and no word, e.g. SG Height Map
HQ on the unit sphere scaled to 1e-8 (2e-8 m across): mean 30 / p99 169 deg; One-Texel 31 /
171; Forward 1e-7: p99 90. The float64 reference is the side that holds: its normals at 1e-6
and 1e-8 are the same (the relief at a fixed world Bump Scale is then all slope), the bake's
are not. Now compare refuses before baking (exit 2), naming the object, its size and the
fix; normal maps, triplanar and volume noise, which agree down to 1e-8, are compared as before.
bake-normal-map through SG Height Map, SG Parallax or SG Tangent Normal warns below those sizes
and refuses below 2e-6 m across (addon/small_objects.py).

A NaN in a UV map a material node reads besides the baked one (a Normal Map node's tangents, a
UV Map node's lookup) baked wrong texels with exit 0; now refused as one in the baked map is
(addon/material_uv_maps.py).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import compare, scale_limits  # noqa: E402
from support.small_objects import bake_open_file, height_map_stack  # noqa: E402
from support.small_objects import scaled_test_object as _scaled  # noqa: E402
from support.compare_cli import compare_cli_refuses  # noqa: E402
from surfgrad_addon.harness.methods import METHODS  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16
P99, MAX = 0.1, 0.5


def _compare(obj, method, variant=None):
    return compare.compare_object(obj, method, RES, variant=variant, log=None)[0]


def test_a_tiny_object_is_refused_before_anything_is_made(tmp_path):
    obj = _scaled("Sphere", 1e-8)
    images = len(bpy.data.images)
    with pytest.raises(compare.CompareError) as err:
        _compare(obj, "height-map", "hq")
    assert str(err.value) == (
        "object 'Sphere' is 2e-08 m across: below 0.001 m, Cycles' float32 derivatives that "
        "height-map bakes from lose precision (the bake and the float64 reference then differ "
        "by degrees, not by the group), so it is not compared; scale it up by 100000 or "
        "more (or the whole scene, with Scene > Units > Unit Scale set to 1e-05 to keep its "
        "units) and compare again")        # round 44b: the limit with the relief scaled
    assert len(bpy.data.images) == images and tuple(obj.scale) == pytest.approx((1e-8,) * 3)
    assert compare_cli_refuses(tmp_path, "tiny.blend", "Sphere", "parallax")


@pytest.mark.parametrize("method", ["normal-map", "triplanar"])
def test_methods_that_hold_are_still_compared_on_a_tiny_object(method):
    report = _compare(_scaled("Sphere", 1e-8), method)
    assert report["texels_compared"] > 150
    assert report["p99_deg"] <= P99 and report["max_deg"] <= MAX, report


@pytest.mark.parametrize("name,scale,method,variant", [
    ("Sphere", 1e-8, "height-map", "hq"),               # measured p99 169
    ("Torus", 1e-3, "parallax", None),                  # measured p99 0.42 / max 4.0
])
def test_below_the_limit_the_bake_leaves_the_bar(monkeypatch, name, scale, method, variant):
    """Why the limit is needed: with the check off, a correct group is called wrong."""
    monkeypatch.setattr(scale_limits, "SMALL_LIMITS", {})
    report = _compare(_scaled(name, scale), method, variant)
    assert report["p99_deg"] > P99 or report["max_deg"] > MAX, report


@pytest.mark.parametrize("method", sorted(m for m in scale_limits.SMALL_LIMITS
                                           if not m.endswith("-sampler")))
def test_at_the_limit_every_refused_method_is_within_the_bar(method):
    """The limits hold on every line: the torus (the worse test object) just above each is
    compared and agrees. The Sampler groups (5.0+) share their plain group's limit and
    reference."""
    half = scale_limits.SMALL_LIMITS[method] * 1.01
    unit = scale_limits.world_extent(_scaled("Torus", 1.0))[0]
    obj = _scaled("Torus", half / unit)
    assert scale_limits.world_extent(obj)[0] == pytest.approx(half, rel=1e-3)
    report = _compare(obj, method)
    assert report["p99_deg"] <= P99 and report["max_deg"] <= MAX, report


def test_the_reference_holds_where_the_bake_does_not():
    """Which side is right below the limit: the float64 reference's normals on the sphere at
    1e-8 equal its own at 1e-6 (the relief at a fixed world Bump Scale is then all slope), to
    0.05 deg; the bake there is 169 deg p99 off (above). No bake needed."""
    from surfgrad_addon import reference as R
    from surfgrad_addon.reference import methods as M
    from surfgrad_addon.harness import bake as B
    from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object
    normals = []
    for scale in (1e-6, 1e-8):
        obj = _scaled("Sphere", scale)
        inp = compare.prepare_inputs(obj, variant="hq")
        try:
            td = R.rasterize(mesh_arrays_from_object(obj), inp.uv_map, RES, RES,
                             facts=B.running_line())
            normals.append(np.asarray(M.resolve(METHODS["height-map"].reference(inp, td))))
        finally:
            for _, img in inp.images.values():
                bpy.data.images.remove(img)
    cos = np.sum(normals[0] * normals[1], -1) / np.prod(
        [np.linalg.norm(n, axis=-1) for n in normals], axis=0)
    assert len(cos) > 150 and np.degrees(np.arccos(np.clip(cos, -1, 1))).max() < 0.05


def test_bake_normal_map_refuses_or_warns_on_a_tiny_object(tmp_path, capsys):
    """Before: bake-normal-map baked SG Height Map on a 2e-8 m sphere with exit 0 (compare of
    the same group there: p99 169 deg). Now refused below 2e-6 m across, exit 2, no file;
    warned about below compare's limit (0.02 m), baked."""
    texts = {}
    for scale, rc in ((1e-8, 2), (1e-4, 0)):
        height_map_stack(_scaled("Sphere", scale))
        code, texts[scale], written = bake_open_file(tmp_path, capsys, f"s{scale:g}")
        assert code == rc and written is (rc == 0)
    assert ("object 'Sphere' is 2e-08 m across: the height derivatives of SG Height Map "
            "Forward node 'Height' (material 'Tiny') come from the bake's texel steps, which "
            "Cycles' float32 holds only to degrees below 2e-06 m, so the map would be wrong; "
            "scale it up by 1000000 or more") in texts[1e-8]
    assert ("object 'Sphere' is 0.0002 m across: the height derivatives of SG Height Map "
            "Forward node 'Height' (material 'Tiny') come from the bake's texel steps, which "
            "Cycles' float32 holds to within 0.1 degree only above 0.02 m") in texts[1e-4]


def test_a_nan_in_a_second_uv_map_the_material_reads_is_refused(tmp_path, capsys):
    """Before: a NaN in a UV map a Normal Map node's tangents read (not the baked map) baked
    with exit 0, 15 texels up to 5 deg off (round 35 refused NaN only in the baked map). Now
    refused, exit 2, naming the map, the node and the fix; the clean map passes the check."""
    from surfgrad_addon.addon.compat import new_material
    from surfgrad_addon.addon.bake_uvs import baked_mesh
    from surfgrad_addon.addon.material_uv_maps import read_uv_map_problems
    obj = _scaled("Sphere", 1.0)
    assert [uv.name for uv in obj.data.uv_layers] == ["UVMap", "Detail"]   # the test sphere's
    mat = new_material("Reads Detail")
    obj.data.materials.append(mat)
    nodes = mat.node_tree.nodes
    normal = nodes.new("ShaderNodeNormalMap")
    normal.uv_map, normal.name = "Detail", "Detail Normal"
    normal.inputs["Color"].default_value = (0.7, 0.5, 0.9, 1.0)
    mat.node_tree.links.new(normal.outputs["Normal"],
                            nodes["Principled BSDF"].inputs["Normal"])
    assert read_uv_map_problems(obj, baked_mesh(obj).triangle_uvs, "UVMap") == []
    obj.data.uv_layers["Detail"].data[0].uv = (float("nan"), 0.5)
    rc, err, written = bake_open_file(tmp_path, capsys, "nan", "--uv-map", "UVMap")
    assert rc == 2 and not written
    assert ("the UVs of UV map 'Detail' of object 'Sphere', which node 'Detail Normal' of "
            "material 'Reads Detail' reads, contain non-finite values (NaN or Inf); unwrap it "
            "again (UV > Unwrap) or remove it") in err
