"""What a bench scenario is (a scene, its methods, an analytic truth: scenarios.py lists them)
and what the scenarios share: float images Cycles reads exactly, the exact height and
hemisphere-tile derivatives, a normal map baked from a truth, the sphere scene."""

from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from ... import reference as R
from ...reference import listings as L
from ...reference import methods as M
from ...reference import images as T


@dataclass
class Method:
    label: str
    family: str                                   # "sg" (ours), "blender", "baseline"
    build: Callable
    reference: Optional[Callable] = None
    memory_note: str = ""


@dataclass
class Context:
    objects: dict
    uv_map: str = "UVMap"
    images: dict = field(default_factory=dict)   # name -> (pixels, bpy image)
    params: dict = field(default_factory=dict)
    cleanup: list = field(default_factory=list)   # datablocks to remove afterwards

    def img(self, name):
        return self.images[name][1]

    def px(self, name):
        return self.images[name][0]


@dataclass
class Scenario:
    name: str
    title: str
    setup: Callable                               # (quick) -> Context
    methods: Callable                             # (ctx) -> [Method]
    truth: Callable                               # (ctx, td) -> unit normals (N, 3)


def float_image(ctx, name, pixels):
    """A Non-Color float image Cycles reads exactly, and the same pixels for the reference."""
    from ..compare import bpy_float_image
    img = bpy_float_image(name, pixels)
    ctx.cleanup.append(img)
    px = np.asarray(pixels, dtype=np.float32).astype(np.float64)
    ctx.images[name] = (px, img)
    return img


def exact_height_surfgrad(td, deriv_st, scale):
    """Blinn's perturbed normal of a continuous height given its exact (dH/ds, dH/dt), in
    surface-gradient form (Eq. 7 through Listing 6), on the shading normal."""
    n = M.unit_base_normal(td)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps()
    return n, scale * L.surfgrad_scale_dependent(n, dpdx, dpdy, deriv_st, dst_dx, dst_dy,
                                                 (1.0, 1.0))


def bake_normal_map_from_truth(mesh, uv_map, size, truth):
    """A tangent-space normal map of `size`^2 that encodes `truth(td)` (unit world normals) in
    the mesh's MikkTSpace frame at each texel centre: what a perfect bake from the detailed
    surface would store (float, not quantised). Texels off the mesh hold (0, 0, 1)."""
    td = R.rasterize(mesh, uv_map, size, size, sample_offset=(0.5, 0.5))
    n_f, t, b = M.mikktspace_frame(td, uv_map)
    v = truth(td)
    frame = np.stack([t, b, n_f], axis=-1)                    # columns t', b', n'
    m = np.linalg.solve(frame, v[..., None])[..., 0]
    m = m / np.linalg.norm(m, axis=-1, keepdims=True)
    out = np.tile([0.0, 0.0, 1.0], (size, size, 1))
    out[td.pixel[:, 1], td.pixel[:, 0]] = m
    return 0.5 * out + 0.5


def hemi_deriv(st, tiles=4, radius=0.85):
    """Listing 2 of the continuous hemisphere-tile normal: the exact derivative at st."""
    return L.tspace_normal_to_derivative(T.hemisphere_tile_normal(st, tiles, radius))


def sphere_context(quick):
    from .. import scenes
    return Context(objects=scenes.new_scene(["Sphere"]))
