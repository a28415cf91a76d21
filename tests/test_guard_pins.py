"""What SG Resolve's guard (.SG Safe Normal, addon/groups/common.py) relies on in Cycles, pinned
on every line, and the guard itself: every output a finite unit normal, the shading normal
where the vector has no direction (zero, NaN, +-Inf), on front and back faces.

The guard's pieces (per-sample values, so that no constant folding decides them):
- Vector Math Normalize gives NaN for a NaN or Inf vector, zero for a zero one and a unit
  vector for a finite one, overflowing squared lengths included;
- Vector Math Maximum against a finite constant turns a NaN component into that constant;
- Multiply Add d * 0 + d is NaN for an infinite d (it is not folded to d);
- the Mix node is a (1 - f) + b f, so factors 0 and 1 select exactly.
The World-space Normal Map node's own handling of zero and non-finite results (which an
earlier guard used) is pinned too: docs/versions.md states it per line.
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
    where LineFacts.normal_map_replaces_non_finite (5.0+), else not (docs/versions.md)."""
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


def _finite_flags(g, v):
    """Per component 1 where it is finite, 0 where NaN or Inf (a bake writes no NaN itself):
    (x > -3e38) (x < 3e38), both false for NaN."""
    def flag(x):
        return g.math(Math.MULTIPLY, g.math(Math.GREATER_THAN, x, -3e38),
                      g.math(Math.LESS_THAN, x, 3e38))
    return g.combine(*[flag(x) for x in g.separate(v)])


def test_vector_normalize_is_nan_for_non_finite_and_zero_for_zero():
    """Normalize: not finite for a NaN or an infinite vector (a NaN in some component), (0, 0, 0)
    for a zero one, a unit vector for a finite one, and finite where the squared length
    overflows."""
    def flags(kind):
        return _bake_vector(lambda g, uv: _finite_flags(g, g.normalize(_vectors(g, uv)[kind])))
    for kind in ("nan", "+inf", "-inf z"):
        assert (flags(kind).min(axis=1) == 0.0).all(), (kind, flags(kind)[0])
    assert np.array_equal(_bake_vector(lambda g, uv: g.normalize(_vectors(g, uv)["zero"])),
                          np.zeros((SIZE * SIZE, 3)))
    unit = _bake_vector(lambda g, uv: g.normalize(_vectors(g, uv)["finite"]))
    assert np.allclose(np.linalg.norm(unit, axis=1), 1.0, atol=1e-6), unit[0]

    def huge(g, uv):
        one = _per_sample(g, uv)[0]
        big = g.math(Math.MULTIPLY, one, 1e30)
        return _finite_flags(g, g.normalize(g.combine(big, big, 0.0)))
    assert (_bake_vector(huge) == 1.0).all()


def test_vector_maximum_alone_turns_nan_into_its_bound():
    """Maximum(v, -2): -2 in each NaN component, a finite component as it is."""
    def build(g, uv):
        one, zero, inf, nan = _per_sample(g, uv)
        return g.vmath(VMath.MAXIMUM, g.combine(nan, g.math(Math.MULTIPLY, one, 0.5), nan),
                       (-2.0, -2.0, -2.0))
    assert np.array_equal(_bake_vector(build), np.tile([-2.0, 0.5, -2.0], (SIZE * SIZE, 1)))


def test_mix_selects_exactly_at_factors_0_and_1():
    """Mix(f, a, b) = a (1 - f) + b f: a at 0 and b at 1 bit for bit (an interpolation a + f (b -
    a) would round b), with a finite other side."""
    a, b_ = (0.3, -0.2, 0.9), (0.1, 0.7, -0.7)

    def build(f):
        def mix(g, uv):
            fac = g.math(Math.MULTIPLY, _per_sample(g, uv)[0], f)
            return g.mix_vector(fac, a, b_)
        return mix
    assert np.array_equal(_bake_vector(build(0.0)), np.tile(np.float32(a), (SIZE * SIZE, 1)))
    assert np.array_equal(_bake_vector(build(1.0)), np.tile(np.float32(b_), (SIZE * SIZE, 1)))


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


# Back faces: a render from under the plane (Cycles' shading normal is negated there).

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
