"""The paper's identities on random inputs, against independent formulas written out here."""

import numpy as np
import pytest

import surfgrad_addon.reference as R

pytestmark = pytest.mark.tier("numpy")


N = 2000


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_units(rng, n=N):
    return unit(rng.normal(size=(n, 3)))


def random_tangents(rng, n_vec):
    """Random vectors in the tangent plane of each unit normal."""
    v = rng.normal(size=n_vec.shape)
    return v - np.sum(v * n_vec, -1, keepdims=True) * n_vec


def angle_deg(a, b):
    c = np.sum(unit(a) * unit(b), -1)
    return np.degrees(np.arccos(np.clip(c, -1, 1)))


def test_resolve_is_normalized_difference(rng):
    n = random_units(rng)
    g = random_tangents(rng, n) * 0.7
    out = R.resolve_normal_from_surface_gradient(n, g)
    expect = (n - g) / np.linalg.norm(n - g, axis=-1, keepdims=True)
    np.testing.assert_allclose(out, expect, atol=1e-15)
    # n - g = 0 has no direction: the base normal comes back instead of NaN.
    assert np.allclose(R.resolve_normal_from_surface_gradient([[0, 0, 1.0]], [[0, 0, 1.0]]),
                       [[0, 0, 1]])


def test_blinn_eq4_equals_eq5_on_curved_surfaces(rng):
    """Blinn's perturbed normal (Eq. 4, from dH/ds, dH/dt) equals n - surface gradient
    (Eq. 5 with Eq. 6) of a volume extension of H, on random points of a curved surface."""
    # Surface sigma(s, t) = (s, t, a s^2 + b st + c t^2), height H~(x) = sin(k . x + phase).
    s, t = rng.uniform(-1, 1, (2, N))
    a, b, c = rng.uniform(-2, 2, (3, N))
    sig_s = np.stack([np.ones(N), np.zeros(N), 2 * a * s + b * t], -1)
    sig_t = np.stack([np.zeros(N), np.ones(N), b * s + 2 * c * t], -1)
    flip = np.where(rng.uniform(size=N) < 0.5, -1.0, 1.0)[:, None]
    n = flip * unit(np.cross(sig_s, sig_t))          # either facing direction
    k = rng.normal(size=(N, 3)) * 3
    p = np.stack([s, t, a * s * s + b * s * t + c * t * t], -1)
    grad_h = np.cos(np.sum(k * p, -1) + 0.3)[:, None] * k
    h_s = np.sum(grad_h * sig_s, -1)                 # chain rule: dH/ds = grad H~ . dsigma/ds
    h_t = np.sum(grad_h * sig_t, -1)
    det = np.sum(n * np.cross(sig_s, sig_t), -1)
    eq4 = n + (np.cross(n, sig_t) * h_s[:, None] + np.cross(sig_s, n) * h_t[:, None]) / det[:, None]
    eq5 = n - R.surfgrad_from_volume_gradient(n, grad_h)
    np.testing.assert_allclose(eq4, eq5, rtol=1e-10, atol=1e-10)
    # Listing 6 with dPdx = dsigma/ds, dPdy = dsigma/dt and unit texture steps is Eq. 7.
    ones = np.tile([1.0, 0.0], (N, 1)), np.tile([0.0, 1.0], (N, 1))
    sg6 = R.surfgrad_scale_dependent(n, sig_s, sig_t, np.stack([h_s, h_t], -1), *ones, (1, 1))
    np.testing.assert_allclose(n - sg6, eq4, rtol=1e-10, atol=1e-10)


