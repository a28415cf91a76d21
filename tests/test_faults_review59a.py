"""Red team 59a: a skeptical review of round 58's merges (e167291..c1fadb3: the asset list
read before Blender, bpy that will not load, compare's settings checks, the noise reach
limit's Scale rule, the decal PROJECTOR_OFFSET, Freeze's empty slots, 4.x's cut names).

1. Triplanar Sharpness past the group's float32 range (3ebd285 made it a compare setting;
   checked_value asked float sockets only for finiteness). Listing 14's weights are
   (|n| - 0.2)^k; where no axis dominates (|n| components about 0.58, the base about 0.38)
   they underflow float32 for k past about 80-90 (0.377^100 is 0 in float32, 4e-43 in
   float64), the group's blend then 0 / 0 (its divide floor), the reference's the proper
   normalised weights. Sweep at 32^2, p99 / max deg, the correct groups: triplanar Sharpness
   64 and 72: 0.0018 / 0.0045 worst; 80: Transformed 0.08 / 58.9; 90: Torus 0.004 / 58.7,
   Transformed 40.0 / 64.6; 100: Sphere 21.6, Torus 42.0, Transformed 52.0 p99;
   triplanar-height 90-100: 9.0-19.8 p99; 1000: 72-74 p99. A negative k divides by the zero
   weights: -0.5 and -1 gave 62.9-68.3 p99 (triplanar), 21.7-22.8 (triplanar-height). compare
   called each correct group wrong. Now a CompareError (compare_settings.HONOURED_RANGES:
   Sharpness 0 to 64) naming the range and the fix, before any bake. 0, 0.5 and 1e-30 agree
   (0.0010-0.0018 p99): still compared; 1e6 agrees trivially (every weight 0 in both) and is
   refused with the rest past 64.
2. The noise reach limit's Scale rule (c819ad1) took the asked Scale as it came: a negative
   Scale (the noise mirrored, its frequency the same) made Scale x 2^(Octaves-1) negative,
   "not top > 0" returned no limit at all (meant for Scale 0). The 100 m sphere at Scale -16
   was compared and the correct volume-noise group called wrong: p99 0.125, max 0.20 deg (bar
   0.1; Scale +16 is refused since c819ad1, limit 62.5 m). Now |Scale|
   (scale_limits.noise_reach_limit): refused as at +16, naming 62.5 m.
3. displace-bump kept its measured 2000 m reach limit at every Scale (ca7fde8: "agrees far
   past" volume-noise's rule, measured on unit objects only). Its error grows with the reach
   and the Scale too (5.2, 32^2, the sphere's mesh scaled out, limit lifted): 100 m at Scale
   100 p99 0.497 / max 0.677 deg, 30 m at 100 0.103, 10 m at Scale 100 Octaves 4 0.148 / 0.42,
   60 m at Scale 40 Octaves 4 0.189: the correct group called wrong. About 3e-7 deg p99 per
   metre of reach times Scale^2 x 2^(Octaves - 1) (SG Noise halves each octave's amplitude).
   Now the limit shrinks by that curvature against the default's (Scale 8, Octaves 2):
   12.8 m at Scale 100, 3.2 m at Scale 100 Octaves 4, 20 m at 40 Octaves 4; just inside
   (12 m, 3 m, 16 m) 0.046-0.054 p99. The unit objects at Scale 100 Octaves 4 (58c's test)
   stay compared.
4. The decal projector (ece1fb9, 2fc1944) was sized by the object's largest dimension on
   all three axes: on a long or flat object the shapes' boundaries that PROJECTOR_OFFSET puts
   on the unit objects fell off the surface again, and a group missing them was called right.
   Mutants of test_faults_mutants58b, p99 / max deg, a Sphere stretched 20 x 1 x 1 (rod),
   flattened to 1 x 1 x 0.01 (disc) and the Plane stretched to 50 x 0.02 (strip): the wedge
   without its open end 0.000 / 0.00 on rod and strip; the depth fade dropped 0.000 on all
   three; the capsule twice as long 0.000 on rod and strip, 0.016 / 0.09 on the disc. Now
   each axis of the projector is the object's reach along it (method_scene._reach_along,
   about the same tilt and offset; the unit Sphere's projector as it was): wedge 58.0 /
   82.8 / 66.3 deg p99 on rod / strip / disc, depth fade 55.6 / 31.6 / 42.8, capsule 20.6 on
   the rod, 3.8 on the disc (the strip, a line in the projector, still 0.001). The correct
   six shapes on the objects listed below (Probed), with the new projector: 0.0001-0.0009
   p99, 0.0022 max.
   test_faults_mutants58b's "old harness" now also sizes the projector as before.

Probed and right (5.2): bake-batch's asset list before Blender, with and without bpy: an
empty list, a UTF-16 list, 3 kB of random bytes, a folder, a missing file each exit 2 with
the list named and the fix, on a Python without bpy too (before the no-bpy line); a BOM/CRLF
list with a comment, blank line and an entry with spaces, and a '~' entry, read and passed
on (no-bpy line without bpy; the output pattern's refusal with it); compare-all, bake-batch
without bpy: the no-bpy line, exit 2. The correct decal groups (six shapes) on the Sphere
flattened to 1%, stretched 20x, scaled 0.01, moved to (5000, -3000, 200), mirrored (scale
-1, 1, 1), the Torus rotated and scaled (1, 1, -2), the Plane stretched to 50 x 0.02, with
the projector as it was: 0.0001-0.0006 p99, 0.0012 max; a Torus with a 5-copy Array
modifier: 0.0001 p99, the wedge mutant 56.2. Sharpness 0, 0.5, 1e-30: agree; a triplanar
bake at Sharpness -1 and 200 writes a finite map. 4.2 and 4.5: copies of per-UV-map groups
whose UV map names are multi-byte (e, EUR, emoji, CJK; group names 60-63 bytes, Blender's
cut at a character) are surfgrad's and Update rebuilds them (8 of 8 names, both lines).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import scale_limits  # noqa: E402
from surfgrad_addon.harness import scenes  # noqa: E402
from surfgrad_addon.harness.compare import CompareError, compare_object  # noqa: E402
from support.small_objects import scaled_test_object  # noqa: E402

pytestmark = pytest.mark.tier("bake")

P99_BAR, MAX_BAR = 0.1, 0.5
RES = 32


@pytest.fixture(scope="module")
def objects():
    objs = scenes.new_scene(["Torus", "Transformed"])
    yield objs
    bpy.ops.wm.read_factory_settings(use_empty=True)


def test_listing_14s_weights_underflow_float32_past_the_range():
    """The fact behind finding 1, independent of the product: at a diagonal normal's base
    (1/sqrt(3) - 0.2) the weight is a normal float32 at k 64, zero at k 100 (float64 keeps
    it), so normalising them is 0 / 0 in the bake alone."""
    base = 1.0 / np.sqrt(3.0) - 0.2
    assert np.float32(base) ** np.float32(64) > np.finfo(np.float32).tiny
    assert np.float32(base) ** np.float32(100) < np.finfo(np.float32).tiny
    assert base ** 100.0 > 1e-45


@pytest.mark.parametrize("method", ["triplanar", "triplanar-height"])
@pytest.mark.parametrize("sharpness", [100.0, 90.0, -0.5])
def test_sharpness_past_the_groups_float32_range_is_refused(objects, method, sharpness):
    """Before: compared, the correct group 9-68 deg p99 wrong on Torus or Transformed. Now
    refused naming the setting and 0 to 64."""
    with pytest.raises(CompareError, match=r"'sharpness' \(Sharpness\) is compared from 0 "
                                           r"to 64"):
        compare_object(objects["Transformed"], method, RES, log=None,
                       settings={"sharpness": sharpness})


@pytest.mark.parametrize("sharpness", [0.0, 0.5, 64.0])
def test_sharpness_within_the_range_is_still_compared_and_agrees(objects, sharpness):
    """The range refuses nothing the group honours: 0 (equal weights), 0.5 and 64."""
    for name in ("Torus", "Transformed"):
        r, _ = compare_object(objects[name], "triplanar", RES, log=None,
                              settings={"sharpness": sharpness})
        assert r["p99_deg"] <= P99_BAR and r["max_deg"] <= MAX_BAR, (name, sharpness, r)


def test_a_negative_noise_scale_has_the_reach_limit_of_its_size(objects):
    """Before: no limit at Scale -16, the 100 m sphere compared and called 0.125 deg p99
    wrong. Now the limit of |Scale|: 1000 m x (4 / 16)^2 = 62.5 m, refused as at +16."""
    assert scale_limits.noise_reach_limit("volume-noise", {"scale": -16.0}) == \
        pytest.approx(1000.0 * (4.0 / 16.0) ** 2)
    assert scale_limits.noise_reach_limit("volume-noise", {"scale": -4.0}) == 1000.0
    import mathutils
    obj = scaled_test_object("Sphere", 1.0)
    obj.data.transform(mathutils.Matrix.Scale(100.0 / scale_limits.object_reach(obj), 4))
    bpy.context.view_layer.update()
    with pytest.raises(CompareError, match=r"beyond 62\.5 m at Scale -16, Octaves 4"):
        compare_object(obj, "volume-noise", RES, log=None, settings={"scale": -16.0})


def _sphere_reaching(reach):
    """The test sphere with its mesh scaled about its origin to reach `reach` metres."""
    import mathutils
    obj = scaled_test_object("Sphere", 1.0)
    obj.data.transform(mathutils.Matrix.Scale(reach / scale_limits.object_reach(obj), 4))
    bpy.context.view_layer.update()
    return obj


def test_displace_bumps_reach_limit_follows_its_scale(objects):
    """Before: 2000 m at every Scale; a 100 m sphere at Scale 100 was compared and the correct
    group called 0.50 deg p99 wrong. Now 2000 m x (8^2 x 2) / (100^2 x 2) = 12.8 m there
    (Scale^2 x 2^(Octaves - 1) against the default Scale 8, Octaves 2): refused naming it;
    a 12 m sphere is compared within the bars."""
    from surfgrad_addon.harness.methods import unavailable_reason
    if unavailable_reason("displace-bump"):
        pytest.skip(unavailable_reason("displace-bump"))
    settings = {"scale": 100.0}
    assert scale_limits.noise_reach_limit("displace-bump", settings) == \
        pytest.approx(2000.0 * (8.0 ** 2 * 2) / (100.0 ** 2 * 2))
    assert scale_limits.noise_reach_limit("displace-bump", {"scale": 100.0, "octaves": 4}) \
        == pytest.approx(2000.0 * (8.0 ** 2 * 2) / (100.0 ** 2 * 8))
    with pytest.raises(CompareError, match=r"beyond 12\.8 m at Scale 100, Octaves 2"):
        compare_object(_sphere_reaching(100.0), "displace-bump", RES, log=None,
                       settings=settings)
    r, _ = compare_object(_sphere_reaching(12.0), "displace-bump", RES, log=None,
                          settings=settings)
    assert r["p99_deg"] <= P99_BAR and r["max_deg"] <= MAX_BAR, r


# Finding 4: the decal projector on long and flat objects ------------------------------------

def _reshaped(name, diagonal, label):
    """compare-all's `name` in a new scene, with its mesh scaled by `diagonal` (x, y, z)."""
    import mathutils
    src = scenes.new_scene([name])[name]
    obj = src.copy()
    obj.data = src.data.copy()
    obj.name = label
    bpy.context.scene.collection.objects.link(obj)
    obj.data.transform(mathutils.Matrix.Diagonal((*diagonal, 1.0)))
    bpy.context.view_layer.update()
    return obj


