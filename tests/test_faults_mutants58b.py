"""Red team 58b: mutation testing of compare, second round (after test_faults_mutants57d.py):
the methods and groups round 57 did not touch. Each mutant is a small, plausible mistake in a
group builder (addon/groups/), patched in before the groups are built; compare (32^2, compare-
all's objects Sphere, Torus, Plane, Transformed) bakes it against the unchanged reference. Bars:
p99 0.1, max 0.5 deg. Figures: worst p99 / max over the four objects, 5.2.

Caught before and after (test_a_mutant_compare_all_catches_is_called_wrong): SG Blend Normals
PD as whiteout (15.9 / 18.1), UDN as whiteout (8.1 / 9.4), RNM as whiteout (10.6 / 10.8), RNM
as PD (26.2 / 27.3); SG Height Blend's weights swapped (39.5 / 51.6), Contrast ignored (15.7 /
21.8); SG Volume Gradient without Listing 8's projection (19.8 / 41.7; filtered 2.4 / 2.9); SG
Noise without the chain rule's 2^i (22.9 / 32.0; displace-bump 8.5 / 10.9), its object-to-world
transform as M^T (Transformed only: 67.6 / 76.6), Filter Footprint's fade off (36.5 / 44.4); SG
Object Normal's k n - v turned (60.0 / 60.0); HQ's Sobel sign turned (37.6 / 41.8, the Sampler
twin the same), its texel centres half a texel off (13.7 / 14.9); Forward's filter width doubled
(12.8 / 14.7), its Bump Scale ignored (64.8 / 64.8); triplanar-height's X plane (y, z) (35.8 /
44.8, Plane 0; Sampler the same); parallax-sampler's view turned (125.8 / 161.8); the decal's
sphere from rho (70.4 / 79.7), cone and wedge radius 1 - z (71.1 / 85.2); decal-overwrite as Add
(41.8 / 73.7); SG Triplanar's weights from the shading normal, not Normal (triplanar 0.0018 /
0.004, passed there: post-resolve catches it, 37.3 / 45.7, Plane 0).

1. The decal's projector was centred on the object, about its size (1.1, 0.95, 1.2 of its half
   size), so the wedge's open end (y < -1), the capsule's rounded ends and the cylinder's depth
   fade lay off every object but a cap of the sphere. Passed as correct, every object, before:
   the wedge without its y > -1 cut 0.0009 / 0.0015; the capsule's half length doubled 0.013 /
   0.118 (Plane; the other three 0.0009 / 0.0015); the cylinder without its depth fade caught
   on the Sphere alone (1.19 / 2.73, the others 0.0009 / 0.0015). Now the object's centre is at
   method_scene.PROJECTOR_OFFSET (0.25, -0.45, -0.35) in the projector's coordinates: every
   shape's edges and the region outside the projector lie on the objects: wedge 60.2-64.9 p99
   every object; capsule 35.9 / 69.1 (Sphere), 14.6 / 31.2 (Transformed), Torus 0.96 / 3.9,
   Plane 0.02 / 0.70; cylinder 8.0-61.2 p99 every object; the correct decal groups (six
   shapes, overwrite, the DirectX/Strength case) 0.0011 / 0.0029 at worst. (A projector 0.7 the size, tried
   first, left the sphere decal off the Sphere and the cone 0.3 deg of tilt 10 km out, where
   tests/test_far.py wants the method to bend normals.)
2. layered (Figure 1's stack) ran SG Combine at Scale A = Scale B = Mask B = 1, where a Combine
   ignoring any of them is the right one: 0.0007 / 0.0032 (the correct group's figures). Now the
   graph sets Scale B 2, Mask B 0.5 (method_registry.LAYER_COMBINE; their product is 1, so the
   reference and tests/data/reference_a08fc13.npz hold): Mask B ignored 31.5 / 54.3, Scale B
   ignored 31.3 / 41.6; the correct group 0.0007 / 0.0028. Left: Scale A is still 1 (ignoring
   it passes, 0.0007 / 0.0032); a value other than 1 changes the reference's recorded values.
3. volume-noise ran at Octaves 4, every octave SG Noise sums: SG Noise ignoring Octaves passed
   (0.0013 / 0.0023); only displace-bump (Octaves 2, 4.5+) caught it. Found here and by rt58c
   alike; main has rt58c's fix (compare_all.SETTINGS_CASES volume-noise at Octaves 2,
   tests/test_faults_settings58c.py): the mutant 27.8 / 37.4 there, the correct group 0.0003 /
   0.0005. Pinned here once more as a mutant.

Blind by construction, left (not pinned here): SG Resolve's .SG Safe Normal as a plain
Normalize (no texel has a vector without direction; tests/test_guard_pins.py pins the guard);
SG Object Normal's max(eps, |k|) as max(eps, k) (0.0001 / 0.0003: the method's v = decoded + 2 N
always faces N); SG Displace's normal not projected (0.0002 / 0.0028: displace-bump's reference
reads the displaced mesh's own normals, which SG Displace makes; tests/test_displace.py checks
them); SG Noise's Gain and Turbulence (no method sets them).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import node_builder as NB  # noqa: E402
from surfgrad_addon.addon.groups import displacement as D  # noqa: E402,F401
from surfgrad_addon.addon.groups import height as H  # noqa: E402
from surfgrad_addon.addon.groups import height_blend as HB  # noqa: E402
from surfgrad_addon.addon.groups import parallax as PX  # noqa: E402
from surfgrad_addon.addon.groups import projection as P  # noqa: E402
from surfgrad_addon.addon.groups import resolve as R  # noqa: E402
from surfgrad_addon.addon.groups import tangent_space as TS  # noqa: E402
from surfgrad_addon.addon.groups import volume as V  # noqa: E402
from surfgrad_addon.addon.node_vocabulary import Math, VMath  # noqa: E402
from surfgrad_addon.harness import compare_all as CA  # noqa: E402
from surfgrad_addon.harness import method_scene as MS  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402
from surfgrad_addon.harness.compare import compare_object  # noqa: E402
from surfgrad_addon.harness.method_graphs import volume as VG  # noqa: E402
from surfgrad_addon.harness.methods import unavailable_reason  # noqa: E402
from surfgrad_addon.reference import method_registry as MR  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from support.group_mutants import while_building  # noqa: E402

pytestmark = pytest.mark.tier("bake")

P99_BAR, MAX_BAR = 0.1, 0.5
RES = 32


# Mutants: each patches a builder (monkeypatch undoes it); the groups are built after. --------

def _math(mp, module, builders, change):
    """Every b.math(op, *args) of the builders as change(self, orig, op, args) says (None:
    unchanged)."""
    orig = NB.GroupBuilder.math

    def math(self, op, *a, **k):
        out = change(self, orig, op, a)
        return orig(self, op, *a, **k) if out is None else out
    for builder in builders:
        while_building(mp, module, builder, "math", math)


def _blend_as(slot, other):
    def mutant(mp):
        orig = TS.select_blend

        def select(b, method, c):
            c = list(c)
            c[slot] = c[other]
            return orig(b, method, tuple(c))
        mp.setattr(TS, "select_blend", select)
    mutant.__name__ = f"_{('pd', 'whiteout', 'udn', 'rnm')[slot]}_as_" \
                      f"{('pd', 'whiteout', 'udn', 'rnm')[other]}"
    return mutant


def _hb_weights_swapped(mp):       # W_B = 1 - w_B / (w_A + w_B)
    def change(self, orig, op, a):
        if op == Math.DIVIDE and not getattr(self, "_mutated", False):
            self._mutated = True
            return orig(self, Math.SUBTRACT, 1.0, orig(self, op, *a))
    _math(mp, HB, ["height_blend_group"], change)


def _hb_contrast_ignored(mp):      # c = 1 - Contrast as 1
    _math(mp, HB, ["height_blend_group"], lambda self, orig, op, a: 1.0 if (
        op == Math.SUBTRACT and isinstance(a[0], float) and a[0] == 1.0) else None)


def _vg_not_projected(mp):         # Listing 8 skipped: grad as it is
    while_building(mp, V, "volume_gradient_group", "sub", lambda self, a, c: a)


def _noise_chain_rule_dropped(mp):  # octave i's gradient not times 2^i
    _math(mp, V, ["noise_group"], lambda self, orig, op, a: a[0] if (
        op == Math.MULTIPLY and len(a) == 2 and isinstance(a[1], float)
        and a[1] in (2.0, 4.0, 8.0) and not isinstance(a[0], float)) else None)


def _noise_octaves_ignored(mp):     # every octave summed, whatever Octaves says
    _math(mp, V, ["noise_group"], lambda self, orig, op, a: 1.0 if (
        op == Math.LESS_THAN and isinstance(a[0], float) and a[0] >= 1.0) else None)


def _noise_transform_turned(mp):    # (M^-T g) with the transform OBJECT -> WORLD
    orig = NB.GroupBuilder.node

    def node(self, kind, *a, **k):
        if kind == "ShaderNodeVectorTransform" and k.get("convert_from") == "WORLD":
            k = dict(k, convert_from="OBJECT", convert_to="WORLD")
        return orig(self, kind, *a, **k)
    while_building(mp, V, "noise_group", "node", node)


def _footprint_fade_off(mp):
    mp.setattr(V, "footprint_fade", lambda b, amp, filtered, footprint, freq: amp)


def _object_normal_turned(mp):      # v - k n for k n - v
    orig = NB.GroupBuilder.sub
    while_building(mp, V, "object_normal_group", "sub", lambda self, a, c: orig(self, c, a))


def _sobel_sign_turned(mp):         # HQ's difference weights -0.5, 0.5 turned
    def change(self, orig, op, a):
        if op == Math.MULTIPLY and len(a) == 2 and isinstance(a[1], float) and \
                a[1] in (-0.5, 0.5):
            return orig(self, op, a[0], -a[1])
    _math(mp, H, ["height_map_group", "height_map_sampler_group"], change)


def _texel_centres_off(mp):         # HQ's taps at fl + j, not fl + j - 0.5
    orig = NB.GroupBuilder.vmath

    def vmath(self, op, *a, **k):
        if op == VMath.ADD and len(a) == 2 and isinstance(a[1], tuple) and len(a[1]) == 3 \
                and a[1][2] == 0.0 and a[1][0] in (-0.5, 0.5, 1.5, 2.5):
            a = (a[0], (a[1][0] + 0.5, a[1][1] + 0.5, 0.0))
        return orig(self, op, *a, **k)
    while_building(mp, H, "height_map_group", "vmath", vmath)


def _forward_width_doubled(mp):
    orig = NB.GroupBuilder.bump
    while_building(mp, H, "height_map_forward_group", "bump",
                    lambda self, h, n, fw, *a, **k: orig(self, h, n, fw * 2, *a, **k))


def _forward_scale_ignored(mp):
    orig = NB.GroupBuilder.scale
    while_building(mp, H, "height_map_forward_group", "scale", lambda self, v, s: v if getattr(
        s, "name", "") == "Bump Scale" else orig(self, v, s))


def _th_x_plane_turned(mp):         # triplanar-height's X plane (y, z) for (z, y)
    orig = NB.GroupBuilder.combine

    def combine(self, *a):
        self._combines = getattr(self, "_combines", 0) + 1
        return orig(self, *(a[::-1] if self._combines == 1 and len(a) == 2 else a))
    while_building(mp, H, "triplanar_height_group", "combine", combine)
    while_building(mp, H, "triplanar_height_sampler_group", "combine", combine)


def _view_xy_turned(mp):
    orig = PX.where_zero
    mp.setattr(PX, "where_zero", lambda b, v, fallback: b.vmath(
        VMath.MULTIPLY, orig(b, v, fallback), (-1.0, -1.0, 1.0)))


def _in_decal_weight(mp, replace):
    """decal_weight with GroupBuilder.attr as replace(orig) says while it builds."""
    orig = P.decal_weight

    def weight(b, q, shape, falloff, shapes=range(6)):
        kept = {attr: getattr(NB.GroupBuilder, attr) for attr in replace}
        for attr, how in replace.items():
            setattr(NB.GroupBuilder, attr, how(kept[attr], q))
        try:
            return orig(b, q, shape, falloff, shapes)
        finally:
            for attr, f in kept.items():
                setattr(NB.GroupBuilder, attr, f)
    mp.setattr(P, "decal_weight", weight)


def _sphere_from_rho(mp):           # |q| as |(q.x, q.y)|
    _in_decal_weight(mp, {"length": lambda orig, q: lambda self, v: orig(
        self, self.vmath(VMath.MULTIPLY, v, (1.0, 1.0, 0.0)) if v is q else v)})


def _constant_in_weight(name, old, new, op=None):
    def how(orig, q):
        def math(self, o, *a, **k):
            a = tuple(new if isinstance(x, float) and x == old and (op is None or o == op)
                      else x for x in a)
            return orig(self, o, *a, **k)
        return math

    def mutant(mp):
        _in_decal_weight(mp, {"math": how})
    mutant.__name__ = name
    return mutant


_radius_one_minus_z = _constant_in_weight("radius_one_minus_z", 0.5, 1.0, Math.MULTIPLY)
_capsule_twice_long = _constant_in_weight("capsule_twice_long", P.CAPSULE_HALF_LENGTH,
                                          2 * P.CAPSULE_HALF_LENGTH, Math.SUBTRACT)


def _wedge_open_end(mp):            # wedge: the y > -1 cut dropped
    def how(orig, q):
        def math(self, o, *a, **k):
            if o == Math.GREATER_THAN and len(a) > 1 and a[1] == -1.000001:
                return 1.0
            return orig(self, o, *a, **k)
        return math
    _in_decal_weight(mp, {"math": how})


def _depth_fade_dropped(mp):        # the depth ramp 1 - |z| as 1 (cylinder, box, cone, wedge)
    def how(orig, q):
        def math(self, o, *a, **k):
            if o == Math.SUBTRACT and isinstance(a[0], float) and a[0] == 1.0 and \
                    not getattr(self, "_depth_done", False):
                self._depth_done = True
                return orig(self, Math.ADD, 1.0, 0.0)
            return orig(self, o, *a, **k)
        return math
    _in_decal_weight(mp, {"math": how})


def _overwrite_as_add(mp):          # base + a (sg - base Overwrite) with Overwrite 0
    orig = NB.GroupBuilder.scale
    while_building(mp, P, "decal_group", "scale", lambda self, v, s: orig(
        self, v, 0.0 if getattr(s, "name", "") == "Overwrite" else s))


def _weights_from_shading(mp):      # SG Triplanar's weights from the shading normal
    orig = P.triplanar_weights
    mp.setattr(P, "triplanar_weights", lambda b, n, k: orig(b, b.geometry("Normal"), k))


def _combine_math(pick):
    def mutant(mp):                 # Scale B x Mask B as one of them
        _math(mp, R, ["combine_group"], lambda self, orig, op, a: a[pick] if
              op == Math.MULTIPLY else None)
    mutant.__name__ = ("mask_b_ignored", "scale_b_ignored")[pick]
    return mutant


_mask_b_ignored, _scale_b_ignored = _combine_math(0), _combine_math(1)


# --------------------------------------------------------------------------------------------

@pytest.fixture
def fresh_groups():
    """Each mutant's groups built anew; none left for the tests after."""
    yield lambda: scenes.new_scene()
    bpy.ops.wm.read_factory_settings(use_empty=True)


