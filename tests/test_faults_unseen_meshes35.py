"""Red team 35c: `compare` and the bake request on meshes as other tools write them.

1. A UV corner dragged far out of the UDIM grid (u = 1e5 on one corner of one face: a stray
   vertex in an importer's UVs, a typo in a script): Blender's bake scan-converts in float32,
   where a UV that large is rounded to a fifth of a texel at 32^2, so which of two faces takes
   a texel beside that face's long edges is decided by rounding. The reference's edge band
   assumed UVs on the UDIM grid: a correct SG Normal Map was called wrong, p99 0.0006 / max
   23.6 deg at 32^2 on 5.2 (the neighbour's tangent frame against the stretched face's). Now
   the band grows with a triangle's farthest UV (reference/raster.py), those texels are left
   out as "edge".
2. A corner at u = 1e30 (finite, so no check refused it): the reference's raster and the bake
   request's overlap count cast 3e31 texels to an integer, and numpy's "invalid value
   encountered in cast" RuntimeWarning reached the user's terminal from compare and from
   bake-normal-map's checks. Now the bounds are clipped before the cast.
3. A NaN or Inf UV: refused as before, but the tiles and overlap counts the request reads
   before its finiteness check cast NaN to integers: four numpy RuntimeWarnings, with their
   source lines, above the refusal on stderr. Now such a triangle covers no tile.
"""

import warnings

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import bake_request  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from test_faults_unseen_meshes31 import P99, MAX, empty_file  # noqa: E402,F401
from test_faults_unseen_meshes32 import _grid, _object  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 32


def _dragged(u, corners=1):
    """The bumped 8 x 8 grid over UVs 0.05..0.65, the first `corners` corners of face 0
    moved to u (4: the whole face, a line in UV space)."""
    verts, faces, uvs = _grid()
    obj = _object("Dragged", [(verts, faces, uvs)])
    layer = obj.data.uv_layers["UVMap"].uv
    corner = np.empty(len(layer) * 2)
    layer.foreach_get("vector", corner)
    corner[0:2 * corners:2] = u
    layer.foreach_set("vector", corner)
    obj.data.update()
    return obj


@pytest.mark.parametrize("u,corners", [(1e5, 1), (1e30, 1), (1e30, 4)])
def test_a_uv_corner_dragged_far_out_is_compared_within_the_bar(empty_file, u, corners):
    """1 and 2. Within the bar with texels of the dragged face left out as on an edge
    (before, 1e5: p99 3.1 deg), and no RuntimeWarning from compare or the request's checks
    (before, 1e30: "invalid value encountered in cast" from each)."""
    obj = _dragged(u, corners)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        report = compare.compare(obj, "normal-map", RES)
        bake_request.mesh_problems(obj, "UVMap", [], tiles=[1001], resolution=RES)
    assert report["texels_compared"] > 250, report
    assert report["p99_deg"] <= P99 and report["max_deg"] <= MAX, report
    if corners == 1:     # the face's sliver in the 0..1 square, decided by float32 rounding
        assert report["excluded"]["edge"] > 20, report


@pytest.mark.parametrize("u", [np.nan, np.inf])
def test_a_uv_that_is_not_a_number_is_refused_in_one_line(empty_file, u):
    """3. A NaN or Inf UV (a broken exporter): refused, as before, but without numpy's
    "invalid value encountered in cast" from the tiles and overlap counts the request reads
    first (before: four RuntimeWarning lines, with their source lines, above the refusal);
    compare's refusal reads as the request's (before: "UV map 'UVMap' contain ...")."""
    obj = _dragged(u)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        problems = bake_request.mesh_problems(obj, "UVMap", [], tiles=[1001], resolution=RES)
        with pytest.raises(ValueError) as err:
            compare.compare(obj, "normal-map", RES)
    assert problems == ["the UVs of UV map 'UVMap' of object 'Dragged' contain non-finite "
                        "values (NaN or Inf); unwrap it again (UV > Unwrap)"]
    assert str(err.value) == ("Dragged: the UVs of UV map 'UVMap' contain non-finite values "
                              "(NaN or Inf); fix the mesh data before baking")
