"""The freeze exhibit (docs/exhibits/freeze.png): a layered surface-gradient stack (SG Normal Map
of a tiled hemisphere map + SG Noise through SG Volume Gradient, added by SG Combine, resolved by
SG Resolve) on a dense sphere, next to a copy of it frozen by addon.freeze into one packed
tangent-space normal map, and a third panel of |live - frozen| amplified.

The camera is orthographic and the two spheres sit a whole number of pixels apart (at 1280 and
at 160 pixels wide), so under the one sun the two panels are the same pixels but for the
material: the difference panel is the left panel minus the middle one, pixel for pixel."""

import math
from pathlib import Path

import numpy as np

from ..addon import freeze as F, groups as G
from ..reference import images as T
from . import demo_scene as S

PICTURE = Path("docs") / "exhibits" / "freeze.png"
SIZE, SAMPLES = (1280, 720), 16
FREEZE_RESOLUTION = 512
ORTHO_WIDTH = 6.4                 # units across the frame: 200 px a unit at 1280, 25 at 160
SHIFT = 2.08                      # sphere to sphere: 416 px at 1280, 52 px at 160
RADIUS, CENTRE_Z, CAMERA_Z = 0.9, 0.35, 0.2
DIFF_GAIN = 10.0
LABELS = ("live stack", "frozen: one normal map", f"|live - frozen| x {DIFF_GAIN:g}")


def stack(g):
    """The layered stack's normal (what freeze_scene in the tests builds)."""
    source = S.image("Freeze exhibit source", T.hemisphere_tile_image(64, tiles=4))
    nm = g.group(G.normal_map_group("UVMap"), Color=g.image(source, g.uv("UVMap")))
    noise = g.group(G.noise_group(), Scale=3.0)
    volume = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                     Bump_Scale=0.15)
    combine = g.group(G.combine_group(), A=nm.outputs[0], B=volume.outputs[0])
    return g.resolve(combine.outputs[0])


def diffuse_material(name, build):
    """A Principled BSDF material (what artists freeze) whose Normal is build(g). Freeze
    bakes the stack through a Diffuse stand-in (addon/freeze.py), so the Principled
    BSDF's glossy closures do not flatten the map."""
    from ..addon import compat
    from .graph import Graph
    mat = compat.new_material(name)
    tree = mat.node_tree
    tree.nodes.clear()
    g = Graph(tree.nodes, tree.links)
    bsdf = g.node("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.62, 0.6, 0.58, 1.0)
    g.link(bsdf.outputs[0], g.node("ShaderNodeOutputMaterial").inputs["Surface"])
    g.link(build(g), bsdf.inputs["Normal"])
    return mat


def _sphere(name, x):
    import bpy
    bpy.ops.mesh.primitive_uv_sphere_add(segments=128, ring_count=64, radius=RADIUS,
                                         location=(x, 0, CENTRE_Z))
    from . import scenes
    return scenes._finish(bpy.context.active_object, name)


def build(resolution=FREEZE_RESOLUTION, log=lambda *_: None):
    """A fresh file with the live sphere, its frozen copy, labels and the camera; returns
    (live object, frozen object, camera)."""
    import bpy
    S.new_file()
    live = _sphere("Live stack", -SHIFT)
    live.data.materials.append(diffuse_material("Layered stack", stack))
    frozen = live.copy()
    frozen.data = live.data.copy()
    frozen.data.materials[0] = live.active_material.copy()
    frozen.name = frozen.data.name = "Frozen"
    frozen.data.materials[0].name = "Layered stack (frozen)"
    frozen.location.x = 0.0
    bpy.context.scene.collection.objects.link(frozen)
    bpy.context.view_layer.update()
    F.freeze(frozen, resolution=resolution, log=log)          # packed: no filepath
    for i, text in enumerate(LABELS):
        S.label(text, ((i - 1) * SHIFT, 0, CENTRE_Z - RADIUS - 0.4), 0.2)
    S.label("Freeze: the stack baked into one normal map", (0, 0, 1.65), 0.26)
    cam = S.camera("Camera freeze", 0.0, z=CAMERA_Z, ortho_scale=ORTHO_WIDTH)
    bpy.context.scene.camera = cam
    return live, frozen, cam


def render_pixels(size, samples, denoise=False, seed=0):
    """Render the open scene; (h, w, 3) float display-referred pixels, top row first."""
    import bpy
    import tempfile
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.cycles.samples = samples
    scene.cycles.seed = seed
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = denoise and bool(
        getattr(bpy.app.build_options, "openimagedenoise", False))
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_depth = "8"   # byte pixels read back as stored
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "freeze.png"
        scene.render.filepath = str(path)
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(str(path), check_existing=False)
        px = np.empty(size[0] * size[1] * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
        bpy.data.images.remove(img)
    return px.reshape(size[1], size[0], 4)[::-1, :, :3].astype(np.float64)


def panel_columns(width):
    """Column slices of the live, frozen and difference panels (SHIFT apart, centred)."""
    shift = int(round(SHIFT * width / ORTHO_WIDTH))
    centre = width // 2
    return [slice(centre + k * shift - shift // 2, centre + k * shift + shift // 2)
            for k in (-1, 0, 1)]


def panel_rows(height, width):
    """Row slice of the spheres' square (the panels' rows): the sphere's diameter, centred."""
    per_unit = width / ORTHO_WIDTH
    centre = height / 2 - (CENTRE_Z - CAMERA_Z) * per_unit
    half = int(math.ceil(RADIUS * per_unit)) + 1
    return slice(int(centre) - half, int(centre) + half)


def with_difference(px):
    """px with the right panel's sphere square replaced by |live - frozen| x DIFF_GAIN."""
    h, w = px.shape[:2]
    live, frozen, right = panel_columns(w)
    rows = panel_rows(h, w)
    diff = np.abs(px[rows, live] - px[rows, frozen]).mean(axis=-1, keepdims=True)
    out = px.copy()
    out[rows, right] = np.clip(diff * DIFF_GAIN, 0.0, 1.0)
    return out


def write_png(px, path):
    import bpy
    h, w = px.shape[:2]
    img = bpy.data.images.new("freeze exhibit", w, h, alpha=False)
    rgba = np.concatenate([px[::-1], np.ones((h, w, 1))], axis=-1).astype(np.float32)
    img.pixels.foreach_set(rgba.ravel())
    img.filepath_raw = str(Path(path).resolve())
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def render(path=PICTURE, samples=SAMPLES, size=SIZE, log=print):
    """Build the exhibit, render it (Cycles, CPU) and write `path` with the difference panel;
    returns the path. Replaces the open file."""
    build(log=lambda *_: None)
    px = with_difference(render_pixels(size, samples, denoise=True))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_png(px, path)
    log(f"rendered {path}")
    return path


if __name__ == "__main__":
    import sys
    render(sys.argv[1] if len(sys.argv) > 1 else PICTURE)