def _runs(method):
    reason = unavailable_reason(method)
    if reason is not None:
        pytest.skip(reason)


def _per_object(objects, method, variant=None, settings=None, names=None):
    out = {}
    for name, obj in objects.items():
        if names is None or name in names:
            r, _ = compare_object(obj, method, RES, variant=variant, log=None, settings=settings)
            out[name] = (r["p99_deg"], r["max_deg"])
    return out


def _wrong(p99, mx):
    return p99 > P99_BAR or mx > MAX_BAR


# (mutant, method, variant, the object that catches it): one object each keeps the file short.
CAUGHT = [
    (_blend_as(0, 1), "blend-pd", None, "Sphere"),
    (_blend_as(2, 1), "blend-udn", None, "Sphere"),
    (_blend_as(3, 1), "blend-rnm", None, "Sphere"),
    (_blend_as(3, 0), "blend-rnm", None, "Torus"),
    (_hb_weights_swapped, "height-blend", None, "Sphere"),
    (_hb_contrast_ignored, "height-blend", None, "Plane"),
    (_vg_not_projected, "volume-noise", None, "Torus"),
    (_vg_not_projected, "volume-noise-filtered", None, "Plane"),
    (_noise_chain_rule_dropped, "volume-noise", None, "Sphere"),
    (_noise_chain_rule_dropped, "displace-bump", None, "Torus"),
    (_noise_transform_turned, "volume-noise", None, "Transformed"),
    (_footprint_fade_off, "volume-noise-filtered", None, "Sphere"),
    (_object_normal_turned, "object-normal", None, "Sphere"),
    (_sobel_sign_turned, "height-map", "hq", "Torus"),
    (_sobel_sign_turned, "height-map-sampler", "hq", "Torus"),
    (_texel_centres_off, "height-map", "hq", "Torus"),
    (_forward_width_doubled, "height-map", "forward", "Plane"),
    (_forward_scale_ignored, "height-map", "forward", "Plane"),
    (_th_x_plane_turned, "triplanar-height", None, "Sphere"),
    (_th_x_plane_turned, "triplanar-height-sampler", None, "Sphere"),
    (_view_xy_turned, "parallax-sampler", None, "Plane"),
    (_sphere_from_rho, "decal", "sphere", "Plane"),
    (_radius_one_minus_z, "decal", "cone", "Sphere"),
    (_radius_one_minus_z, "decal", "wedge", "Torus"),
    (_overwrite_as_add, "decal-overwrite", None, "Torus"),
    (_weights_from_shading, "post-resolve", None, "Torus"),
]