def test_scale_dependent_gradient_gives_directional_derivatives(rng):
    """Eq. 7's defining property: grad_S H . dP/ds = dH/ds, . dP/dt = dH/dt, . n = 0, with
    arbitrary screen derivatives and texture-space chain rule (dim scaling)."""
    n = random_units(rng)
    p_s, p_t = random_tangents(rng, n), random_tangents(rng, n)
    jac = rng.normal(size=(N, 2, 2))                 # d(s,t)/d(x,y) per pixel
    dpdx = p_s * jac[:, 0, 0:1] + p_t * jac[:, 1, 0:1]
    dpdy = p_s * jac[:, 0, 1:2] + p_t * jac[:, 1, 1:2]
    dim = np.array([256.0, 128.0])
    deriv = rng.normal(size=(N, 2))                  # dH/du in pixels
    sg = R.surfgrad_scale_dependent(n, dpdx, dpdy, deriv, jac[:, :, 0], jac[:, :, 1], dim)
    np.testing.assert_allclose(np.sum(sg * p_s, -1), deriv[:, 0] * dim[0], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(np.sum(sg * p_t, -1), deriv[:, 1] * dim[1], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(np.sum(sg * n, -1), 0, atol=1e-9)


def test_resolve_after_perturbed_normal_returns_v(rng):
    n = random_units(rng)
    v = rng.normal(size=(N, 3)) * rng.uniform(0.1, 10, (N, 1))
    v = np.where(np.sum(v * n, -1, keepdims=True) < 0, -v, v)   # front hemisphere
    v = v + 0.05 * n                                               # keep n.v away from 0
    out = R.resolve_normal_from_surface_gradient(n, R.surfgrad_from_perturbed_normal(n, v))
    np.testing.assert_allclose(out, unit(v), atol=1e-9)
    # The gradient is in the tangent plane.
    np.testing.assert_allclose(np.sum(R.surfgrad_from_perturbed_normal(n, v) * n, -1), 0,
                               atol=1e-9)


def test_surface_gradients_are_linear(rng):
    n = random_units(rng)
    t, b = random_tangents(rng, n), random_tangents(rng, n)
    d1, d2 = rng.normal(size=(2, N, 2))
    g1, g2 = rng.normal(size=(2, N, 3))
    a, c = 0.7, -1.9
    np.testing.assert_allclose(R.surfgrad_from_tbn(a * d1 + c * d2, t, b),
                               a * R.surfgrad_from_tbn(d1, t, b) + c * R.surfgrad_from_tbn(d2, t, b),
                               atol=1e-12)
    np.testing.assert_allclose(R.surfgrad_from_volume_gradient(n, a * g1 + c * g2),
                               a * R.surfgrad_from_volume_gradient(n, g1)
                               + c * R.surfgrad_from_volume_gradient(n, g2), atol=1e-12)
    dpdx, dpdy = random_tangents(rng, n), random_tangents(rng, n)
    sx, sy = rng.normal(size=(2, N, 2))
    f = lambda d: R.surfgrad_scale_dependent(n, dpdx, dpdy, d, sx, sy, (64, 64))
    np.testing.assert_allclose(f(a * d1 + c * d2), a * f(d1) + c * f(d2), rtol=1e-9, atol=1e-9)


def test_triplanar_equals_weighted_per_plane_surface_gradients(rng):
    """Listing 13 (one projected volume gradient) equals the weighted sum of each plane's
    surface gradient computed the other way, through Eq. 7 (Listing 6) with that plane's
    projection as its texture mapping."""
    n = random_units(rng)
    w = R.determine_triplanar_weights(n)
    np.testing.assert_allclose(w.sum(-1), 1, atol=1e-12)
    dx_, dy_, dz_ = rng.normal(size=(3, N, 2))
    sg = R.surfgrad_from_triplanar_projection(n, w, dx_, dy_, dz_)
    dpdx, dpdy = random_tangents(rng, n), random_tangents(rng, n)
    total = np.zeros_like(sg)
    for weight, deriv, axes in ((w[:, 0], dx_, (2, 1)), (w[:, 1], dy_, (0, 2)),
                                (w[:, 2], dz_, (0, 1))):
        st_dx = dpdx[:, list(axes)]   # the plane's (u, v) = chosen world coordinates
        st_dy = dpdy[:, list(axes)]
        total += weight[:, None] * R.surfgrad_scale_dependent(n, dpdx, dpdy, deriv, st_dx,
                                                              st_dy, (1, 1))
    np.testing.assert_allclose(sg, total, rtol=1e-7, atol=1e-7)


def test_triplanar_weights_hand_values():
    w = R.determine_triplanar_weights(np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]))
    np.testing.assert_allclose(w[0], [0, 0, 1])
    expect = np.array([0.4 ** 3, 0, 0.6 ** 3])
    np.testing.assert_allclose(w[1], expect / expect.sum())


