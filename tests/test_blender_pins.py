"""Pins of the numpy reference against real Blender, on every supported line (headless `bpy`,
Cycles CPU bakes).

1. `white_noise_color` equals the White Noise Texture node (3D, Color) bit for bit at integer
   lattice points, negative ones and +-0 included.
2. `sample_image` equals the Image Texture node ('Closest'/'Linear' x 'REPEAT'/'EXTEND') to
   float32 rounding at generic coordinates, and bit for bit for 'Closest' even at EXACT texel
   boundaries: Cycles takes the texel index from `frac()` (kernel/device/cpu/image.h),
   `i = (int)x - (x < 0 ? 1 : 0)` with x = u * width in float32, which is floor(x) except at
   negative integers, where it is floor(x) - 1; the reference uses the same rule.
3. The bake shades texel (i, j) at ((i + 0.501) / W, (j + 0.502) / H), as the reference's
   rasteriser assumes.

Every probe bakes EMIT (Emission strength 1) into a float Non-Color image, 1 sample, margin 0.
Note the bake sample points are texel centres plus (0.001, 0.002) texels (see
support/bake_probe); the expected values below use those points.
"""

import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

pytest.importorskip("bpy")

from support import bake_probe as probe  # noqa: E402
from surfgrad_addon.reference.image_sampling import bake_sample_points, sample_image  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from surfgrad_addon.reference.noise import white_noise_color  # noqa: E402

LINE = facts_for(probe.bpy.app.version)

BAKE = 32                      # bake target is BAKE x BAKE texels
MODES = [(i, e) for i in ("Closest", "Linear") for e in ("REPEAT", "EXTEND")]


def _probe():
    probe.new_scene()
    return probe.EmissionProbe(probe.add_uv_plane())


def _cycles_texel_index(x):
    """Cycles' frac() integer part (kernel/device/cpu/image.h) on float32 x."""
    x = np.asarray(x, dtype=np.float32)
    return np.trunc(x).astype(np.int64) - (x < 0)


def _wrap(i, size, extension):
    return np.mod(i, size) if extension == "REPEAT" else np.clip(i, 0, size - 1)


# --------------------------------------------------------------------------------------------
# The bake itself: where it samples and that it writes float32 values untouched.

def test_bake_samples_texel_centre_plus_blender_offset():
    pr = _probe()
    px = pr.bake(pr.uv.outputs["UV"], BAKE, BAKE)
    centres = probe.texel_centre_uv(BAKE, BAKE).astype(np.float64)
    offset_texels = (px[..., :2] - centres) * BAKE
    # Not the texel centre: +0.001 texel in u, +0.002 texel in v, on every texel.
    assert np.all(np.abs(offset_texels[..., 0] - 0.001) < 2e-5)
    assert np.all(np.abs(offset_texels[..., 1] - 0.002) < 2e-5)
    # ... and to float32 rounding exactly the points bake_sample_uv models (measured 3.4e-8).
    np.testing.assert_allclose(px[..., :2], probe.bake_sample_uv(BAKE, BAKE), rtol=0, atol=1e-7)
    # The reference's rasteriser uses the same points.
    np.testing.assert_allclose(px[..., :2], bake_sample_points(BAKE, BAKE), rtol=0, atol=1e-7)
    assert np.all(px[..., 2] == 0.0)          # the UV output's z
    assert np.all(px[..., 3] == 1.0)          # every texel was covered


