"""What SG Resolve's guard (.SG Safe Normal, addon/groups/common.py) relies on in Cycles, pinned
on every line, and the guard itself: every output a finite unit normal, the shading normal
where the vector has no direction (zero, NaN, +-Inf), on front and back faces.

The guard's pieces (per-sample values, so that no constant folding decides them):
- a World-space Normal Map node replaces a zero result by the shading normal on every line and
  a NaN or Inf one only where the line's facts say so (5.0+); on 4.2/4.5 a NaN passes;
- Vector Math Maximum/Minimum against finite constants turn NaN and +-Inf into finite values
  (what 4.2/4.5's guard clamps with);
- Face Forward keeps its first vector where the dot product is NaN;
- Multiply Add d * 0 + d is NaN for an infinite d (it is not folded to d).
Front faces are Cycles EMIT bakes (support/bake_probe); back faces a tiny render from behind.
"""

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

pytest.importorskip("bpy")

from support import bake_probe as probe  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.node_vocabulary import Math, VMath  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402

LINE = facts_for(probe.bpy.app.version)
SIZE = 4
UP = np.array([0.0, 0.0, 1.0])          # the probe plane's shading normal (front)


def _per_sample(g, uv):
    """(one, zero, inf, nan) as per-sample scalars: 1 = (u > -1) at every texel."""
    u = g.separate(uv)[0]
    one = g.math(Math.GREATER_THAN, u, -1.0)
    inf = g.math(Math.EXPONENT, g.math(Math.MULTIPLY, one, 1000.0))
    return one, g.math(Math.SUBTRACT, one, 1.0), inf, g.math(Math.SUBTRACT, inf, inf)


def _vectors(g, uv):
    """Named per-sample vectors for the guard."""
    one, zero, inf, nan = _per_sample(g, uv)
    neg_inf = g.math(Math.MULTIPLY, inf, -1.0)
    return {"zero": g.combine(zero, zero, zero),
            "nan": g.combine(nan, zero, one),
            "+inf": g.combine(inf, zero, zero),
            "-inf": g.combine(neg_inf, zero, zero),
            "-inf z": g.combine(zero, zero, neg_inf),
            "+inf z": g.combine(zero, zero, inf),
            "tiny": g.combine(g.math(Math.MULTIPLY, one, 1e-30), zero, zero),
            "finite": g.combine(g.math(Math.MULTIPLY, one, 0.3), -0.2, 0.9)}


def _bake_vector(build):
    """Bake build(g, uv) -> vector socket on the probe plane; the texels' xyz, (N, 3)."""
    probe.new_scene()
    pr = probe.EmissionProbe(probe.add_uv_plane())
    px = pr.bake(build(pr, pr.uv.outputs["UV"]), SIZE, SIZE)
    return px[..., :3].reshape(-1, 3).astype(np.float64)


def _safe(g, v):
    node = g.node("ShaderNodeGroup", node_tree=G.safe_normal_group())
    g.link(v, node.inputs["Vector"])
    return node.outputs[0]


def test_world_normal_map_node_replaces_what_the_line_says():
    """Zero -> the shading normal on every line; NaN and Inf -> the shading normal exactly
    where LineFacts.normal_map_replaces_non_finite (5.0+), else not."""
    def decoded(kind):
        def build(g, uv):
            v = _vectors(g, uv)[kind]
            return g.normal_map(g.vmath(VMath.MULTIPLY_ADD, v, (0.5,) * 3, (0.5,) * 3), "WORLD")
        return _bake_vector(build)
    assert np.array_equal(decoded("zero"), np.tile(UP, (SIZE * SIZE, 1)))
    for kind in ("nan", "+inf"):
        out = decoded(kind)
        replaced = np.array_equal(out, np.tile(UP, (SIZE * SIZE, 1)))
        assert replaced == LINE.normal_map_replaces_non_finite, (kind, out[0])


def test_vector_maximum_minimum_turn_non_finite_into_finite():
    """4.2/4.5's guard: Minimum(Maximum(v, -B), B) is finite for NaN and +-Inf components and
    leaves a finite v as it is."""
    bound = 1e30

    def build(g, uv):
        one, zero, inf, nan = _per_sample(g, uv)
        v = g.combine(nan, inf, g.math(Math.MULTIPLY, inf, -1.0))
        clamped = g.vmath(VMath.MINIMUM, g.vmath(VMath.MAXIMUM, v, (-bound,) * 3), (bound,) * 3)
        return g.scale(clamped, 1.0 / bound)
    out = _bake_vector(build)
    assert np.isfinite(out).all(), out[0]
    assert np.allclose(out[:, 1:], [1.0, -1.0]), out[0]

    def keep(g, uv):
        v = _vectors(g, uv)["finite"]
        return g.vmath(VMath.MINIMUM, g.vmath(VMath.MAXIMUM, v, (-bound,) * 3), (bound,) * 3)
    assert np.array_equal(_bake_vector(keep), np.tile(np.float32([0.3, -0.2, 0.9]),
                                                      (SIZE * SIZE, 1)))


