"""Red team 57d: does compare call a WRONG group wrong? Mutation testing of the node groups.

Each mutant is a small, plausible mistake in a group builder (addon/groups/), patched in before
the groups are built; compare (32^2, compare-all's four objects Sphere, Torus, Plane,
Transformed) bakes the mutated groups against the unchanged numpy reference. Bars: p99 0.1,
max 0.5 deg. Worst p99 / max over the four objects, at compare-all's cases before this round:

  caught before: SG Normal Map's red channel turned (95.1 / 137 deg); SG Resolve's n - sg as
  n + sg (172 / 173); Listing 5's facing-away branch removed (Transformed only: 180 / 180, the
  other three 0.0004 / 0.001); SG Tangent Normal's tangent and bitangent swapped (111 / 119);
  Listing 4's tangent not normalised (20.6 / 24.6; Plane 0.0006); triplanar weights not
  normalised (40.9 / 43.8); the X plane sampling (y, z) for (z, y) (110 / 150; Plane 0.0002);
  the decal's X axis flipped (135 / 166); one-texel height step twice a texel (17.0 / 17.5);
  whiteout's z taken from UDN (8.1 / 9.4); parallax's view with x, y turned (126 / 162).

1. Blind spots: compare-all compared every group at Strength 1 and DirectX off only, exactly
   where these mistakes change nothing. Passed as correct, every object, before:
   SG Normal Map ignoring DirectX (green never flipped): 0.0004 / 0.0011 (the correct group's
   figures); ignoring Strength, and squaring it: 0.0004 / 0.0011; SG Triplanar ignoring
   DirectX: 0.0018 / 0.0040 (likewise SG Decal and SG Tangent Normal, the same Listing 2).
   Now compare takes settings (harness/compare_settings.py: parameter values on both sides;
   DirectX on in the graph, the reference reading the image with green turned to 1 - green,
   which is what a DirectX map is) and compare-all adds a case at Strength 0.6, DirectX on for
   normal-map, triplanar, decal and procedural-basis (compare_all.SETTINGS_CASES). There, at
   32^2: DirectX ignored 60.6-75.6 deg p99 (normal-map), 89-108 (triplanar), 100-128 (decal),
   107-109 (procedural-basis); Strength ignored 23.3-35.7, squared 15.6-29.9; the correct
   groups 0.0003 / 0.0007 (normal-map), 0.0016 / 0.0048 (triplanar), 0.0008 / 0.0015
   (decal), 0.0005 / 0.0013 (procedural-basis).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import node_builder as NB  # noqa: E402
from surfgrad_addon.addon.groups import common as C  # noqa: E402
from surfgrad_addon.addon.groups import height as H  # noqa: E402
from surfgrad_addon.addon.groups import parallax as PX  # noqa: E402
from surfgrad_addon.addon.groups import projection as P  # noqa: E402
from surfgrad_addon.addon.groups import tangent_space as TS  # noqa: E402
from surfgrad_addon.addon.node_vocabulary import Math, VMath  # noqa: E402
from surfgrad_addon.harness import compare_all as CA  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402
from surfgrad_addon.harness.compare import compare_object  # noqa: E402
from support.group_mutants import while_building  # noqa: E402

pytestmark = pytest.mark.tier("bake")

P99_BAR, MAX_BAR = 0.1, 0.5
RES = 32


# Mutants: each patches a builder (monkeypatch undoes it); the groups are built after. --------

def _red_turned(mp):
    orig = TS.listing2_colour

    def colour(b, color, directx):
        x, y, z = b.separate(color)
        return orig(b, b.combine(b.math(Math.SUBTRACT, 1.0, x), y, z), directx)
    mp.setattr(TS, "listing2_colour", colour)


def _directx_ignored(mp):                     # every group's green flip, both forms
    mp.setattr(C, "flip_green_colour", lambda b, color, directx: color)
    mp.setattr(C, "flip_green", lambda b, y, directx: y)


def _node_strength(mp, how):
    orig = NB.GroupBuilder.normal_map

    def normal_map(self, color, space, strength=1.0, uv_map=""):
        if not isinstance(strength, (int, float)):
            strength = how(self, strength)
        return orig(self, color, space, strength, uv_map)
    mp.setattr(NB.GroupBuilder, "normal_map", normal_map)


def _strength_ignored(mp):
    _node_strength(mp, lambda b, s: 1.0)


def _strength_squared(mp):
    _node_strength(mp, lambda b, s: b.math(Math.MULTIPLY, s, s))


def _facing_away_removed(mp):
    def reaching(b, n, v, against):
        return b.vmath(VMath.MULTIPLY_ADD, v, b.math(Math.DIVIDE, -1.0, b.dot(against, v)), n)
    mp.setattr(TS, "surfgrad_reaching", reaching)


def _resolve_adds(mp):
    from surfgrad_addon.addon.groups import resolve
    while_building(mp, resolve, "resolve_group", "sub", NB.GroupBuilder.add)


def _tangent_not_normalised(mp):
    while_building(mp, TS, "procedural_basis_group", "normalize", lambda self, v: v)


def _tangent_bitangent_swapped(mp):
    orig = TS.tangent_normal_to_surfgrad
    mp.setattr(TS, "tangent_normal_to_surfgrad",
               lambda b, color, strength, t, bt, directx=None:
               orig(b, color, strength, bt, t, directx))


def _weights_not_normalised(mp):
    def weights(b, n, k):
        base = b.separate(b.vmath(VMath.MAXIMUM, b.vmath(VMath.SUBTRACT, b.vmath(
            VMath.ABSOLUTE, n), (0.2, 0.2, 0.2)), (0.0, 0.0, 0.0)))
        return tuple(b.math(Math.POWER, c, k) for c in base)
    mp.setattr(P, "triplanar_weights", weights)


def _x_plane_axes_swapped(mp):
    def planes(b, p):
        x, y, z = b.separate(p)
        return b.combine(y, z), b.combine(x, z), b.combine(x, y)
    mp.setattr(P, "plane_coordinates", planes)


def _decal_x_flipped(mp):
    orig = P.decode_tangent_normal

    def decode(b, color, directx=None, weight=None):
        dx, dy = orig(b, color, directx, weight)
        return b.math(Math.MULTIPLY, dx, -1.0), dy
    mp.setattr(P, "decode_tangent_normal", decode)


def _texel_step_doubled(mp):
    orig = H._texel_offset
    mp.setattr(H, "_texel_offset", lambda b, uv, du, dv: orig(
        b, uv, du * 2 if isinstance(du, float) else du, dv * 2 if isinstance(dv, float) else dv))


def _whiteout_from_udn(mp):
    orig = TS.select_blend
    mp.setattr(TS, "select_blend", lambda b, method, c: orig(b, method, (c[0], c[2], c[2], c[3])))


def _view_xy_turned(mp):
    orig = PX.where_zero
    mp.setattr(PX, "where_zero", lambda b, v, fallback: b.vmath(
        VMath.MULTIPLY, orig(b, v, fallback), (-1.0, -1.0, 1.0)))


@pytest.fixture
def fresh_groups():
    """Each mutant's groups built anew; none left for the tests after (the builders reuse a
    group of the current version, mutated or not)."""
    yield lambda: scenes.new_scene()
    bpy.ops.wm.read_factory_settings(use_empty=True)


def _worst(objects, method, variant=None, settings=None):
    """(worst p99, worst max, {object: (p99, max)}) over compare-all's objects."""
    per = {}
    for name, obj in objects.items():
        r, _ = compare_object(obj, method, RES, variant=variant, log=None, settings=settings)
        per[name] = (r["p99_deg"], r["max_deg"])
    return max(p for p, _ in per.values()), max(m for _, m in per.values()), per