def test_decal_equals_volume_gradient_route(rng):
    """Listing 15 equals the surface gradient of H(p) = h(x.p, y.p) computed from the volume
    gradient by central differences of the closed form."""
    n = random_units(rng, 300)
    axis_x = random_units(rng, 300)
    axis_y = unit(np.cross(axis_x, rng.normal(size=(300, 3))))
    p = rng.normal(size=(300, 3))
    h = lambda q: np.sin(3 * np.sum(q * axis_x, -1)) * np.cos(2 * np.sum(q * axis_y, -1))
    u, v = np.sum(p * axis_x, -1), np.sum(p * axis_y, -1)
    deriv = np.stack([3 * np.cos(3 * u) * np.cos(2 * v), -2 * np.sin(3 * u) * np.sin(2 * v)], -1)
    eps = 1e-6
    grad = np.stack([(h(p + eps * e) - h(p - eps * e)) / (2 * eps) for e in np.eye(3)], -1)
    fd = grad - np.sum(grad * n, -1, keepdims=True) * n
    np.testing.assert_allclose(R.surfgrad_from_decal(n, deriv, axis_x, axis_y), fd, atol=1e-8)


def test_tbn_with_orthonormal_frame_equals_classic_normal_mapping(rng):
    """Eq. 17: resolve(n, L3(L2(m), t, b)) equals normalize(t m.x + b m.y + n m.z)."""
    n = random_units(rng)
    t = unit(random_tangents(rng, n))
    sign = np.where(rng.uniform(size=N) < 0.5, -1.0, 1.0)[:, None]
    b = sign * np.cross(n, t)
    m = unit(rng.normal(size=(N, 3)) * [1, 1, 0.5] + [0, 0, 1.2])
    m[:, 2] = np.abs(m[:, 2]) + 0.02
    m = unit(m)
    classic = unit(t * m[:, :1] + b * m[:, 1:2] + n * m[:, 2:])
    sg = R.resolve_normal_from_surface_gradient(
        n, R.surfgrad_from_tbn(R.tspace_normal_to_derivative(m), t, b))
    np.testing.assert_allclose(sg, classic, atol=1e-12)


def test_mikktspace_renormalisation_is_compliant(rng):
    """Listing 9: with the interpolated, unnormalised frame (t, b = sign n x t, n), scaling all
    three by 1/|n| and resolving gives MikkTSpace's normalize(t m.x + b m.y + n m.z)."""
    n = rng.normal(size=(N, 3)) + [0, 0, 3]          # not unit length
    t = rng.normal(size=(N, 3))                      # not orthogonal, not unit
    sign = np.where(rng.uniform(size=N) < 0.5, -1.0, 1.0)
    m = unit(rng.normal(size=(N, 3)) * 0.4 + [0, 0, 1])
    m[:, 2] = np.abs(m[:, 2]) + 0.05                 # front-facing tangent normals only
    m = unit(m)
    b = sign[:, None] * np.cross(n, t)
    mikk = unit(t * m[:, :1] + b * m[:, 1:2] + n * m[:, 2:])
    nn, tt, bb = R.mikkts_renormalize(n, t, sign)
    np.testing.assert_allclose(np.linalg.norm(nn, axis=-1), 1, atol=1e-14)
    out = R.resolve_normal_from_surface_gradient(
        nn, R.surfgrad_from_tbn(R.tspace_normal_to_derivative(m), tt, bb))
    np.testing.assert_allclose(out, mikk, atol=1e-12)


def test_two_sided_flip_only_flips_back_faces():
    n = np.array([[0, 0, 1.0], [0, 1.0, 0]])
    out = R.two_sided_flip(n, np.array([True, False]))
    np.testing.assert_array_equal(out, [[0, 0, -1], [0, 1, 0]])


def test_bump_prologue_sigma_and_flip_sign(rng):
    n = random_units(rng, 50)
    dpdx, dpdy = rng.normal(size=(2, 50, 3))
    pro = R.bump_prologue(n * 2.0, random_tangents(rng, n), np.ones(50), dpdx, dpdy)
    np.testing.assert_allclose(pro.base_normal, n, atol=1e-14)
    np.testing.assert_allclose(np.sum(pro.sigma_x * n, -1), 0, atol=1e-12)
    np.testing.assert_allclose(pro.sigma_x + np.sum(dpdx * n, -1, keepdims=True) * n, dpdx)
    expect = np.where(np.sum(dpdy * np.cross(n, dpdx), -1) < 0, -1, 1)
    np.testing.assert_array_equal(pro.flip_sign[:, 0], expect)


