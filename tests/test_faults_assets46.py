"""Red team 46a: the product on more real assets made outside the project (glTF roundtrip
files of KhronosGroup/glTF-Blender-IO, castle-engine/demo-models, usd-wg/assets' USD, imported
with Blender's own importers); each finding is built here by code, a few faces, so no test
reads a fetched file.

1. An object-space bake of an object scaled unevenly (its own scale, a delta or a parent's: a
   glTF node with scale (1, 1, 0.1), as castle-engine's normal_maps_scaled_object has):
   Blender turns the baked normal into object space by the inverse of the object's matrix, but
   its Normal Map node (Object Space) reads a map by the inverse transpose, so the map that
   bake-normal-map --space object, bake-batch and the API wrote was read back bent, exit 0: a
   plane scaled (2, 0.5, 1) fed a normal map leaning 60 degrees, 36.6 degrees off (scaled
   (1, 1, 0.1): 59.0), on 5.2 and 4.2 alike; its own geometry's normal was stored bent too.
   Now such a bake is refused before baking, naming the object, the worst bend and the fixes
   (apply the scale, or bake in tangent space, which is right): addon/object_space_scale.py.
   A uniform or mirrored scale bakes as before, and reads back right.
"""

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import normal_bake as NB  # noqa: E402
from surfgrad_addon.addon.bake_request import BakeRequestError  # noqa: E402
from surfgrad_addon.addon.object_space_scale import worst_bend_deg  # noqa: E402
from test_faults_assets44 import _tilted_plane  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16


def _centre(path):
    img = bpy.data.images.load(str(path))
    try:
        return np.array(img.pixels[:]).reshape(RES, RES, 4)[RES // 2, RES // 2, :3]
    finally:
        bpy.data.images.remove(img)


def _read_back_deg(obj, mat, normal, encoded, tmp_path):
    """Feed the object-space map's texel through Blender's own Normal Map node (Object Space)
    and bake that in tangent space: the degrees between what comes back and `normal`, the
    tangent-space normal the object-space map was baked from."""
    tree = mat.node_tree
    next(n for n in tree.nodes if n.bl_idname == "ShaderNodeNormalMap").space = "OBJECT"
    rgb = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeRGB")
    rgb.outputs[0].default_value = (*encoded, 1.0)
    out = tmp_path / "back.exr"
    api.bake_normal_map(obj, str(out), space="tangent", resolution=RES, margin=0, log=None)
    back = _centre(out) * 2.0 - 1.0
    back /= np.linalg.norm(back)
    return math.degrees(math.acos(min(1.0, float(back @ normal))))


def _scaled_plane(scale):
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfDiffuse")
    obj.scale = scale
    obj.rotation_euler = (0.3, 0.2, 0.1)
    bpy.context.view_layer.update()
    return obj, mat, normal


def test_an_unevenly_scaled_object_space_bake_is_refused(tmp_path):
    """Finding 1: refused before baking (before: exit 0 and a map read back 36.6 degrees off),
    naming the object and both fixes; no file written."""
    obj, _, _ = _scaled_plane((2.0, 0.5, 1.0))
    out = tmp_path / "n.exr"
    with pytest.raises(BakeRequestError) as err:
        api.bake_normal_map(obj, str(out), space="object", resolution=RES, margin=0, log=None)
    text = str(err.value)
    assert "'Plane' is scaled unevenly" in text and "Apply > Scale" in text, text
    assert "--space tangent" in text and f"{worst_bend_deg(obj.matrix_world):.1f}" in text
    assert not out.exists() and not list(tmp_path.iterdir())


def test_blender_bends_an_unevenly_scaled_object_space_bake(tmp_path):
    """Finding 1, the Blender fact the refusal rests on (pinned per line: a line that fixes it
    fails here, and the refusal can go): Blender's own object-space bake under scale
    (2, 0.5, 1), read back by its own Object Space Normal Map node, is far off the normal
    baked (36.6 degrees measured), within worst_bend_deg's bound (61.9)."""
    obj, mat, normal = _scaled_plane((2.0, 0.5, 1.0))
    out = tmp_path / "raw.exr"
    NB.bake_normal_tiles(obj, str(out), space="object", resolution=RES, margin=0, log=lambda _: 0)
    off = _read_back_deg(obj, mat, normal, _centre(out), tmp_path)
    assert 20.0 < off < worst_bend_deg(obj.matrix_world), off


@pytest.mark.parametrize("scale", [(1.5, 1.5, 1.5), (-1.0, 1.0, 1.0)])
def test_an_evenly_scaled_object_space_bake_reads_back_right(tmp_path, scale):
    """Finding 1: a uniform or mirrored scale is baked (no refusal) and Blender's Object Space
    Normal Map node reads the map back as the normal baked."""
    obj, mat, normal = _scaled_plane(scale)
    out = tmp_path / "n.exr"
    api.bake_normal_map(obj, str(out), space="object", resolution=RES, margin=0, log=None)
    assert _read_back_deg(obj, mat, normal, _centre(out), tmp_path) < 0.05