def test_face_forward_keeps_its_vector_where_the_dot_is_nan():
    """Face Forward(a, i, r) = dot(r, i) < 0 ? a : -a: a NaN dot is not < 0, so -a (the guard
    passes -u as a, so that a NaN vector keeps u, the shading normal)."""
    def build(g, uv):
        vs = _vectors(g, uv)
        return g.vmath(VMath.FACEFORWARD, (0.0, 0.0, 1.0), vs["nan"], (1.0, 0.0, 0.0))
    assert np.array_equal(_bake_vector(build), np.tile(-UP, (SIZE * SIZE, 1)))


def test_multiply_add_by_zero_is_not_folded_away():
    """d * 0 + d: NaN for d = Inf (so Greater Than says 0), d for a finite d."""
    def build(g, uv):
        one, zero, inf, nan = _per_sample(g, uv)
        return g.combine(*[g.math(Math.GREATER_THAN, g.math(Math.MULTIPLY_ADD, d, 0.0, d), 0.5)
                           for d in (inf, g.math(Math.MULTIPLY, one, 2.0), nan)])
    assert np.array_equal(_bake_vector(build), np.tile([0.0, 1.0, 0.0], (SIZE * SIZE, 1)))


KINDS = ["zero", "nan", "+inf", "-inf", "-inf z", "+inf z", "tiny", "finite"]


@pytest.mark.parametrize("kind", KINDS)
def test_safe_normal_front_faces(kind):
    """The guard baked (front faces): the shading normal where the vector has no direction,
    else the vector normalised."""
    out = _bake_vector(lambda g, uv: _safe(g, _vectors(g, uv)[kind]))
    if kind == "finite":
        want = np.array([0.3, -0.2, 0.9]) / math.sqrt(0.3 ** 2 + 0.2 ** 2 + 0.9 ** 2)
    else:
        want = UP
    assert np.isfinite(out).all(), out[0]
    assert np.allclose(out, want, atol=1e-6), (kind, out[0])


# Back faces: a render from under the plane (Cycles' Normal Map node negates its result there).

def _render_from_behind(build):
    """Render build(g, uv) -> vector socket as colour 0.5 v + 0.5 through Emission, camera under
    the plane looking up (its back face); the pixels decoded back to vectors, (N, 3)."""
    import bpy
    scene = probe.new_scene()
    pr = probe.EmissionProbe(probe.add_uv_plane())
    v = build(pr, pr.uv.outputs["UV"])
    pr.links.new(pr.vmath(VMath.MULTIPLY_ADD, v, (0.5,) * 3, (0.5,) * 3),
                 pr.emission.inputs["Color"])
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 0.5
    cam.location = (0.0, 0.0, -2.0)
    cam.rotation_euler = (math.pi, 0.0, 0.0)       # looking along +Z, at the plane's back
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.render.filter_size = 0.01
    scene.cycles.samples = 1
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    with tempfile.TemporaryDirectory() as tmp:
        scene.render.filepath = str(Path(tmp) / "behind.exr")
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(scene.render.filepath)
        px = probe.image_pixels(img)
        bpy.data.images.remove(img)
    return 2.0 * px[..., :3].reshape(-1, 3).astype(np.float64) - 1.0


def test_the_plane_is_seen_from_behind():
    """The render's shading normal faces the camera: -Z."""
    out = _render_from_behind(lambda g, uv: g.geometry("Normal"))
    assert np.allclose(out, -UP, atol=1e-5), out[0]


@pytest.mark.parametrize("kind", KINDS)
def test_safe_normal_back_faces(kind):
    """From behind: the shading normal (-Z there) where the vector has no direction, else the
    vector normalised, not negated."""
    out = _render_from_behind(lambda g, uv: _safe(g, _vectors(g, uv)[kind]))
    if kind == "finite":
        want = np.array([0.3, -0.2, 0.9]) / math.sqrt(0.3 ** 2 + 0.2 ** 2 + 0.9 ** 2)
    else:
        want = -UP
    assert np.isfinite(out).all(), out[0]
    assert np.allclose(out, want, atol=1e-5), (kind, out[0])