def test_tspace_normal_to_derivative_clamps_and_matches_eq15(rng):
    m = unit(rng.normal(size=(N, 3)))
    d = R.tspace_normal_to_derivative(m)
    assert np.all(np.isfinite(d)) and np.all(np.abs(d) <= 128 + 1e-9)
    # z = 0 and z < 0 stay within the clamp and keep the direction of -(x, y).
    edge = np.array([[1.0, 0, 0], [0, -1.0, 0], [0.6, 0.8, 0], [0.3, 0.4, -0.866], [0, 0, 0]])
    de = R.tspace_normal_to_derivative(edge)
    np.testing.assert_allclose(de[:3], [[-128, 0], [0, 128], [-96, -128]])
    np.testing.assert_allclose(de[3], [-0.3 / 0.866, -0.4 / 0.866])
    np.testing.assert_array_equal(de[4], [0, 0])
    # Eq. 15 where z dominates; flip_vertical negates the second component only.
    front = m[np.abs(m[:, 2]) > 0.2]
    np.testing.assert_allclose(R.tspace_normal_to_derivative(front),
                               -front[:, :2] / np.abs(front[:, 2:]), rtol=1e-12)
    flipped = R.tspace_normal_to_derivative(front, flip_vertical=True)
    np.testing.assert_allclose(flipped * [1, -1], R.tspace_normal_to_derivative(front))
    # Eq. 12 inverts Eq. 15.
    np.testing.assert_allclose(
        R.derivative_to_tspace_normal(R.tspace_normal_to_derivative(unit(front * [1, 1, 0] + [0, 0, 1]))),
        unit(front * [1, 1, 0] + [0, 0, 1]), atol=1e-12)


@pytest.mark.parametrize("mirror", [1.0, -1.0])
def test_gen_basis_tb_is_the_normalised_uv_frame(rng, mirror):
    """Listing 4: t = normalize(dP/ds), b is the unit vector in the tangent plane
    perpendicular to t on the side of dP/dt, for clockwise and mirrored UVs alike."""
    n = random_units(rng)
    p_s, p_t = random_tangents(rng, n), random_tangents(rng, n)
    # UV Jacobian of the surface: d(s,t)/d(x,y); mirror flips the s axis of the unwrap.
    jac = rng.normal(size=(N, 2, 2))
    jac[:, 0, :] *= mirror
    dpdx = p_s * jac[:, 0, 0:1] + p_t * jac[:, 1, 0:1]
    dpdy = p_s * jac[:, 0, 1:2] + p_t * jac[:, 1, 1:2]
    t, b = R.gen_basis_tb(n, dpdx, dpdy, jac[:, :, 0], jac[:, :, 1])
    np.testing.assert_allclose(t, unit(p_s), atol=1e-8)
    np.testing.assert_allclose(np.linalg.norm(b, axis=-1), 1, atol=1e-8)
    np.testing.assert_allclose(np.sum(b * t, -1), 0, atol=1e-8)
    np.testing.assert_allclose(np.sum(b * n, -1), 0, atol=1e-8)
    assert np.all(np.sum(b * p_t, -1) > 0)
    # Degenerate UVs (det = 0) give finite output, not NaN.
    t0, b0 = R.gen_basis_tb(n[:3], dpdx[:3], dpdy[:3], np.zeros((3, 2)), np.zeros((3, 2)))
    assert np.all(np.isfinite(t0)) and np.all(np.isfinite(b0))