@pytest.mark.parametrize("mutant,method,variant,catching", CAUGHT,
                         ids=[f"{c[0].__name__.strip('_')}-{c[1]}" for c in CAUGHT])
def test_a_mutant_compare_all_catches_is_called_wrong(monkeypatch, fresh_groups, mutant, method,
                                                      variant, catching):
    _runs(method)
    if mutant is _forward_width_doubled and not facts_for(bpy.app.version).bump_filter_width:
        pytest.skip("the Bump node has no Filter Width before 4.4: the mutant changes nothing")
    mutant(monkeypatch)
    (p99, mx), = _per_object(fresh_groups(), method, variant, names={catching}).values()
    assert p99 > 10 * P99_BAR and mx > MAX_BAR, (p99, mx)


def _old_projector(mp):
    mp.setattr(MS, "PROJECTOR_OFFSET", (0.0, 0.0, 0.0), raising=False)
    # (and sized by the largest dimension on every axis, as before rt59a)
    mp.setattr(MS, "_reach_along", lambda obj, centre, axes: np.full(
        3, max(obj.dimensions) * 0.5), raising=False)


def _old_combine(mp):
    mp.setattr(MR, "LAYER_COMBINE", (1.0, 1.0, 1.0), raising=False)
    mp.setattr(VG, "LAYER_COMBINE", (1.0, 1.0, 1.0), raising=False)


