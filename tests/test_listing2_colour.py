"""SG Normal Map's Listing 2 colour (common.listing2_colour), baked by Cycles on every line,
against float32 arithmetic in numpy: red and green pass as they are (green flipped to 1 - g
with DirectX on), and blue is max(|b - 0.5| + 0.5, max(|r - 0.5|, |g - 0.5|) / 128 + 0.5 +
2^-23), each rounded once, bit for bit; the Normal Map node's decode 2 (c - 0.5) of it is
Listing 2's m with z clamped (TSPACE_Z_CLAMP) over NODE_Z_FLOOR, so never zero: a mid-grey
texel decodes to (0, 0, 2^-22), the shading normal, on every line."""

import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

pytest.importorskip("bpy")

from support import bake_probe as probe  # noqa: E402
from surfgrad_addon.addon.groups import common as C  # noqa: E402
from surfgrad_addon.reference.vecmath import NODE_Z_FLOOR, TSPACE_Z_CLAMP  # noqa: E402

SIZE = 16


def _colours():
    """SIZE x SIZE colours: random in [0, 1] (every mantissa bit used), with a band where the
    1/128 clamp decides blue (b = 0.5 +- a little) and one with b < 0.25 (z < -0.5)."""
    rng = np.random.default_rng(21)
    c = rng.random((SIZE, SIZE, 3), dtype=np.float32)
    c[:4, :, 2] = np.float32(0.5) + rng.uniform(-1e-3, 1e-3, (4, SIZE)).astype(np.float32)
    c[4:6, :, 2] = rng.uniform(0.0, 0.25, (2, SIZE)).astype(np.float32)
    c[6, :4] = 0.5                                          # mid-grey: m = 0
    rgba = np.concatenate([c, np.ones((SIZE, SIZE, 1), np.float32)], axis=-1)
    return rgba


def _bake(rgba, directx):
    probe.new_scene()
    pr = probe.EmissionProbe(probe.add_uv_plane())
    img = probe.new_float_image("Listing2Colours", SIZE, SIZE, rgba)
    tex = pr.node("ShaderNodeTexImage", image=img, interpolation="Closest", extension="EXTEND")
    pr.link(pr.uv.outputs["UV"], tex.inputs["Vector"])
    switch = None
    if directx is not None:
        value = pr.node("ShaderNodeValue")
        value.outputs[0].default_value = float(directx)
        switch = value.outputs[0]
    return pr.bake(C.listing2_colour(pr, tex.outputs["Color"], switch), SIZE, SIZE)[..., :3]


def _expected(c, directx):
    f = np.float32
    a = np.abs(c - f(0.5))                                  # exact for c in [0.25, 1]
    m = np.maximum(a[..., 0], a[..., 1])
    blue = np.maximum(a[..., 2] + f(0.5), m * f(TSPACE_Z_CLAMP) + f(0.5 + NODE_Z_FLOOR / 2))
    green = f(1.0) - c[..., 1] if directx else c[..., 1]
    return np.stack([c[..., 0], green, blue], axis=-1), a, m


@pytest.mark.parametrize("directx", [None, 0, 1])
def test_listing2_colour_is_float32_listing2(directx):
    rgba = _colours()
    got = _bake(rgba, directx)
    want, a, m = _expected(rgba[..., :3], directx)
    assert got.dtype == np.float32 and np.array_equal(got, want), \
        np.argwhere(got != want)[:5]
    f = np.float32
    # The decoded z is Listing 2's clamp over the floor: mid-grey gives (0, 0, 2^-22).
    z = np.float64(2) * (want[..., 2].astype(np.float64) - 0.5)
    assert (z >= NODE_Z_FLOOR).all() and (z[6, :4] == NODE_Z_FLOOR).all()
    # Where |dz| decides, blue is the centred form 0.5 + max(|dz|, M / 128), rounded once.
    by_z = a[..., 2] >= m * f(TSPACE_Z_CLAMP) + f(NODE_Z_FLOOR)
    assert np.array_equal(want[..., 2][by_z], (a[..., 2] + f(0.5))[by_z])
    # The clamp decides blue in the band near b = 0.5, and |dz| below 0.25 is mirrored.
    clamped = a[..., 2] < m * f(TSPACE_Z_CLAMP)
    assert clamped[:4].mean() > 0.5 and clamped[6:].mean() < 0.1
    assert (want[4:6, :, 2] > 0.75).all()