@pytest.mark.parametrize("hostile", ["none", "view", "target"])
def test_bake_writes_float32_values_bit_exact(hostile):
    """Closest lookups of a same-size image (texel (i, j) sampled inside texel (i, j)) come back
    bit for bit: negatives, values far above 1, exponents from 1e-37 to 1e37, denormals.
    View transform, look, exposure and gamma do not matter for a float bake on any line. The
    target image's colour space does not matter up to 5.0; 5.2 encodes the result into it
    (LineFacts.bake_applies_target_colorspace), so surfgrad's bakes write Non-Color images.
    The one loss: -0.0 comes back as +0.0 (the render buffer accumulates onto +0.0)."""
    scene = probe.new_scene()
    if hostile == "view":
        scene.view_settings.view_transform = "AgX"
        scene.view_settings.look = "AgX - Punchy"
        scene.view_settings.exposure = 3.0
        scene.view_settings.gamma = 2.2
    pr = probe.EmissionProbe(probe.add_uv_plane())
    n = 16
    rng = np.random.default_rng(7)
    vals = (rng.uniform(-1, 1, (n, n, 3)) * 10.0 ** rng.integers(-37, 38, (n, n, 3)))
    vals = vals.astype(np.float32)
    vals[0, 0] = [1e-40, -1e-42, 2.0 ** -149]          # float32 denormals
    vals[0, 1] = [-0.0, 1.0, -1.0]
    vals[0, 2] = [3.0e37, -7.0, 1.0 / 3.0]
    assert np.all(np.isfinite(np.abs(vals).sum(-1)))    # |R|+|G|+|B| must not overflow
    img = np.ones((n, n, 4), np.float32)
    img[..., :3] = vals
    src = probe.new_float_image("src", n, n, img)
    tex = pr.node("ShaderNodeTexImage", image=src, interpolation="Closest", extension="EXTEND")
    pr.links.new(pr.uv.outputs["UV"], tex.inputs["Vector"])
    expected = vals.copy()
    expected[0, 1, 0] = 0.0                              # -0.0 -> +0.0
    if LINE.line == "4.2":
        # 4.2's Cycles flushes float32 denormals to zero (5 of these values).
        expected[np.abs(expected) < np.finfo(np.float32).tiny] = 0.0
    if hostile == "target":
        target = probe.new_float_image("target", n, n)
        target.colorspace_settings.name = "sRGB"
        pr.links.new(tex.outputs["Color"], pr.emission.inputs["Color"])
        pr.target_node.image = target
        pr.nodes.active = pr.target_node
        assert probe.bpy.ops.object.bake(type="EMIT", margin=0) == {"FINISHED"}
        px = probe.image_pixels(target)[..., :3]
        if LINE.bake_applies_target_colorspace:
            # 5.2: 1.0 stays 1.0 (sRGB's fixed point), 1/3 becomes its sRGB encoding.
            assert px[0, 1, 1] == pytest.approx(1.0, abs=1e-4)
            assert px[0, 2, 2] == pytest.approx(1.055 * (1 / 3) ** (1 / 2.4) - 0.055, abs=2e-3)
            return
    else:
        px = pr.bake(tex.outputs["Color"], n, n)[..., :3]
    assert np.array_equal(px.view(np.uint32), expected.view(np.uint32))
    assert np.signbit(vals[0, 1, 0]) and not np.signbit(px[0, 1, 0])


# --------------------------------------------------------------------------------------------
# Pin 1: White Noise 3D Color on the integer lattice.

@pytest.mark.parametrize("lattice", ["unit", "wide"])
def test_white_noise_color_bit_exact_on_integer_lattice(lattice):
    """Lattice point per texel: (a, b) = floor(uv * 32 + (-16, -13)), so a in [-16, 15],
    b in [-13, 18], all (a, b) distinct; then
      unit: p = (a, b, (a - b) * -1)       z = -0.0 on the diagonal a == b
      wide: p = (a * 1021 + 7, b * -389, a * b + 5)   larger exponents, still exact integers
    built with Vector Math Multiply Add / Floor and Math nodes, fed to White Noise (3D)."""
    pr = _probe()
    mad = pr.vmath("MULTIPLY_ADD", pr.uv.outputs["UV"], (BAKE, BAKE, 0.0))
    mad.node.inputs[2].default_value = (-16.0, -13.0, 0.0)
    a, b, _ = pr.separate(pr.vmath("FLOOR", mad))

    ia = np.arange(BAKE, dtype=np.float32) - 16
    ib = np.arange(BAKE, dtype=np.float32) - 13
    A, B = np.meshgrid(ia, ib)                     # (row j = b, column i = a)
    if lattice == "unit":
        vec = pr.combine(a, b, pr.math("MULTIPLY", pr.math("SUBTRACT", a, b), -1.0))
        p = np.stack([A, B, (A - B) * np.float32(-1)], -1)
    else:
        x = pr.math("ADD", pr.math("MULTIPLY", a, 1021.0), 7.0)
        y = pr.math("MULTIPLY", b, -389.0)
        z = pr.math("ADD", pr.math("MULTIPLY", a, b), 5.0)
        vec = pr.combine(x, y, z)
        p = np.stack([A * np.float32(1021) + np.float32(7), B * np.float32(-389),
                      A * B + np.float32(5)], -1)
    noise = pr.node("ShaderNodeTexWhiteNoise", noise_dimensions="3D")
    pr.links.new(vec, noise.inputs["Vector"])
    px = pr.bake(noise.outputs["Color"], BAKE, BAKE)

    # The probe design: every bake sample sits mid-cell, so the floors are unambiguous.
    cell = probe.bake_sample_uv(BAKE, BAKE) * BAKE
    assert np.all(np.abs(cell - np.floor(cell) - 0.5) < 0.01)
    assert len({(x, y) for x, y in zip(A.ravel(), B.ravel())}) == BAKE * BAKE
    assert (p < 0).any(axis=(0, 1)).all() and (p > 0).any(axis=(0, 1)).all()
    assert (p == 0).any()

    expected = white_noise_color(p)
    assert expected.dtype == np.float32
    assert np.array_equal(px[..., :3], expected), (
        f"{np.count_nonzero(px[..., :3] != expected)} of {expected.size} channels differ")
    assert np.all(px[..., 3] == 1.0)
    if lattice == "unit":
        # The sign of zero reaches the hash: at z = -0.0 the +0.0 hash would be wrong.
        neg_zero = (p[..., 2] == 0) & np.signbit(p[..., 2])
        assert neg_zero.sum() == 29
        p_pos = p.copy()
        p_pos[..., 2][neg_zero] = 0.0
        assert not np.any(np.all(white_noise_color(p_pos)[neg_zero] == px[..., :3][neg_zero],
                                 axis=-1))