# Findings 1-3: (mutant, method, variant, the harness as it was, settings now, the objects
# that must call it wrong now).
BLIND = [
    (_wedge_open_end, "decal", "wedge", _old_projector, None, None),
    (_capsule_twice_long, "decal", "capsule", _old_projector, None, {"Sphere", "Transformed"}),
    (_depth_fade_dropped, "decal", "cylinder", _old_projector, None, None),
    (_mask_b_ignored, "layered", None, _old_combine, None, None),
    (_scale_b_ignored, "layered", None, _old_combine, None, None),
    (_noise_octaves_ignored, "volume-noise", None, None, CA.SETTINGS_CASES["volume-noise"],
     None),
]


@pytest.mark.parametrize("mutant,method,variant,old,settings,catching", BLIND,
                         ids=[f"{b[0].__name__.strip('_')}-{b[1]}" for b in BLIND])
def test_a_mutant_the_old_harness_passed_is_called_wrong(monkeypatch, fresh_groups, mutant,
                                                         method, variant, old, settings,
                                                         catching):
    """As compare-all ran before, the mutant is the right group within the bars on every
    object (or, the cylinder, caught on the Sphere alone); as it runs now, wrong on the
    objects that reach the mistake, by degrees."""
    mutant(monkeypatch)
    with monkeypatch.context() as before:
        if old:
            old(before)
        per = _per_object(fresh_groups(), method, variant)
    passed = [n for n, (p99, mx) in per.items() if not _wrong(p99, mx)]
    assert len(passed) >= (3 if mutant is _depth_fade_dropped else 4), per
    per = _per_object(fresh_groups(), method, variant, settings)
    for name, (p99, mx) in per.items():
        if catching is None or name in catching:
            assert p99 > 10 * P99_BAR and mx > MAX_BAR, (name, p99, mx)


@pytest.mark.parametrize("method,variant", [("decal", s) for s in (
    "box", "sphere", "cylinder", "cone", "wedge", "capsule")] + [("decal-overwrite", None),
                                                                 ("layered", None)])
def test_the_correct_groups_pass_the_changed_cases(fresh_groups, method, variant):
    """The unmutated groups with the smaller projector and layered's Combine settings: within
    the bars on every object (and the projector leaves texels outside it on each: the
    region where the decal adds nothing is compared too)."""
    objects = fresh_groups()
    per = _per_object(objects, method, variant)
    assert not any(_wrong(*v) for v in per.values()), per
    if method == "decal":
        import numpy as np
        for name, obj in objects.items():
            projector = MS.decal_projector(obj)
            try:
                to_q = np.linalg.inv(np.array(projector.matrix_world)) @ np.array(
                    obj.matrix_world)
                v = np.array([(*p.co, 1.0) for p in obj.data.vertices]) @ to_q.T
                assert (np.abs(v[:, :3]).max(axis=1) > 1.0).any(), name
            finally:
                bpy.data.objects.remove(projector)