def _wrong(p99, mx):
    return p99 > P99_BAR or mx > MAX_BAR


# Already caught at the defaults: (mutant, method, variant, objects that must catch it).
CAUGHT = [
    (_red_turned, "normal-map", None, None),
    (_resolve_adds, "normal-map", None, None),
    (_facing_away_removed, "normal-map", None, {"Transformed"}),
    (_tangent_bitangent_swapped, "procedural-basis", None, None),
    (_tangent_not_normalised, "procedural-basis", None, {"Sphere", "Torus", "Transformed"}),
    (_weights_not_normalised, "triplanar", None, None),
    (_x_plane_axes_swapped, "triplanar", None, {"Sphere", "Torus", "Transformed"}),
    (_decal_x_flipped, "decal", "box", None),
    (_texel_step_doubled, "height-map", "one-texel", None),
    (_whiteout_from_udn, "blend-whiteout", None, None),
    (_view_xy_turned, "parallax", None, None),
]


@pytest.mark.parametrize("mutant,method,variant,catching", CAUGHT,
                         ids=[c[0].__name__.strip("_") for c in CAUGHT])
def test_a_mutant_compare_all_already_caught_is_called_wrong(monkeypatch, fresh_groups, mutant,
                                                             method, variant, catching):
    mutant(monkeypatch)
    objects = fresh_groups()
    _, _, per = _worst(objects, method, variant)
    for name, (p99, mx) in per.items():
        if catching is None or name in catching:
            assert _wrong(p99, mx), (method, name, p99, mx)


