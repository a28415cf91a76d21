"""Round 53 (helper rt53a): what each method reads, as the registry declares it
(reference/method_registry.MethodSpec.reads), against what its reference reads when it runs.

`compare --image X --method <one that reads no normal map>` (height-map, triplanar-height,
volume-noise, height-blend, ...) was refused only after the whole bake and its comparison
(harness/compare.py checked which images the reference had read): minutes of bake lost before
"reads no normal map". It is now refused before the file opens, from the method's declared
reads (tests/test_faults_trust53a.py pins the refusal and that the graphs read the same). The
declaration is a second statement of what the code reads, so here it is held to the run: every
method's reference, run on a small sphere with inputs that record what is read, reads exactly
the images its spec declares (the Sampler twins and displace-bump included).
"""

import numpy as np
import pytest

from surfgrad_addon import reference as R
from surfgrad_addon.harness.methods import METHODS
from surfgrad_addon.reference.method_registry import REST_ATTRIBUTE

pytestmark = pytest.mark.tier("numpy")

SIZE = 16


class _Recorded:
    """A method's inputs (harness/main_job.ReferenceInputs' fields) that note each image read."""

    def __init__(self, variant):
        self.images = {"normal": R.images.hemisphere_tile_image(SIZE),
                       "detail": R.images.hemisphere_tile_image(SIZE, tiles=8, radius=0.6),
                       "height": R.images.wave_height_image(SIZE)}
        self.variant, self.uv_map, self.detail_uv = variant, "UVMap", "Detail"
        self.projector = type("Projector", (), {"matrix_world": np.eye(4)})()
        self.parallax_scale = self.relief_scale = None
        self.read = set()

    def pixels(self, name):
        self.read.add(name)
        return self.images[name]


@pytest.fixture(scope="module")
def texels():
    mesh = R.meshes.uv_sphere(segments=12, rings=6)
    # displace-bump's reference reads the rest positions its modifier stores.
    mesh.point_attributes[REST_ATTRIBUTE] = np.asarray(mesh.positions, dtype=np.float64)
    return R.rasterize(mesh, "UVMap", SIZE, SIZE)


@pytest.mark.parametrize("name", sorted(METHODS))
def test_a_methods_declared_reads_are_what_its_reference_reads(name, texels):
    m = METHODS[name]
    for variant in m.variants:
        inp = _Recorded(variant)
        n, sg = m.reference(inp, texels)
        assert np.isfinite(sg).all()
        assert inp.read == set(m.reads), (name, variant, sorted(inp.read), m.reads)


def test_the_methods_that_read_no_normal_map_are_the_ones_compare_refused_after_the_bake():
    """The round-50 list (tests/test_faults_docs50c.py: height-map, triplanar-height,
    volume-noise) and the rest that read none, from the declarations."""
    none = sorted(k for k, m in METHODS.items() if "normal" not in m.reads)
    assert none == ["displace-bump", "height-blend", "height-map", "height-map-sampler",
                    "procedural-basis", "triplanar-height", "triplanar-height-sampler",
                    "volume-noise", "volume-noise-filtered"], none
