"""Red team 48a: round 47's changes to the normal-map bake (tests/test_faults_bake_closures47.py)
at the other entry points.

1. A linked material a linked node group gives by a Set Material (refused since round 47) was
   refused by the bake itself, after the request's checks had passed: a request with another
   problem too (its output there already) named that one alone, and the rerun the next. Now the
   request's checks (bake_request: bake-normal-map, bake-batch, the api) name it with the rest.
2. EEVEE's Specular BSDF makes no closure in Cycles: Cycles' own bake of it gave the surface's
   normal (60 degrees off the map fed it), and since round 47 it stands in, its Normal baked as
   EEVEE renders it, with no word that Cycles renders the material without it. It still stands
   in, and the bake warns, naming the material and the node.
Freeze bakes its stack alone through a Diffuse BSDF (freeze._baking_the_stack_alone), so a
Transparent BSDF or Holdout added to its Principled BSDF leaves its map as it was (probed, 5.2).
"""

import contextlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import normal_bake  # noqa: E402
from surfgrad_addon.addon.bake_request import BakeRequestError  # noqa: E402
from test_faults_assets44 import _baked_normals, _tilted_plane  # noqa: E402
from test_faults_bake_closures47 import _degrees_off, _linked_set_material  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def test_a_linked_group_is_named_with_the_requests_other_problems(tmp_path):
    """Finding 1: one refusal names both problems; nothing is written or changed."""
    obj, _, _, _ = _linked_set_material(tmp_path, linked_group=True)
    (tmp_path / "n.exr").write_bytes(b"an earlier map")
    with pytest.raises(BakeRequestError) as refused:
        _baked_normals(obj, tmp_path / "n.exr")
    assert "n.exr exists" in str(refused.value)
    assert "node group 'Set Material', linked from" in str(refused.value)
    assert (tmp_path / "n.exr").read_bytes() == b"an earlier map"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["library.blend", "n.exr"]


def test_an_eevee_specular_bakes_its_normal_and_is_warned_of(tmp_path, capsys, monkeypatch):
    """Finding 2: the map is its Normal, and the warning names it; Cycles' own bake (no stand
    in) gives the surface's normal, the fact the warning states."""
    obj, _, normal = _tilted_plane("ShaderNodeEeveeSpecular")
    capsys.readouterr()
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    assert "material 'Imported': Specular BSDF 'Specular BSDF' is EEVEE's alone" in \
        capsys.readouterr().err
    monkeypatch.setattr(normal_bake, "_stand_ins", lambda *_: contextlib.nullcontext())
    surface = _degrees_off(_baked_normals(obj, tmp_path / "cycles.exr"), np.array([0, 0, 1.0]))
    assert surface < 0.05
