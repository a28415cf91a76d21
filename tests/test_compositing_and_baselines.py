"""Table 1 / Eq. 18 compositing, post-resolve, Gustavson's Eq. 3-8 and the baselines."""

import numpy as np
import pytest

import surfgrad_addon.reference as R

pytestmark = pytest.mark.tier("numpy")


N = 1000


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.fixture
def tnormals():
    rng = np.random.default_rng(5)
    a = unit(rng.normal(size=(N, 3)) * [0.5, 0.5, 0.3] + [0, 0, 1])
    b = unit(rng.normal(size=(N, 3)) * [0.5, 0.5, 0.3] + [0, 0, 1])
    return a, b


def test_classic_blends_hand_values():
    a = np.array([0.6, 0.0, 0.8])
    b = np.array([0.0, 0.6, 0.8])
    np.testing.assert_allclose(R.blend_udn(a, b), unit(np.array([0.6, 0.6, 0.8])))
    np.testing.assert_allclose(R.blend_whiteout(a, b), unit(np.array([0.6, 0.6, 0.64])))
    # PD adds derivatives: (-0.75, 0) + (0, -0.75) -> normal (0.75, 0.75, 1).
    np.testing.assert_allclose(R.blend_pd(a, b), unit(np.array([0.75, 0.75, 1.0])))
    z = np.array([0, 0, 1.0])
    np.testing.assert_allclose(R.blend_rnm(z, b), b, atol=1e-15)     # flat base: b unchanged
    np.testing.assert_allclose(R.blend_rnm(a, z), a, atol=1e-15)     # flat detail: a unchanged


def test_rnm_rotates_detail_by_the_base_rotation(tnormals):
    """RNM applies to b the rotation that takes (0,0,1) to a (shortest arc)."""
    a, b = tnormals
    z = np.array([0, 0, 1.0])
    axis = np.cross(z, a)
    s = np.linalg.norm(axis, axis=-1, keepdims=True)
    c = a[:, 2:3]
    k = axis / s
    # Rodrigues' formula.
    rot_b = b * c + np.cross(k, b) * s + k * np.sum(k * b, -1, keepdims=True) * (1 - c)
    np.testing.assert_allclose(R.blend_rnm(a, b), rot_b, atol=1e-12)


@pytest.mark.parametrize("method,classic", [("pd", R.blend_pd), ("whiteout", R.blend_whiteout),
                                            ("udn", R.blend_udn)])
def test_surface_gradient_forms_equal_classic_on_one_unwrap(tnormals, method, classic):
    """Table 1: with both maps on the same orthonormal frame, the SG form resolves to the
    classic blend, on any surface orientation."""
    a, b = tnormals
    rng = np.random.default_rng(9)
    n = unit(rng.normal(size=(N, 3)))
    t = unit(np.cross(n, rng.normal(size=(N, 3))))
    bt = np.cross(n, t)
    sg = R.surfgrad_blend(method, a, t, bt, b, t, bt)
    out = R.resolve_normal_from_surface_gradient(n, sg)
    m = classic(a, b)
    expect = unit(t * m[:, :1] + bt * m[:, 1:2] + n * m[:, 2:])
    np.testing.assert_allclose(out, expect, atol=1e-12)
    rnm = R.resolve_normal_from_surface_gradient(n, R.surfgrad_blend_rnm(a, b, t, bt))
    m = R.blend_rnm(a, b)
    # Strong tilts can rotate b below the tangent plane; Listing 2 folds those (abs z).
    front = m[:, 2] > 0.01
    assert front.mean() > 0.9
    np.testing.assert_allclose(rnm[front], unit(t * m[:, :1] + bt * m[:, 1:2] + n * m[:, 2:])[front],
                               atol=1e-12)
    with pytest.raises(ValueError, match="unknown Table 1 method"):
        R.surfgrad_blend("overlay", a, t, bt, b, t, bt)


def test_post_resolve_uses_the_resolved_normal_as_new_base():
    rng = np.random.default_rng(2)
    n = unit(rng.normal(size=(N, 3)))
    g1 = rng.normal(size=(N, 3)) * 0.3
    g1 -= np.sum(g1 * n, -1, keepdims=True) * n
    vol = rng.normal(size=(N, 3)) * 0.3
    seen = {}

    def second(n1):
        seen["n1"] = n1
        return R.surfgrad_from_volume_gradient(n1, vol)
    out = R.post_resolve_bump(n, g1, second)
    n1 = unit(n - g1)
    np.testing.assert_allclose(seen["n1"], n1, atol=1e-14)
    g2 = vol - np.sum(vol * n1, -1, keepdims=True) * n1
    np.testing.assert_allclose(out, unit(n1 - g2), atol=1e-14)
    # A zero second pass leaves the first resolve.
    np.testing.assert_allclose(R.post_resolve_bump(n, g1, lambda m: 0 * m), n1, atol=1e-14)


def test_gustavson_displaced_normal_is_exact_on_a_plane():
    """Eq. 4-8 on a plane z = 0 displaced to z = a h(x, y): the true normal of the height
    field is (-a h_x, -a h_y, 1) normalised."""
    rng = np.random.default_rng(4)
    p = np.c_[rng.uniform(-3, 3, (N, 2)), np.zeros(N)]
    n0 = np.tile([0, 0, 1.0], (N, 1))
    h, g = R.fractal_sum(p, octaves=3)
    amount = 0.35
    disp = R.displace_along_normal(p, n0, h, amount)
    np.testing.assert_allclose(disp[:, 2], amount * h)
    np.testing.assert_allclose(disp[:, :2], p[:, :2])
    true = unit(np.c_[-amount * g[:, 0], -amount * g[:, 1], np.ones(N)])
    np.testing.assert_allclose(R.displaced_normal(n0, g, amount), true, atol=1e-14)


