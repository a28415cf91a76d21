"""The bakes a colour configuration could touch, on one small scene: a layered surface-gradient
stack (tests/support/freeze_scene.py) on an 8 x 6 sphere, baked by api.bake_normal_map into a
tangent-space 8-bit PNG and a half EXR, frozen (a 16-bit PNG) and compared with the reference;
then its normal map tagged sRGB, and the warning that gives.
`python colour_bakes.py FOLDER` runs them in a child (a colour configuration is read once, at
Blender's start: OCIO) and prints their results as JSON; a test runs them in its own process too
and compares the two."""

import json
import sys
from pathlib import Path

import bpy
import numpy as np

SIZE = 16
FILES = ("tangent.png", "tangent.exr", "frozen.png")


def colour_spaces():
    image = bpy.data.images.new("probe", 4, 4)
    try:
        prop = image.colorspace_settings.bl_rna.properties["name"]
        return [item.identifier for item in prop.enum_items]
    finally:
        bpy.data.images.remove(image)


def pixels(path):
    """A written map's RGB as stored, read as data."""
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        image.colorspace_settings.is_data = True
        px = np.empty(image.size[0] * image.size[1] * 4, np.float32)
        image.pixels.foreach_get(px)
        return px.reshape(-1, 4)[:, :3]
    finally:
        bpy.data.images.remove(image)


def bake_all(folder):
    from surfgrad_addon import api
    from surfgrad_addon.addon import freeze as F
    from surfgrad_addon.harness import compare
    from support.freeze_scene import layered_material
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=8, ring_count=6, calc_uvs=True)
    obj = bpy.context.active_object
    obj.data.uv_layers[0].name = "UVMap"
    bpy.ops.object.shade_smooth()
    layered_material(obj)
    quiet = dict(log=None, resolution=SIZE, margin=0)
    api.bake_normal_map(obj, str(folder / FILES[0]), depth="8", **quiet)
    api.bake_normal_map(obj, str(folder / FILES[1]), depth="half", **quiet)
    record = F.freeze(obj, SIZE, filepath=str(folder / FILES[2]))
    frozen_is_data = bpy.data.images[record["image"]].colorspace_settings.is_data
    F.thaw(obj.active_material)
    report, _ = compare.compare_object(obj, "normal-map", SIZE, log=None)
    # The artist's slip: the map tagged with the configuration's sRGB, and the fix named.
    spaces = colour_spaces()
    srgb = next(name for name in ("sRGB", "srgb_tx") if name in spaces)
    bpy.data.images["Layered_source"].colorspace_settings.name = srgb
    from surfgrad_addon.addon.normal_map_checks import colour_space_warnings
    return {"spaces": spaces, "warnings": colour_space_warnings(obj),
            "frozen_is_data": frozen_is_data, "p99": report["p99_deg"],
            "max": report["max_deg"], "compared": report["texels_compared"]}


if __name__ == "__main__":
    print(json.dumps(bake_all(sys.argv[1])))
