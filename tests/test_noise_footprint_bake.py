"""SG Noise's Filter Footprint in a bake: the filter really changes the baked normals (the
unfiltered reference no longer matches), and the footprint the reference reads is in the fade
band at the comparison's resolution. The filtered bake against the filtered reference is
test_bake_compare's "volume-noise-filtered"."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import compare, methods, scenes as test_scenes  # noqa: E402
from surfgrad_addon.reference import rasterize  # noqa: E402
from surfgrad_addon.reference.method_registry import NOISE_SCALE  # noqa: E402
from surfgrad_addon.reference.methods import bake_noise_footprint  # noqa: E402
from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object  # noqa: E402
from surfgrad_addon.addon.node_builder import running_line  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RESOLUTION = 48


@pytest.fixture(scope="module")
def scene():
    yield test_scenes.new_scene()


def test_filtered_bake_differs_from_the_unfiltered_reference(scene):
    obj = bpy.data.objects["Sphere"]
    inp = compare.prepare_inputs(obj)
    try:
        filtered = methods.METHODS["volume-noise-filtered"]
        plain = methods.METHODS["volume-noise"]
        report, _ = compare.compare_graph(inp, obj, filtered.graph, plain.reference, RESOLUTION)
        same, _ = compare.compare_graph(inp, obj, filtered.graph, filtered.reference,
                                        RESOLUTION)
    finally:
        for _, img in inp.images.values():
            bpy.data.images.remove(img)
    # The faded octaves carry degrees of tilt; the filtered reference follows to 0.01 deg.
    assert report["p99_deg"] > 1.0, report
    assert same["p99_deg"] < 0.01, same


def test_the_bake_footprint_puts_the_fine_octaves_in_the_fade(scene):
    """On the Plane (UV = the 2 m square, 48 texels) the bake's differentials are
    k (2/48 + 2/48) long (k: the line's bake_differential_scale) along orthonormal axes:
    the footprint in noise units is Scale x that, the same at every texel."""
    obj = bpy.data.objects["Plane"]
    mesh = mesh_arrays_from_object(obj)
    td = rasterize(mesh, obj.data.uv_layers.active.name, RESOLUTION, RESOLUTION,
                   facts=running_line())
    f = bake_noise_footprint(td, NOISE_SCALE)
    size = np.ptp(np.asarray([v.co[:] for v in obj.data.vertices]), axis=0)[:2]
    scale_xy = np.asarray(obj.matrix_world.to_scale())[:2]
    r = running_line().bake_differential_scale * np.sum(size * scale_xy / RESOLUTION)
    expect = NOISE_SCALE * r / scale_xy[0]
    np.testing.assert_allclose(f, expect, rtol=1e-6)
    assert 0.25 < 8 * expect and 2 * expect < 0.5      # octave 4 fades, octave 2 keeps some