# --------------------------------------------------------------------------------------------
# Pin 2: Image Texture sampling.

def _bake_image_texture(pr, image, coords_socket, interpolation, extension):
    h, w = image.shape[:2]
    src = probe.new_float_image("src", w, h, image)
    tex = pr.node("ShaderNodeTexImage", image=src, interpolation=interpolation,
                  extension=extension)
    pr.links.new(coords_socket, tex.inputs["Vector"])
    return pr.bake(tex.outputs["Color"], BAKE, BAKE)


def _random_image(w, h, seed):
    rng = np.random.default_rng(seed)
    img = np.ones((h, w, 4), np.float32)         # alpha 1 (RGB is what is compared)
    img[..., :3] = rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    return img


SCALE = (2.7, 2.3)           # st = uv * SCALE + SHIFT spans [-0.79, 1.87] x [-0.58, 1.69]
SHIFT = (-0.83, -0.61)


@pytest.mark.parametrize("interpolation,extension", MODES)
def test_image_texture_matches_sample_image(interpolation, extension):
    """A 5 x 4 float image, sampled through an affine map of the bake UV that leaves [0, 1] on
    both sides in both axes. Closest: bit exact. Linear: within 2e-6 (measured ~6e-7, from the
    float32 UV interpolation of the bake and float32 arithmetic in Cycles)."""
    w, h = 5, 4
    img = _random_image(w, h, seed=3)
    pr = _probe()
    st_socket = pr.vmath("MULTIPLY_ADD", pr.uv.outputs["UV"], (*SCALE, 1.0))
    st_socket.node.inputs[2].default_value = (*SHIFT, 0.0)
    px = _bake_image_texture(pr, img, st_socket, interpolation, extension)

    st = probe.bake_sample_uv(BAKE, BAKE) * np.array(SCALE) + np.array(SHIFT)
    assert st[..., 0].min() < -0.5 and st[..., 0].max() > 1.5
    assert st[..., 1].min() < -0.5 and st[..., 1].max() > 1.5
    texel = st * np.array([w, h])
    # Probe design: no sample within 1e-3 texel of a Closest boundary (Cycles' float32 st is
    # off by ~1e-6 texel), so Closest is compared where floor() is unambiguous.
    assert np.min(np.abs(texel - np.round(texel))) > 1e-3

    expected = sample_image(img[..., :3].astype(np.float64), st, interpolation, extension)
    got = px[..., :3].astype(np.float64)
    if interpolation == "Closest":
        assert np.array_equal(got, expected)
    else:
        err = np.max(np.abs(got - expected))
        assert err < 2e-6, err
    # REPEAT and EXTEND really differ on this probe (it leaves the unit square).
    other = "EXTEND" if extension == "REPEAT" else "REPEAT"
    alt = sample_image(img[..., :3].astype(np.float64), st, interpolation, other)
    assert np.mean(np.any(np.abs(alt - expected) > 1e-3, axis=-1)) > 0.3
    # Baking at the nominal texel centres instead would be visibly off for Linear
    # (~1e-3 here): the (0.001, 0.002) texel bake offset is not negligible.
    if interpolation == "Linear":
        centred = probe.texel_centre_uv(BAKE, BAKE) * np.array(SCALE) + np.array(SHIFT)
        off = sample_image(img[..., :3].astype(np.float64), centred, interpolation, extension)
        assert np.max(np.abs(got - off)) > 1e-4