# Finding 1: called right at the defaults, wrong in compare-all's settings case.
BLIND = [
    (_directx_ignored, "normal-map"),
    (_strength_ignored, "normal-map"),
    (_strength_squared, "normal-map"),
    (_directx_ignored, "triplanar"),
    (_directx_ignored, "decal"),
]


@pytest.mark.parametrize("mutant,method", BLIND,
                         ids=[f"{m.__name__.strip('_')}-{k}" for m, k in BLIND])
def test_a_mutant_equal_at_the_defaults_is_called_wrong_in_the_settings_case(
        monkeypatch, fresh_groups, mutant, method):
    """At Strength 1, DirectX off the mutant is the right group (within the bar on every
    object: why compare-all passed it); compare-all's settings case calls it wrong on every
    object, by degrees."""
    mutant(monkeypatch)
    objects = fresh_groups()
    variant = dict((m, v) for m, v, _ in CA.all_cases([method]))[method]
    p99, mx, _ = _worst(objects, method, variant)
    assert not _wrong(p99, mx), (p99, mx)
    settings = CA.SETTINGS_CASES[method]
    _, _, per = _worst(objects, method, variant, settings)
    for name, (p99, mx) in per.items():
        assert p99 > 10 * P99_BAR and mx > MAX_BAR, (name, p99, mx)


@pytest.mark.parametrize("method", sorted(CA.SETTINGS_CASES))
def test_the_correct_groups_pass_compare_alls_settings_cases(fresh_groups, method):
    """The unmutated groups, in every case compare-all runs of the method, within the bars on
    every object (so the settings case reaches both sides alike)."""
    objects = fresh_groups()
    cases = [(v, s) for m, v, s in CA.all_cases([method])]
    assert any(s for _, s in cases) and any(s is None for _, s in cases)
    for variant, settings in cases:
        if settings is None and len(cases) > 2:
            continue                          # the decal's other shapes: compare-all's own
        p99, mx, per = _worst(objects, method, variant, settings)
        assert not _wrong(p99, mx), (variant, settings, per)


def test_settings_reach_the_graph_and_unknown_ones_are_refused(fresh_groups):
    """A DirectX setting turns DirectX on in the bake (with the reference's green turned, the
    pair agrees: above); an unknown setting, or DirectX for a method without the switch
    (object-space normals), is a CompareError naming why."""
    from surfgrad_addon.harness.compare import CompareError
    obj = fresh_groups()["Plane"]
    with pytest.raises(CompareError, match="no setting 'sharpness'.*directx, strength"):
        compare_object(obj, "normal-map", RES, log=None, settings={"sharpness": 2})
    with pytest.raises(CompareError, match="no group with a DirectX switch"):
        compare_object(obj, "object-normal", RES, log=None, settings={"directx": True})
    r, _ = compare_object(obj, "normal-map", RES, log=None, settings={"directx": True})
    assert r["settings"] == {"directx": True} and r["p99_deg"] < P99_BAR
    assert CA._label("normal-map", "hq", {"directx": True, "strength": 0.6}) == \
        "normal-map-directx-strength0.6"
    assert np.isfinite(r["max_deg"]) and r["max_deg"] < MAX_BAR


def test_a_small_object_bakes_the_relief_its_reference_scales(fresh_groups):
    """Coordinator, on merging: compare took the graph before scaling a height map's relief to
    a small object (scale_limits.scaled_relief), so the bake kept the unscaled relief while the
    reference scaled it, and a correct height map on an object under UNIT_HALF was called
    wrong. The graph is now taken from the method as scaled."""
    obj = fresh_groups()["Sphere"]
    obj.scale = (0.3, 0.3, 0.3)
    bpy.context.view_layer.update()
    r, _ = compare_object(obj, "height-map", RES, log=None)
    assert r["p99_deg"] < P99_BAR and r["max_deg"] < MAX_BAR, (r["p99_deg"], r["max_deg"])
