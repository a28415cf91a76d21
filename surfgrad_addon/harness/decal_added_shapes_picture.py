"""A picture of SG Decal's wedge and capsule (shapes 4 and 5) on curved surfaces, until the
decal-shapes exhibit of demo.blend (demo.py) lays out more than its four columns: each over a
fine detail map, the wedge added to it, the capsule overwriting it.

    python -c "from surfgrad_addon.harness.decal_added_shapes_picture import render; render('out')"
"""

import math

import numpy as np

from . import demo_scene as S
from .demo_pictures import render_pictures
from ..addon import groups as G
from ..reference import images as T
from ..reference.decals import DECAL_SHAPES

# (shape, overwrite): the wedge keeps the detail through it, the capsule replaces it.
ADDED_SHAPES = (("wedge", False), ("capsule", True))
PROJECTOR_SIZE = 0.62        # of the unit sphere: the decal's footprint across its front


def _decal_on_detail(proj, shape, overwrite, domes, detail):
    m = np.array(proj.matrix_world)[:3, :3]
    ax, ay = (tuple(m[:, k] / np.linalg.norm(m[:, k])) for k in range(2))

    def build(g):
        tc = g.node("ShaderNodeTexCoord", object=proj)
        uv = g.group(G.decal_coordinates_group(), Decal_Coordinates=tc.outputs["Object"])
        under = g.group(G.normal_map_group("UVMap"), Color=g.image(detail, g.uv("UVMap")),
                        Strength=0.6)
        node = g.group(G.decal_group(), Decal_Coordinates=tc.outputs["Object"],
                       Color=g.image(domes, uv.outputs[0], extension="CLIP"), Axis_X=ax,
                       Axis_Y=ay, Falloff=0.15, Shape=DECAL_SHAPES.index(shape),
                       Overwrite=overwrite, Base_Gradient=under.outputs[0])
        return g.resolve(node.outputs[0])
    return build


def build():
    """A fresh file with the two spheres, their projectors and a camera; returns the camera."""
    S.new_file()
    domes = S.image("Domes 128", T.hemisphere_tile_image(128, 2, 0.9))
    detail = S.image("Detail tile", T.hemisphere_tile_image(256, 8, 0.6))
    builds = []
    for (shape, overwrite), x in zip(ADDED_SHAPES, (-1.25, 1.25)):
        # Projection axis toward the camera (-Y), tilted: the decal across the curved front.
        proj = S.decal_projector(f"Decal {shape}", (x - 0.06, -0.5, 1.15),
                                 (math.radians(105), math.radians(12), math.radians(8)),
                                 (PROJECTOR_SIZE,) * 3)
        builds.append(_decal_on_detail(proj, shape, overwrite, domes, detail))
    a, b = S.pair(0.0, "Decal shapes 4 and 5", *builds, left_label="wedge, add",
                  right_label="capsule, overwrite")
    return S.camera("Camera decal-added-shapes", 0.0, crops=S.pair_crops(
        a, b, (0.0, -0.9, 0.1), ("wedge, add", "capsule, overwrite")))


def render(out_dir, **kw):
    """decal-added-shapes.png (and its crop) in out_dir; kw as render_pictures takes."""
    return render_pictures({"decal-added-shapes": build()}, out_dir, **kw)