def _exact_boundary_probe(interpolation, extension):
    """A 4 x 4 image sampled at st = floor(uv * 32 + (-16, -13)) / 8: every u * 4 and v * 4 is
    an exact multiple of 1/2 in float32, from -8 to 7.5 (u) and -6.5 to 9 (v), so half of the
    samples sit exactly on texel boundaries (integers), many of them negative."""
    w = h = 4
    img = _random_image(w, h, seed=11)
    pr = _probe()
    mad = pr.vmath("MULTIPLY_ADD", pr.uv.outputs["UV"], (BAKE, BAKE, 0.0))
    mad.node.inputs[2].default_value = (-16.0, -13.0, 0.0)
    st_socket = pr.vmath("MULTIPLY", pr.vmath("FLOOR", mad), (0.125, 0.125, 0.0))
    px = _bake_image_texture(pr, img, st_socket, interpolation, extension)
    a, b = np.meshgrid(np.arange(BAKE) - 16.0, np.arange(BAKE) - 13.0)
    st = np.stack([a / 8, b / 8], -1)
    return img, st, px[..., :3]


@pytest.mark.parametrize("extension", ["REPEAT", "EXTEND"])
def test_closest_texel_index_is_cycles_frac_rule_on_exact_boundaries(extension):
    """Cycles' Closest texel index is (int)x - (x < 0) with x = u * width (float32), then
    wrapped (REPEAT: mod) or clamped (EXTEND): at negative integer x that is floor(x) - 1."""
    img, st, got = _exact_boundary_probe("Closest", extension)
    x = st * 4
    assert np.all(x == np.round(2 * x) / 2)
    neg_int = (x < 0) & (x == np.round(x))
    assert neg_int[..., 0].sum() == 8 * BAKE and neg_int[..., 1].sum() == 6 * BAKE
    ix = _wrap(_cycles_texel_index(x[..., 0]), 4, extension)
    iy = _wrap(_cycles_texel_index(x[..., 1]), 4, extension)
    assert np.array_equal(got, img[iy, ix, :3])
    # The rule differs from floor() exactly at the negative integers (and the texels there
    # differ, so the probe can tell): under REPEAT that changes the texel; EXTEND clamps both
    # to texel 0, so there floor() gives the same answer.
    fx = _wrap(np.floor(x[..., 0]).astype(np.int64), 4, extension)
    fy = _wrap(np.floor(x[..., 1]).astype(np.int64), 4, extension)
    changed = (fx != ix) | (fy != iy)
    if extension == "REPEAT":
        assert np.array_equal(changed, neg_int.any(axis=-1))
        assert np.all(np.any(got[changed] != img[fy, fx, :3][changed], axis=-1))
    else:
        assert not changed.any()


@pytest.mark.parametrize("extension", ["REPEAT", "EXTEND"])
def test_reference_closest_matches_blender_on_exact_boundaries(extension):
    """The reference's Closest lookup uses Cycles' integer-part rule, so it matches the bake
    bit for bit even exactly on (negative) texel boundaries."""
    img, st, got = _exact_boundary_probe("Closest", extension)
    expected = sample_image(img[..., :3].astype(np.float64), st, "Closest", extension)
    assert np.array_equal(got, expected), (
        f"{np.count_nonzero(np.any(got != expected, axis=-1))} texels differ")


@pytest.mark.parametrize("extension", ["REPEAT", "EXTEND"])
def test_linear_matches_sample_image_on_exact_boundaries(extension):
    """Linear at exact half-texel positions: where u * width - 0.5 is a negative integer Cycles
    has index floor - 1 with weight t = 1.0, which is the same lookup; agreement to rounding."""
    img, st, got = _exact_boundary_probe("Linear", extension)
    expected = sample_image(img[..., :3].astype(np.float64), st, "Linear", extension)
    err = np.max(np.abs(got - expected))
    assert err < 1e-6, err
