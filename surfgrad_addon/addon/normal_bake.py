"""Bake an object's material (surface-gradient groups or anything else) into a normal map file.

For pipeline TDs, headless:

    blender -b scene.blend --python surfgrad_addon/bake_normal_map.py -- \\
        --object Rock --output rock_normal.png --space tangent --resolution 2048
    python -m surfgrad_addon bake-normal-map --blend scene.blend --object Rock \\
        --output rock_normal.exr --space object

Cycles (CPU) bakes type NORMAL through the object's own materials into a new image, saved as
PNG (8-bit) or OpenEXR (float) by the output's extension. Tangent space uses the chosen UV map's
MikkTSpace tangents (it is made the active UV map for the bake, then restored). Everything the
bake touches (render settings, active UV map, active nodes) is put back; the temporary image
and nodes are removed; an existing file is only replaced with overwrite.
"""

import time
from pathlib import Path

from .scene_state import SCENE_SETTINGS, restored

SPACES = {"tangent": "TANGENT", "object": "OBJECT"}
RESOLUTION_RANGE = (4, 16384)        # texels per side: a map, and an image Blender can hold


def resolution_problem(resolution, lo, hi):
    """None for a whole number of texels in [lo, hi], else what is wrong with it."""
    if isinstance(resolution, bool) or not isinstance(resolution, int) or \
            not lo <= resolution <= hi:
        return f"resolution {resolution!r}: use a whole number of texels from {lo} to {hi}"
    return None
FORMATS = {".png": ("PNG", False), ".exr": ("OPEN_EXR", True)}


class NormalBakeError(ValueError):
    """Bad input: the message names the thing and the fix."""


def bake_normal_map(obj, output, space="tangent", resolution=1024, uv_map=None, margin=16,
                    samples=1, overwrite=False, log=print):
    """Bake obj's materials to a normal map file at `output`. Returns the written path."""
    import bpy

    output = Path(output)
    if output.is_dir():
        raise NormalBakeError(f"output {str(output)!r} is a folder: give a file name in it")
    if output.suffix.lower() not in FORMATS:
        raise NormalBakeError(f"output {str(output)!r}: use a .png or .exr file name")
    if not output.parent.is_dir():
        raise NormalBakeError(f"output folder {str(output.parent)!r} does not exist: create it "
                              f"first")
    problem = resolution_problem(resolution, *RESOLUTION_RANGE)
    if problem:
        raise NormalBakeError(problem)
    if output.exists() and not overwrite:
        raise NormalBakeError(f"{output} exists; pass --overwrite to replace it")
    if space not in SPACES:
        raise NormalBakeError(f"space {space!r}: use one of {sorted(SPACES)}")
    if obj is None or obj.type != "MESH":
        raise NormalBakeError("pick a mesh object to bake (--object NAME)")
    mesh = obj.data
    names = [uv.name for uv in mesh.uv_layers]
    if not names:
        raise NormalBakeError(f"object {obj.name!r} has no UV map; unwrap it first")
    uv_map = uv_map or next((uv.name for uv in mesh.uv_layers if uv.active_render), names[0])
    if uv_map not in names:
        raise NormalBakeError(f"object {obj.name!r} has no UV map {uv_map!r}; it has {names}")
    materials = [s.material for s in obj.material_slots if s.material is not None]
    if not materials:
        raise NormalBakeError(f"object {obj.name!r} has no material to bake")
    fmt, is_float = FORMATS[output.suffix.lower()]
    scene = bpy.context.scene
    log(f"[1/3] preparing {obj.name}: {space} space, {resolution}x{resolution}, UV map "
        f"{uv_map!r}, {len(materials)} material(s)")
    image = bpy.data.images.new(f"{obj.name}_normal", resolution, resolution, alpha=False,
                                float_buffer=is_float)
    image.colorspace_settings.name = "Non-Color"
    added = []
    settings = SCENE_SETTINGS + ("render.bake.normal_space",)
    try:
        for mat in materials:
            tree = mat.node_tree
            node = tree.nodes.new("ShaderNodeTexImage")
            node.image = image
            added.append((tree, node, tree.nodes.active))
            tree.nodes.active = node
        active_uv = mesh.uv_layers.active.name
        with restored(scene, settings):
            scene.render.engine = "CYCLES"
            scene.cycles.device = "CPU"
            scene.cycles.samples = samples
            scene.cycles.use_denoising = False
            scene.render.bake.target = "IMAGE_TEXTURES"
            scene.render.bake.use_selected_to_active = False
            mesh.uv_layers.active = mesh.uv_layers[uv_map]
            selection = [o for o in bpy.context.view_layer.objects if o.select_get()]
            active_obj = bpy.context.view_layer.objects.active
            try:
                for o in bpy.context.view_layer.objects:
                    o.select_set(o == obj)
                bpy.context.view_layer.objects.active = obj
                log("[2/3] baking with Cycles (CPU) ...")
                t0 = time.perf_counter()
                result = bpy.ops.object.bake(type="NORMAL", normal_space=SPACES[space],
                                             uv_layer=uv_map, margin=margin, use_clear=True)
                log(f"      baked in {time.perf_counter() - t0:.2f} s")
            finally:
                mesh.uv_layers.active = mesh.uv_layers[active_uv]
                for o in bpy.context.view_layer.objects:
                    o.select_set(o in selection)
                bpy.context.view_layer.objects.active = active_obj
        if result != {"FINISHED"}:
            raise NormalBakeError(f"the bake of {obj.name!r} did not finish ({result})")
        output.parent.mkdir(parents=True, exist_ok=True)
        image.filepath_raw = str(output.resolve())
        image.file_format = fmt
        image.save()
        log(f"[3/3] wrote {output}")
        return output
    finally:
        for tree, node, previous in added:
            tree.nodes.remove(node)
            tree.nodes.active = previous
        bpy.data.images.remove(image)