def _projector_q(obj):
    """obj's vertices in the coordinates of the projector compare makes for it."""
    from surfgrad_addon.harness import method_scene as MS
    projector = MS.decal_projector(obj)
    try:
        to_q = np.linalg.inv(np.array(projector.matrix_world)) @ np.array(obj.matrix_world)
        v = np.array([(*p.co, 1.0) for p in obj.data.vertices]) @ to_q.T
        return v[:, :3]
    finally:
        bpy.data.objects.remove(projector)


@pytest.mark.parametrize("label,name,diagonal", [("Rod", "Torus", (8.0, 0.5, 0.5)),
                                                  ("Disc", "Torus", (1.0, 1.0, 0.02))])
def test_every_shapes_boundary_lies_on_a_long_or_flat_object(label, name, diagonal):
    """Each decal shape's boundaries as q-coordinates, independent of the groups: the wedge
    open end y = -1 and the depth fade's |z| = 1 (cylinder, box, cone, wedge) each crossed by
    the surface. Before (the object's largest size on every axis) the Torus stretched 8 x
    0.5 x 0.5 reached q.y -0.52 to -0.38 and |q.z| 0.64 at most: neither crossed; the Torus
    flattened to 2% |q.z| 0.80 at most. Now q.y -1.50 to 0.60, |q.z| up to 1.18 on both."""
    q = _projector_q(_reshaped(name, diagonal, label))
    assert q[:, 1].min() < -1.0 < q[:, 1].max(), (label, q[:, 1].min(), q[:, 1].max())
    assert np.abs(q[:, 2]).max() > 1.0 > np.abs(q[:, 2]).min(), label
    assert (np.abs(q).max(axis=1) < 1.0).any(), label        # and texels inside it


def test_a_group_without_the_wedges_open_end_is_called_wrong_on_a_rod(monkeypatch):
    """The wedge mutant of test_faults_mutants58b (the y > -1 cut dropped) on a rod: before,
    0.000 deg p99 (called right); now 62.6 / 76.4. The correct wedge group within the bars
    there (0.0003 p99)."""
    import test_faults_mutants58b as M58
    rod = _reshaped("Torus", (8.0, 0.5, 0.5), "Rod2")
    r, _ = compare_object(rod, "decal", RES, variant="wedge", log=None)
    assert r["p99_deg"] <= P99_BAR and r["max_deg"] <= MAX_BAR, r
    M58._wedge_open_end(monkeypatch)
    rod = _reshaped("Torus", (8.0, 0.5, 0.5), "Rod3")      # (its groups built anew)
    r, _ = compare_object(rod, "decal", RES, variant="wedge", log=None)
    assert r["p99_deg"] > 10 * P99_BAR and r["max_deg"] > MAX_BAR, r
