"""A normal map baked through the api, read back as unit vectors, and the angle between two
such fields: what the bake-and-measure tests share."""

import numpy as np


def baked_normals(obj, path, space, resolution):
    """Bake obj's materials into `path` (space 'tangent' or 'object', no margin) and return
    its texels as (resolution, resolution, 3) unit vectors."""
    from surfgrad_addon import api
    api.bake_normal_map(obj, str(path), space=space, resolution=resolution, margin=0, log=None)
    return read_normals(path, resolution)


def read_normals(path, resolution):
    """A baked map's texels as (resolution, resolution, 3) unit vectors."""
    import bpy
    img = bpy.data.images.load(str(path))
    try:
        px = np.array(img.pixels[:]).reshape(resolution, resolution, 4)[..., :3] * 2.0 - 1.0
    finally:
        bpy.data.images.remove(img)
    return px / np.linalg.norm(px, axis=-1, keepdims=True)


def degrees_between(a, b):
    """Per texel, the angle in degrees between unit vectors a and b (..., 3)."""
    return np.degrees(np.arccos(np.clip((a * b).sum(-1), -1.0, 1.0)))
