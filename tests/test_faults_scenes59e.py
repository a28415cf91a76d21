"""Red team 59e: the state an artist's or TD's .blend is in when surfgrad's commands meet it.

1. An object in Sculpt Mode (a script's session with the sculpt open, or a .blend saved in
   Sculpt Mode, which opens in it, headless too), or back in Object Mode after sculpting in
   the same session. Sculpt Mode keeps the mesh's vertex normals its own way (each the
   normalised sum of its faces' normals; Object Mode weights them by corner angle: 0.39 deg
   apart on the grid below) in the mesh's normal cache, which stays after Object Mode is back
   until a vertex moves, and Cycles shades and bakes those, where compare's reference reads
   the mesh's own normals. compare called the correct group wrong: measured on 5.2, a bent
   6 x 5 grid at 32^2, `compare --blend sculpt.blend --method normal-map` gave p99 0.266 / max
   0.338 deg, exit 0 (the same file saved in Object Mode: 0.0003 / 0.0004; the bar is p99 0.1,
   max 0.5); api compare in Sculpt Mode, or in Object Mode after a sculpt (once a compare had
   run earlier in the session), the same; a steeper 8 x 6 grid (bend 1.0): p99 1.42 deg.
   Now compare takes the object out of Sculpt Mode, has the mesh's normals recomputed for
   the comparison, and puts Sculpt Mode back
   (addon/sculpt_normals.py): the figures are Object Mode's; the object is in Sculpt Mode
   after, its vertices and the active object as they were. On 5.0 and 4.5 compare was
   right (its reference read the same normals as the bake there; finding 2 held); on 4.2
   Cycles shades Object Mode's normals in Sculpt Mode too (pinned), so both were right.
2. The same normals in bake-normal-map's route (api.bake_normal_map; Freeze and bake-batch
   bake through normal_bake.bake_normal_tiles too): an object baked once, then taken into
   Sculpt Mode with no stroke, baked again (in Sculpt Mode, or back in Object Mode in the same
   session) wrote another map with exit 0: on a 6 x 5 grid with a steep bump at 32^2, p99
   2.82 / max 3.48 deg off its own earlier map in tangent space, 2.72 / 3.42 in object space
   (5.2; 5.0 and 4.5: 2.82 / 3.47 and 2.72 / 3.41; the mesh unchanged, and the file, saved and reopened in Object Mode, renders with the
   earlier map's normals). Now the bake runs with addon/sculpt_normals.own_normals as compare
   does: the map is the earlier one (within 0.01 deg), the mode given back.

Probed and fine on 5.2 (api.bake_normal_map's 32^2 map texel for texel the plain file's, and
compare normal-map within p99 0.0003 / max 0.0004 deg, every scene, view layer, object and
collection setting read back unchanged after both): the object hidden (eye, monitor,
hide_render, hide_set), holdout (object, collection), a collection Indirect Only, a view layer
off for rendering, a material override; a scene with a far camera, no world, EEVEE or
Workbench as its engine; AgX with the Punchy look, exposure 1.5, gamma 0.6 and curves,
Khronos PBR Neutral, a Display P3 display, an Output override (Save as Render's settings);
the scene's bake settings left as an artist had them (Selected to Active with a cage, its
extrusion and ray distance; margin Extend 64 and Adjacent Faces 0; target Color Attributes;
Clear Image off; Object space with a -X/+Z/+Y swizzle; Split Materials); Persistent Data;
a compositor tree with an Invert node; Cycles set by the artist (denoising, adaptive sampling
at threshold 0.5, 7 samples, no bounces, an animated seed, film exposure 3, filter width 8,
view layer samples 64, a transparent film, the light tree off, scrambling distance, a time
limit, one thread, device GPU, OSL); the active UV map not the render one; frame 37, a
render region, resolution 1 %, Simplify; the object in Edit Mode with its UVs moved to tile
1002 (or back into 1001) or its vertices moved, unsaved: each bakes and compares the edit
mesh, as Cycles renders it; Vertex, Weight and Texture Paint modes; a shape key at 0.7. An
object in a collection excluded from the active view layer (also where another view layer
holds it) is refused naming the view layer, the collection and the fix.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.harness import asset_scenes as A, bake as B, compare  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 32
BAR_P99, BAR_MAX = 0.1, 0.5          # compare-all's bar for a correct group
# Sculpt Mode's own vertex normals reach Cycles from 4.5 (measured: 0.3-1.4 deg); on 4.2 the
# shading normals in Sculpt Mode are Object Mode's (within 2e-6 deg), so its compare was right.
SCULPT_NORMALS_OWN = bpy.app.version >= (4, 5, 0)


@pytest.fixture
def empty_file():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy


def _grid(nx, ny, bend):
    obj = A._link("Grid", A._grid("Grid", nx=nx, ny=ny, bend=bend))
    return obj


def _sculpt(obj):
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="SCULPT")
    assert obj.mode == "SCULPT"


def _positions(obj):
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    return co


def _shading_normals(obj):
    px, covered, _ = B.bake_vector(
        obj, lambda nodes, links: nodes.new("ShaderNodeNewGeometry").outputs["Normal"],
        RES, RES)
    n = px[covered].astype(np.float64)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


@pytest.mark.parametrize("nx, ny, bend", [(6, 5, 0.35), (8, 6, 1.0)])
def test_sculpt_mode_normals_are_not_object_modes(empty_file, nx, ny, bend):
    """The fact behind finding 1 (so the test below can fail): from 4.5 Cycles shades an
    object in Sculpt Mode with other normals than in Object Mode; not on 4.2."""
    obj = _grid(nx, ny, bend)
    plain = _shading_normals(obj)
    _sculpt(obj)
    sculpted = _shading_normals(obj)
    deg = np.degrees(np.arccos(np.clip((plain * sculpted).sum(1), -1, 1)))
    if SCULPT_NORMALS_OWN:
        assert deg.max() > 0.2, deg.max()
    else:
        assert deg.max() < 0.001, deg.max()


@pytest.mark.parametrize("nx, ny, bend", [(6, 5, 0.35), (8, 6, 1.0)])
def test_compare_of_an_object_in_sculpt_mode_does_not_call_the_correct_group_wrong(
        empty_file, nx, ny, bend):
    obj = _grid(nx, ny, bend)
    plain = compare.compare(obj, "normal-map", RES)
    co = _positions(obj)
    _sculpt(obj)
    # Before: 6 x 5: p99 0.266 / max 0.338 deg.
    report = compare.compare(obj, "normal-map", RES)
    assert report["p99_deg"] < BAR_P99 and report["max_deg"] < BAR_MAX, report["p99_deg"]
    assert abs(report["p99_deg"] - plain["p99_deg"]) < 0.01
    assert report["texels_compared"] == plain["texels_compared"]
    # Given back: Sculpt Mode, the vertices, the active object.
    assert obj.mode == "SCULPT" and bpy.context.view_layer.objects.active == obj
    assert np.array_equal(_positions(obj), co)


def test_a_file_saved_in_sculpt_mode_compares_as_in_object_mode(empty_file, tmp_path):
    """The .blend a sculptor saves: it opens in Sculpt Mode (headless too)."""
    obj = _grid(6, 5, 0.35)
    _sculpt(obj)
    path = tmp_path / "sculpt.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    obj = bpy.data.objects["Grid"]
    assert obj.mode == "SCULPT"
    report = compare.compare(obj, "normal-map", RES)
    assert report["p99_deg"] < BAR_P99 and report["max_deg"] < BAR_MAX, report["p99_deg"]
    assert obj.mode == "SCULPT"


def test_compare_after_leaving_sculpt_mode_reads_no_stale_normals(empty_file):
    """Sculpt Mode's normals stay in the mesh after Object Mode is back (the session goes on);
    a compare earlier in the session made the bake take them."""
    obj = _grid(6, 5, 0.35)
    plain = compare.compare(obj, "normal-map", RES)
    _sculpt(obj)
    bpy.ops.object.mode_set(mode="OBJECT")
    # Before: p99 0.266 / max 0.338 deg.
    report = compare.compare(obj, "normal-map", RES)
    assert report["p99_deg"] < BAR_P99 and report["max_deg"] < BAR_MAX, report["p99_deg"]
    assert abs(report["p99_deg"] - plain["p99_deg"]) < 0.01
    assert obj.mode == "OBJECT"


def _bumped(bump=0.8):
    """A 6 x 5 grid with a steep bump, its material a Normal Map node reading a noise on the
    UVs (a map that tilts each texel its own way)."""
    obj = _grid(6, 5, 0.35)
    for v in obj.data.vertices:
        v.co.z += bump * np.exp(-2 * (v.co.x ** 2 + v.co.y ** 2))
    mat = bpy.data.materials.new("M")
    if bpy.app.version < (5, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    coords, noise = nt.nodes.new("ShaderNodeTexCoord"), nt.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    mix, nmap = nt.nodes.new("ShaderNodeMix"), nt.nodes.new("ShaderNodeNormalMap")
    mix.data_type = "RGBA"
    mix.inputs[6].default_value = (0.5, 0.5, 1.0, 1.0)
    mix.inputs[7].default_value = (0.75, 0.5, 0.933, 1.0)
    nt.links.new(coords.outputs["UV"], noise.inputs["Vector"])
    nt.links.new(noise.outputs[0], mix.inputs[0])
    nt.links.new(mix.outputs[2], nmap.inputs["Color"])
    nt.links.new(nmap.outputs[0], nt.nodes["Principled BSDF"].inputs["Normal"])
    obj.data.materials.append(mat)
    return obj


def _baked(obj, path, space):
    api.bake_normal_map(obj, path, space=space, resolution=RES, samples=1, margin=0,
                        log=None)
    img = bpy.data.images.load(str(path))
    try:
        img.colorspace_settings.is_data = True
        px = np.array(img.pixels[:], dtype=np.float64).reshape(RES, RES, -1)[..., :3]
    finally:
        bpy.data.images.remove(img)
    n = px * 2 - 1
    return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)


@pytest.mark.parametrize("space", ["tangent", "object"])
@pytest.mark.parametrize("when", ["in sculpt mode", "after sculpt mode"])
def test_a_bake_in_or_after_sculpt_mode_is_the_meshs_own(empty_file, tmp_path, space, when):
    """bake-normal-map's route (api.bake_normal_map; Freeze and bake-batch bake through the
    same function) bakes with the mesh's own normals, as the file renders once reopened."""
    obj = _bumped()
    # Baked before Sculpt Mode (an artist's earlier bake or render): no stroke follows, so
    # the mesh stays as it is, and so must its map.
    plain = _baked(obj, tmp_path / "plain.exr", space)
    _sculpt(obj)
    if when == "after sculpt mode":
        bpy.ops.object.mode_set(mode="OBJECT")
    co = _positions(obj)
    baked = _baked(obj, tmp_path / "sculpted.exr", space)
    deg = np.degrees(np.arccos(np.clip((plain * baked).sum(-1), -1, 1)))
    # Before (4.5 and later): p99 2.72 / max 3.42 deg (object), 2.82 / 3.48 (tangent).
    assert deg.max() < 0.01, (np.percentile(deg, 99), deg.max())
    assert obj.mode == ("SCULPT" if when == "in sculpt mode" else "OBJECT")
    assert bpy.context.view_layer.objects.active == obj
    assert np.array_equal(_positions(obj), co)
