"""The freeze exhibit (harness/exhibit_freeze.py) at a tiny size: the frozen sphere renders like
the live one, and both are far from the same sphere with no stack (so the stack shows).

Measured on the spheres' discs, mean |pixel difference| (display values 0-1) between the left
(live) and middle (frozen) panels, which the orthographic camera makes the same pixels but for
the material. At 4 samples that is mostly sampling noise, which is larger on the bumpy spheres
than on flat ones, so the floor is the same render with another seed (live against live,
frozen against frozen, averaged). Measured on 5.2 (freeze at 128 texels, 160 x 90):
live - frozen 0.0285, floor 0.0245 (live 0.0267, frozen 0.0223), live - flat 0.067, frozen -
flat 0.061. Bars: live - frozen <= 1.25 floor + 0.003 (the frozen one samples a linear-filtered
128-texel map, a little smoother than the live noise: at 32 samples the whole difference is
0.008); each stacked sphere >= 2 floors from its flat self."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import exhibit_freeze as E  # noqa: E402

pytestmark = pytest.mark.tier("bake")

SIZE, SAMPLES = (160, 90), 4


def discs(px):
    """(live disc pixels, frozen disc pixels), the same pixels of each panel."""
    h, w = px.shape[:2]
    live, frozen, _ = E.panel_columns(w)
    rows = E.panel_rows(h, w)
    a, b = px[rows, live], px[rows, frozen]
    n, m = a.shape[:2]
    y, x = np.mgrid[:n, :m]
    radius = E.RADIUS * w / E.ORTHO_WIDTH - 1.5          # inside the silhouette's edge
    inside = (y - (n - 1) / 2) ** 2 + (x - (m - 1) / 2) ** 2 < radius ** 2
    return a[inside], b[inside]


def mean_abs(a, b):
    return float(np.abs(a - b).mean())


@pytest.fixture(scope="module")
def renders():
    live_obj, frozen_obj, _ = E.build(resolution=128)
    stacked = E.render_pixels(SIZE, SAMPLES)
    reseeded = E.render_pixels(SIZE, SAMPLES, seed=1)
    for obj in (live_obj, frozen_obj):
        tree = obj.active_material.node_tree
        for link in [lk for lk in tree.links if lk.to_socket.name == "Normal" and
                     lk.to_node.bl_idname == "ShaderNodeBsdfPrincipled"]:
            tree.links.remove(link)
    flat = E.render_pixels(SIZE, SAMPLES)
    return discs(stacked), discs(reseeded), discs(flat)


def test_frozen_renders_like_live(renders):
    (live, frozen), (live_again, frozen_again), _ = renders
    floor = 0.5 * (mean_abs(live, live_again) + mean_abs(frozen, frozen_again))
    err = mean_abs(live, frozen)
    assert err <= 1.25 * floor + 0.003, (err, floor)


def test_the_stack_shows(renders):
    (live, frozen), (live_again, frozen_again), (flat_left, flat_middle) = renders
    floor = 0.5 * (mean_abs(live, live_again) + mean_abs(frozen, frozen_again))
    assert mean_abs(live, flat_left) >= 2 * floor, (mean_abs(live, flat_left), floor)
    assert mean_abs(frozen, flat_middle) >= 2 * floor, (mean_abs(frozen, flat_middle), floor)


def test_panels_line_up():
    """The two panels are a whole number of pixels apart at both sizes (what the difference
    panel needs): SHIFT over ORTHO_WIDTH times the width."""
    for width in (160, 1280):
        shift = E.SHIFT * width / E.ORTHO_WIDTH
        assert abs(shift - round(shift)) < 1e-9