def test_gustavson_bump_approaches_true_displacement_on_a_sphere_as_amplitude_shrinks():
    """On a curved surface Eq. 4-8 is Blinn's approximation: the error against the normal of
    the really displaced sphere (by finite differences of the displaced parameterisation)
    falls as the amplitude shrinks relative to the radius."""
    th, ph = np.meshgrid(np.linspace(0.4, 2.7, 30), np.linspace(0, 6, 30))
    def sphere(th, ph):
        return np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    errs = []
    for amount in (0.2, 0.05, 0.0125):
        def surf(th, ph):
            p0 = sphere(th, ph)
            return R.displace_along_normal(p0, p0, R.gradient_noise(p0 * 3)[0], amount)
        e = 1e-6
        d_th = (surf(th + e, ph) - surf(th - e, ph)) / (2 * e)
        d_ph = (surf(th, ph + e) - surf(th, ph - e)) / (2 * e)
        true = unit(np.cross(d_th, d_ph))
        p0 = sphere(th, ph)
        _, g = R.gradient_noise(p0 * 3)
        bump = R.displaced_normal(p0, 3 * g, amount)
        errs.append(np.degrees(np.arccos(np.clip(np.sum(true * bump, -1), -1, 1))).max())
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 0.5


def test_perlin_baseline_differs_from_surface_gradient_only_off_the_tangent_plane():
    rng = np.random.default_rng(8)
    n = unit(rng.normal(size=(N, 3)))
    g_t = rng.normal(size=(N, 3))
    g_t -= np.sum(g_t * n, -1, keepdims=True) * n
    sg = R.resolve_normal_from_surface_gradient(n, R.surfgrad_from_volume_gradient(n, g_t))
    np.testing.assert_allclose(R.perturb_normal_perlin1985(n, g_t), sg, atol=1e-14)
    # A gradient along n changes nothing for SG, but tilts Perlin's toward -n.
    g = g_t + 3.0 * n
    sg2 = R.resolve_normal_from_surface_gradient(n, R.surfgrad_from_volume_gradient(n, g))
    np.testing.assert_allclose(sg2, sg, atol=1e-14)
    perlin = R.perturb_normal_perlin1985(n, g)
    assert np.all(np.sum(perlin * n, -1) < 0)      # pulled under the surface


def test_geiss_triplanar_flattens_steep_slopes():
    n = np.array([[0, 0, 1.0]])
    w = R.determine_triplanar_weights(n)
    m = unit(np.array([[0.9, 0.0, 0.1]]))           # a near-vertical hemisphere edge
    zero = np.zeros((1, 3))
    geiss = R.triplanar_geiss(n, w, zero, zero, m)
    sg = R.resolve_normal_from_surface_gradient(n, R.surfgrad_from_triplanar_projection(
        n, w, np.zeros((1, 2)), np.zeros((1, 2)), R.tspace_normal_to_derivative(m)))
    np.testing.assert_allclose(sg, m, atol=1e-12)   # SG reproduces the map's normal
    tilt = np.degrees(np.arccos(geiss[0, 2]))
    assert tilt < 45                                # Geiss caps the slope at 45 degrees
    np.testing.assert_allclose(R.triplanar_derivative_perlin(
        n, w, np.zeros((1, 2)), np.zeros((1, 2)), R.tspace_normal_to_derivative(m)), sg,
        atol=1e-12)                                 # identical while n is a projection axis


def test_lxengine_bump_ignores_derivative_lengths():
    """The blog's method gives the right normal for an isometric screen mapping on a flat
    surface, but the same normal when dP/dx, dP/dy are scaled: it is scale-blind, while
    Listing 6 divides by the true lengths."""
    n = np.array([[0, 0, 1.0]])
    dpdx, dpdy = np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]])
    dh = np.array([0.3]), np.array([-0.2])
    lx = R.bump_screen_derivative_lxengine(n, dpdx, dpdy, *dh)
    sg = R.resolve_normal_from_surface_gradient(n, R.surfgrad_scale_dependent(
        n, dpdx, dpdy, np.stack(dh, -1), None, None, None, is_deriv_screen_space=True))
    np.testing.assert_allclose(lx, sg, atol=1e-15)
    lx2 = R.bump_screen_derivative_lxengine(n, 4 * dpdx, 4 * dpdy, *dh)
    sg2 = R.resolve_normal_from_surface_gradient(n, R.surfgrad_scale_dependent(
        n, 4 * dpdx, 4 * dpdy, np.stack(dh, -1), None, None, None, is_deriv_screen_space=True))
    np.testing.assert_allclose(lx2, lx, atol=1e-15)
    np.testing.assert_allclose(sg2, unit(np.array([[-0.3 / 4, 0.2 / 4, 1]])), atol=1e-15)


def test_decal_baseline_ignores_the_receiving_surface():
    axis_x, axis_y, axis_z = np.eye(3)
    deriv = np.array([[0.2, -0.1]])
    base = R.decal_projector_normal(deriv, axis_x, axis_y, axis_z)
    np.testing.assert_allclose(base, unit(np.array([[-0.2, 0.1, 1.0]])))
    tilted = unit(np.array([[0.0, 0.7, 0.7]]))
    sg = R.resolve_normal_from_surface_gradient(tilted, R.surfgrad_from_decal(tilted, deriv,
                                                                              axis_x, axis_y))
    assert np.degrees(np.arccos(np.sum(sg * base))) > 30   # engines' result ignores the tilt