def test_parallax_l11_then_l12_round_trips(rng):
    n = random_units(rng)
    p_s, p_t = random_tangents(rng, n), random_tangents(rng, n)
    jac = rng.normal(size=(N, 2, 2))
    dpdx = p_s * jac[:, 0, 0:1] + p_t * jac[:, 1, 0:1] + 0.3 * n   # not in the tangent plane
    dpdy = p_s * jac[:, 0, 1:2] + p_t * jac[:, 1, 1:2]
    sigma_x, sigma_y, _ = R.sigma_vectors(n, dpdx, dpdy)
    d = unit(rng.normal(size=(N, 3)))
    d = np.where(np.sum(d * n, -1, keepdims=True) < 0, -d, d) + 0.1 * n
    d = unit(d)
    offs = R.project_vec_to_texture_space(n, dpdx, dpdy, jac[:, :, 0], jac[:, :, 1], d, 1.0,
                                          skip_proj=True)
    back = R.tex_space_offs_to_surface(sigma_x, sigma_y, jac[:, :, 0], jac[:, :, 1], offs)
    d_tan = d - np.sum(d * n, -1, keepdims=True) * n
    np.testing.assert_allclose(back, d_tan, atol=1e-7)
    # The projected form is the same offset scaled by bump_scale / (n . dir).
    proj = R.project_vec_to_texture_space(n, dpdx, dpdy, jac[:, :, 0], jac[:, :, 1], d, 0.25)
    np.testing.assert_allclose(proj, offs * 0.25 / np.sum(d * n, -1, keepdims=True), rtol=1e-9)


def test_parallax_occlusion_march_finds_the_height_field(rng):
    st = rng.uniform(0, 1, (500, 2))
    v = rng.normal(size=(500, 2)) * 0.05
    # A constant height c: the ray crosses at level c exactly (linear refinement is exact).
    for c in (0.0, 0.37, 1.0):
        offs = R.parallax_occlusion_march(lambda q: np.full(q.shape[:-1], c), st, v, steps=8)
        np.testing.assert_allclose(offs, c * v, atol=1e-12)
    # A plane H(q) = a + k . q: the crossing solves level = a + k . (st + level v).
    k = np.array([0.8, -0.5])
    hfun = lambda q: 0.3 + np.sum(q * k, -1) * 0.2
    offs = R.parallax_occlusion_march(hfun, st * 0.5, v, steps=4)
    level = (0.3 + 0.2 * np.sum(st * 0.5 * k, -1)) / (1 - 0.2 * np.sum(v * k, -1))
    np.testing.assert_allclose(offs, level[:, None] * v, atol=1e-12)
    np.testing.assert_allclose(R.parallax_offset_limited(np.full(500, 0.5), v), 0.5 * v)


def test_screen_derivatives_without_ddxy_match_finite_differences(rng):
    """Listing 10 against a finite difference of the pixel ray's hit point on the plane."""
    f, w, h = 1.2, 640.0, 480.0
    proj = np.array([[f / (w / h), 0, 0, 0], [0, f, 0, 0], [0, 0, -1.0, -0.2], [0, 0, -1, 0]])
    to_scr = np.array([[w / 2, 0, 0, w / 2], [0, h / 2, 0, h / 2], [0, 0, 0.5, 0.5], [0, 0, 0, 1]])
    view = np.eye(4)
    view[:3, 3] = [0.1, -0.2, -3.0]
    inv = np.linalg.inv(to_scr @ proj @ view)
    pos = np.array([[0.3, 0.2, 0.1]])
    norm = unit(np.array([[0.2, 0.3, 1.0]]))
    clip = to_scr @ proj @ view @ np.append(pos[0], 1)
    x0, y0 = clip[0] / clip[3], clip[1] / clip[3]

    def hit(x, y):  # ray through screen (x, y) intersected with the plane
        a = inv @ [x, y, 0.3, 1]
        b = inv @ [x, y, 0.6, 1]
        a, b = a[:3] / a[3], b[:3] / b[3]
        tt = np.dot(pos[0] - a, norm[0]) / np.dot(b - a, norm[0])
        return a + tt * (b - a)
    e = 1e-3
    fd_x = (hit(x0 + e, y0) - hit(x0 - e, y0)) / (2 * e)
    fd_y = (hit(x0, y0 + e) - hit(x0, y0 - e)) / (2 * e)
    dpdx, dpdy = R.screen_deriv_of_pos_no_ddxy(pos, norm, inv, x0, y0)
    np.testing.assert_allclose(dpdx[0], fd_x, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(dpdy[0], fd_y, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(np.dot(dpdx[0], norm[0]), 0, atol=1e-12)
