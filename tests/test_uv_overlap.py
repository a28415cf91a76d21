"""reference/uv_overlap.contested_texels against a per-texel count written independently
(barycentric coordinates of each texel centre, one triangle at a time), and on layouts whose
answer is known by hand."""

import numpy as np
import pytest

from surfgrad_addon.reference.uv_overlap import contested_texels

pytestmark = pytest.mark.tier("numpy")


def _brute(uv, size, offset=(0.0, 0.0)):
    claims = np.zeros((size, size), int)
    centres = (np.stack(np.meshgrid(np.arange(size), np.arange(size)), -1) + 0.5) / size
    centres = centres + np.asarray(offset)
    for a, b, c in np.asarray(uv, float):
        m = np.array([b - a, c - a]).T
        if abs(np.linalg.det(m)) < 1e-15:
            continue
        w = np.linalg.solve(m, (centres - a).reshape(-1, 2).T).T
        bary = np.column_stack([1 - w.sum(1), w])
        claims += (bary > 1e-9).all(1).reshape(size, size)
    return int((claims >= 2).sum())


def test_stacked_squares_contest_every_texel():
    quad = np.array([[[0, 0], [0.5, 0], [0.5, 0.5]], [[0, 0], [0.5, 0.5], [0, 0.5]]])
    # one island: neighbours share the diagonal edge and contest nothing
    assert contested_texels(quad, 16) == 0
    # the same island twice (mirrored halves stacked): all 8 x 8 texels, the 8 on the shared
    # diagonal too (each island's one face takes them; before red team 50a, neither did)
    assert contested_texels(np.concatenate([quad, quad[:, ::-1]]), 16) == 64


def test_random_layouts_match_an_independent_count():
    rng = np.random.default_rng(7)
    for size, offset in ((16, (0.0, 0.0)), (37, (0.0, 0.0)), (24, (2.0, 1.0))):
        uv = rng.uniform(-0.2, 1.2, (25, 3, 2)) + np.asarray(offset)
        assert contested_texels(uv, size, offset) == _brute(uv, size, offset)


def test_zero_area_and_outside_triangles_claim_nothing():
    line = np.array([[[0, 0], [1, 1], [0.5, 0.5]]] * 2)
    far = np.array([[[3, 3], [4, 3], [4, 4]]] * 2)
    assert contested_texels(np.concatenate([line, far]), 8) == 0
