"""float32 in gives float32 out, within float32 tolerance of float64; and the reference imports
with numpy alone."""

from pathlib import Path

import numpy as np
import pytest

import surfgrad_addon.reference as R

pytestmark = pytest.mark.tier("child")


ROOT = Path(__file__).resolve().parents[1]
rng = np.random.default_rng(11)
n = rng.normal(size=(500, 3))
n /= np.linalg.norm(n, axis=-1, keepdims=True)
v3 = [rng.normal(size=(500, 3)) for _ in range(4)]
v2 = [rng.normal(size=(500, 2)) for _ in range(4)]
m = v3[0] * 0.3 + [0, 0, 1]
m /= np.linalg.norm(m, axis=-1, keepdims=True)
img = rng.uniform(size=(16, 16))
st = rng.uniform(size=(500, 2))

CASES = {
    "resolve": lambda f: R.resolve_normal_from_surface_gradient(f(n), f(v3[1]) * 0.3),
    "tspace_normal_to_derivative": lambda f: R.tspace_normal_to_derivative(f(m)),
    "surfgrad_from_tbn": lambda f: R.surfgrad_from_tbn(f(v2[0]), f(v3[1]), f(v3[2])),
    "gen_basis_tb": lambda f: np.concatenate(R.gen_basis_tb(f(n), f(v3[1]), f(v3[2]),
                                                            f(v2[0]), f(v2[1])), -1),
    "surfgrad_from_perturbed_normal": lambda f: R.surfgrad_from_perturbed_normal(f(n), f(m + n)),
    "surfgrad_scale_dependent": lambda f: R.surfgrad_scale_dependent(
        f(n), f(v3[1]), f(v3[2]), f(v2[0]), f(v2[1]), f(v2[2]), (8, 8)),
    "surfgrad_from_volume_gradient": lambda f: R.surfgrad_from_volume_gradient(f(n), f(v3[1])),
    "triplanar": lambda f: R.surfgrad_from_triplanar_projection(
        f(n), R.determine_triplanar_weights(f(n)), f(v2[0]), f(v2[1]), f(v2[2])),
    "decal": lambda f: R.surfgrad_from_decal(f(n), f(v2[0]), f(v3[1]), f(v3[2])),
    "deriv_from_height_map": lambda f: R.deriv_from_height_map(f(img), f(st), hq=True),
    "mikkts_renormalize": lambda f: np.concatenate(R.mikkts_renormalize(f(m), f(v3[1]),
                                                                        np.ones(500)), -1),
    "project_vec_to_texture_space": lambda f: R.project_vec_to_texture_space(
        f(n), f(v3[1]), f(v3[2]), f(v2[0]), f(v2[1]), f(m), 0.1),
    "tex_space_offs_to_surface": lambda f: R.tex_space_offs_to_surface(
        f(v3[1]), f(v3[2]), f(v2[0]), f(v2[1]), f(v2[2])),
    "blend_rnm": lambda f: R.blend_rnm(f(m), f(m[::-1])),
    "gradient_noise": lambda f: R.gradient_noise(f(v3[3] * 4))[1],
    "displaced_normal": lambda f: R.displaced_normal(f(n), f(v3[1]), 0.2),
    "perlin1985": lambda f: R.perturb_normal_perlin1985(f(n), f(v3[1]) * 0.2),
}


@pytest.mark.tier("numpy")
@pytest.mark.parametrize("name", sorted(CASES))
def test_float32_in_float32_out(name):
    f64 = CASES[name](lambda a: np.asarray(a, np.float64))
    f32 = CASES[name](lambda a: np.asarray(a, np.float32))
    assert f64.dtype == np.float64
    assert f32.dtype == np.float32, name
    scale = max(1.0, float(np.max(np.abs(f64))))
    np.testing.assert_allclose(f32, f64, rtol=2e-4, atol=2e-4 * scale)


def test_reference_imports_without_bpy():
    """In a fresh interpreter that refuses to import bpy (or mathutils), the reference loads
    and evaluates."""
    from support.child import run_without_bpy
    stdout = run_without_bpy(
        "import numpy, surfgrad_addon.reference as R\n"
        "assert 'bpy' not in sys.modules\n"
        "print(R.resolve_normal_from_surface_gradient([0, 0, 1.0], [0.5, 0, 0]).round(6).tolist())\n"
        "print(numpy.__version__)\n")
    first, version = stdout.split("\n")[:2]
    assert first == "[-0.447214, 0.0, 0.894427]"  # (-0.5, 0, 1)/|.|
    assert version.split(".")[0] in ("1", "2")
