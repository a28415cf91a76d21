"""Small procedural assets for batch bakes (tests and bench-batch): .blend files, one or more
mesh objects each, every object a grid of islands spread over UDIM tiles, with a
surface-gradient material (SG Normal Map of a packed procedural normal map -> SG Resolve ->
the BSDF's Normal). Built from code, so a fresh clone makes them in seconds."""

from pathlib import Path

import numpy as np

from ..addon import groups as G
from ..addon.compat import new_material
from ..reference import images as T
from .graph import Graph, surface_gradient


def _normal_image(bpy, name, size, kind, seed):
    """A packed Non-Color float image: the hemisphere tile map, or per-texel random normals
    (detail finer than a bake texel: what anti-aliasing is for)."""
    if kind == "noise":
        rng = np.random.default_rng(seed)
        m = rng.normal(size=(size, size, 3)) * [0.6, 0.6, 0.0] + [0, 0, 1]
        m /= np.linalg.norm(m, axis=-1, keepdims=True)
        pixels = 0.5 * m + 0.5
    else:
        pixels = T.hemisphere_tile_image(size, tiles=4)
    img = bpy.data.images.new(name, size, size, alpha=False, float_buffer=True)
    img.colorspace_settings.is_data = True
    rgba = np.concatenate([pixels, np.ones((size, size, 1))], axis=-1).astype(np.float32)
    img.pixels.foreach_set(rgba.ravel())
    img.pack()
    return img


def sg_material(bpy, name, image, uv_map="UVMap"):
    """SG Normal Map (on uv_map) of `image` resolved into a Diffuse BSDF's Normal."""
    mat = new_material(name)
    tree = mat.node_tree
    tree.nodes.clear()
    g = Graph(tree.nodes, tree.links)
    out = g.node("ShaderNodeOutputMaterial")
    bsdf = g.node("ShaderNodeBsdfDiffuse")
    g.link(bsdf.outputs["BSDF"], out.inputs["Surface"])
    color = g.image(image, g.uv(uv_map), interpolation="Closest")
    normal_map = g.group(G.normal_map_group(uv_map), Color=color)
    g.link(g.resolve(surface_gradient(normal_map)), bsdf.inputs["Normal"])
    return mat


def tiled_plane(bpy, name, tiles=(1001, 1002), uv_map="UVMap", offset=(0.0, 0.0)):
    """A mesh object of flat unit quads side by side in x, quad i's UVs filling UDIM tile
    tiles[i] (so its tangent frame is constant: the baked tangent map equals the source)."""
    verts, faces, uvs = [], [], []
    for i, tile in enumerate(tiles):
        u0, v0 = (tile - 1001) % 10, (tile - 1001) // 10
        x = 1.1 * i
        base = len(verts)
        verts += [(x, 0, 0), (x + 1, 0, 0), (x + 1, 1, 0), (x, 1, 0)]
        faces.append((base, base + 1, base + 2, base + 3))
        uvs += [(u0, v0), (u0 + 1, v0), (u0 + 1, v0 + 1), (u0, v0 + 1)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    layer = mesh.uv_layers.new(name=uv_map)
    layer.data.foreach_set("uv", np.asarray(uvs, dtype=np.float32).ravel())
    obj = bpy.data.objects.new(name, mesh)
    obj.location = (offset[0], offset[1], 0)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def write_asset(path, objects=("Asset",), tiles=(1001, 1002), image_size=64, kind="tiles",
                seed=0, uv_map="UVMap", collection=None):
    """Write a .blend at `path` holding `objects` (names), each a tiled_plane with its own SG
    material; with `collection`, they are linked into a collection of that name too."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    coll = None
    if collection:
        coll = bpy.data.collections.new(collection)
        bpy.context.scene.collection.children.link(coll)
    for k, name in enumerate(objects):
        obj = tiled_plane(bpy, name, tiles, uv_map, offset=(0, 2.0 * k))
        img = _normal_image(bpy, f"{name}_src", image_size, kind, seed + k)
        obj.data.materials.append(sg_material(bpy, f"{name}_SG", img, uv_map))
        if coll is not None:
            coll.objects.link(obj)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(path.resolve()), compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return path


def source_normals(image_size=64, kind="tiles", seed=0):
    """The unit normals the asset's map encodes, (size, size, 3), row 0 at v = 0."""
    if kind == "noise":
        rng = np.random.default_rng(seed)
        m = rng.normal(size=(image_size, image_size, 3)) * [0.6, 0.6, 0.0] + [0, 0, 1]
        return m / np.linalg.norm(m, axis=-1, keepdims=True)
    return T.hemisphere_tile_image(image_size, tiles=4) * 2 - 1


def write_assets(folder, count=4, overwrite=False):
    """`count` assets asset_000.blend ... in `folder` (one object Asset000 ... each, tiles 1001
    and 1002); refuses to replace files unless overwrite. Returns the paths."""
    if count < 1:
        raise ValueError(f"count {count}: give 1 or more assets")
    paths = [Path(folder) / f"asset_{i:03d}.blend" for i in range(count)]
    existing = [str(p) for p in paths if p.exists()]
    if existing and not overwrite:
        raise FileExistsError(f"{existing[0]} exists; pass --overwrite to replace it")
    return [write_asset(p, (f"Asset{i:03d}",), tiles=(1001, 1002), image_size=128, seed=i)
            for i, p in enumerate(paths)]
