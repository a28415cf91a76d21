"""The height-blend exhibit (harness/exhibit_height_blend.py): both planes carry the same two
layers, the left through SG Combine and a mask of its own, the right through SG Height Blend
whose Weight B colours it; a small render shows rock and sand on both."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import exhibit_height_blend as X  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _groups(obj):
    return {n.node_tree.name for n in obj.active_material.node_tree.nodes
            if n.bl_idname == "ShaderNodeGroup"}


def test_the_exhibit_renders_both_blends(tmp_path):
    path = X.render_height_blend(tmp_path / "hb.png", samples=2, size=(128, 72),
                                 log=lambda *_: None)
    left = bpy.data.objects["Sand on cobbles | masked mix (SG Combine)"]
    right = bpy.data.objects["Sand on cobbles | height blend (SG Height Blend)"]
    assert {"SG Combine", "SG Height Map Forward", "SG Volume Gradient"} <= _groups(left)
    assert "SG Height Blend" not in _groups(left)
    assert {"SG Height Blend", "SG Height Map Forward", "SG Volume Gradient"} <= _groups(right)
    blend = next(n for n in right.active_material.node_tree.nodes
                 if getattr(n, "node_tree", None) and n.node_tree.name == "SG Height Blend")
    assert blend.outputs["Weight B"].is_linked and blend.outputs["Surface Gradient"].is_linked
    img = bpy.data.images.load(str(path))
    assert tuple(img.size) == (128, 72)
    px = np.array(img.pixels[:]).reshape(72, 128, 4)[::-1, :, :3]      # top row first
    # Each plane shows rock (grey) and sand (red well above blue) in its middle band.
    for x0, x1 in ((20, 55), (73, 108)):
        band = px[25:55, x0:x1]
        sandy = (band[..., 0] - band[..., 2]) > 0.08
        assert 0.05 < sandy.mean() < 0.95, (x0, sandy.mean())
