"""Small Cycles renders of every demo.blend exhibit (the README's before/after pictures), each
with an enlarged crop of the spots its camera names (demo_scene.camera's crops)."""

import json
import math
from pathlib import Path

import numpy as np

from .demo_scene import CROP_REFERENCE_KEY, CROPS_KEY

PICTURE_SIZE = (1280, 720)
PICTURE_SAMPLES = 16         # with the denoiser: clean enough, and 2 shared cores can afford it
CROP_PIXELS = 150            # the square cut around each spot, shown about twice as large
ERROR_SCALE = 0.12           # the error row's colour range: |difference| in display values


def render_pictures(cams, out_dir, width=PICTURE_SIZE[0], height=PICTURE_SIZE[1],
                    samples=PICTURE_SAMPLES, log=print):
    """A Cycles CPU render of every exhibit (PNG, 1280 x 720 by default: the labels are
    readable at that size) into out_dir, and beside it <name>_crop.png: the camera's crop spots
    enlarged side by side, labelled (needs matplotlib; skipped with a note without it)."""
    import bpy
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    # The denoiser (guided by the albedo and normal passes, so bumps stay) where this Cycles
    # build has one; otherwise plain samples.
    scene.cycles.use_denoising = bool(getattr(bpy.app.build_options, "openimagedenoise", False))
    scene.render.image_settings.file_format = "PNG"
    paths = []
    for i, (name, cam) in enumerate(cams.items()):
        scene.camera = cam
        path = out / f"{name}.png"
        scene.render.filepath = str(path.resolve())
        bpy.ops.render.render(write_still=True)
        paths.append(path)
        crop = _crop_picture(scene, cam, path, out / f"{name}_crop.png", log)
        if crop:
            paths.append(crop)
        log(f"  rendered {i + 1}/{len(cams)}: {path}" + (f" and {crop.name}" if crop else ""))
    return paths


def crop_boxes(scene, cam, width, height, size=CROP_PIXELS):
    """[(label, (x0, y0)) ...]: each crop spot's square in pixels (x from the left, y from the
    bottom, Blender's pixel order), kept inside the picture."""
    from bpy_extras.object_utils import world_to_camera_view
    import bpy
    from mathutils import Vector
    spots = json.loads(cam.get(CROPS_KEY, "[]"))
    boxes = []
    for spot in spots:
        obj = bpy.data.objects[spot["object"]]
        p = world_to_camera_view(scene, cam, obj.location + Vector(spot["offset"]))
        x0 = int(round(p.x * width - size / 2))
        y0 = int(round(p.y * height - size / 2))
        boxes.append((spot["label"], (min(max(x0, 0), width - size),
                                      min(max(y0, 0), height - size))))
    return boxes


def _crop_picture(scene, cam, picture, path, log, size=CROP_PIXELS):
    if CROPS_KEY not in cam:
        return None
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        log("  matplotlib is not installed: no enlarged crops")
        return None
    import bpy
    img = bpy.data.images.load(str(picture), check_existing=False)
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    px = px.reshape(h, w, 4)[..., :3]
    boxes = crop_boxes(scene, cam, w, h, size)
    crops = [(label, np.clip(px[y0:y0 + size, x0:x0 + size], 0, 1))
             for label, (x0, y0) in boxes]
    reference = dict(crops).get(cam.get(CROP_REFERENCE_KEY))
    cols = min(len(crops), 4)
    rows = math.ceil(len(crops) / cols) + (reference is not None)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.75 * rows), dpi=100,
                             squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (label, crop) in zip(axes.ravel(), crops):
        ax.imshow(crop, origin="lower", interpolation="nearest")
        ax.set_title(label, fontsize=13)
    if reference is not None:
        # The last row: each crop's difference to the reference's (same pixels: the camera
        # sees every object alike), on one colour scale.
        for ax, (label, crop) in zip(axes[-1], crops):
            if crop is reference:
                continue
            err = crop_error(crop, reference)
            im = ax.imshow(err, origin="lower", interpolation="nearest", cmap="magma",
                           vmin=0.0, vmax=ERROR_SCALE)
            ax.set_title(f"|{label} - {cam[CROP_REFERENCE_KEY]}|", fontsize=12)
        fig.colorbar(im, ax=list(axes[-1]), fraction=0.02, pad=0.01)
    fig.suptitle(f"{cam.name.replace('Camera ', '')}: enlarged crops", fontsize=14)
    if reference is None:
        fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.94))
    fig.savefig(path)
    plt.close(fig)
    return path


def crop_error(crop, reference):
    """Per pixel |crop - reference|, the largest over the colour channels."""
    return np.abs(np.asarray(crop) - np.asarray(reference)).max(axis=-1)
