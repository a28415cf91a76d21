"""Red team 54b: glTF input as a pipeline TD gets it from other tools, after the
KHR_mesh_quantization, KHR_materials_clearcoat / _anisotropy, sparse-accessor morph target,
multi-primitive and texCoord > 1 features of the glTF 2.0 specification (small glTF files
written by numpy, imported with Blender's glTF importer on 5.2, 5.0, 4.5 and 4.2; here rebuilt
in Blender by code, so no test reads a glTF file).

No product fault was confirmed this round; the fine case below is pinned, the lead is written
down (not rebuilt by code in time, so not pinned):

1. (fine, pinned) KHR_mesh_quantization positions (int16 with the node's scale: mesh
   coordinates up to 32767, object scale 3.05e-5 for a 2 m asset down to 3e-9 for 0.2 mm, and
   5 km from the origin): the scale changed nothing (imported, 5.2: the same 1.33 / 0.38
   degrees at every size, which is lead 2's; rebuilt here with float normals: within 0.5
   degrees, tangent and object space, on all four lines).
2. (lead, not fixed) Custom normals a little off the mesh's own smooth normals (int8 NORMAL
   data, 0.3 to 0.5 degrees from the surface's): on 4.5, 5.0 and 5.2 the tangent-space map
   differs from the image the Normal Map node reads by up to 1.3 to 1.4 degrees (mean 0.26) in
   the columns where the image's x leans least (4.2: 0.13, as without custom normals; clearing
   the custom normals gives 0.13 on 5.2). A morph target (shape key at 1.0, custom normals from
   the import) gave 2.3 degrees on 5.2 only (0.13 on 4.2, 4.5, 5.0). On 4.2 the quantized
   import's tangent map held (0.13) but its object-space map was 4.3 degrees off the
   analytic surface frame (5.2: 0.38), also not narrowed. The bake is Blender's
   (object.bake, tangent space): its tangent-space encoding and the Normal Map node's
   decoding seem to disagree on which normal the frame uses when custom normals are not the
   smooth ones. Rebuilt here by code (quads, int8-rounded custom normals, float UVs), the
   deviation did not appear (0.08 degrees on 5.2): the imported mesh differs (triangles from
   indices, uint16-normalized UVs such as 0.12500191, int16-rounded positions); not narrowed.

Probed and right on 5.2 and 4.2 (32^2 bakes against the glTF image's normals computed
independently): TANGENT attributes unnormalized (x3), w = 0, all zero and w = -1 (the importer
ignores TANGENT; Blender's MikkTSpace frame is used: 0.13 degrees); a node scale
uneven per axis (object-space bake refused naming the fix, tangent 0.14); TEXCOORD_2 as the
normal texture's texCoord (baked on 'UVMap.002': 0.13); two primitives sharing one vertex
buffer with two materials (0.13); KHR_materials_clearcoat's clearcoatNormalTexture plus
KHR_materials_anisotropy (two Normal Map nodes and a Tangent node: 0.13; the coat has the same
map, so no coat warning is due); unnormalized uint16 UVs dequantized by KHR_texture_transform
(gltfpack's layout: UVs up to 1023 on the mesh, refused naming <UDIM> or tile 1001, exit 2).
"""

import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

CELLS = 8
SIZE = 32
N_IMAGE = 64


def _wave(u, v):
    """The tangent-space normal the test image holds at (u, v): tilts up to 27 degrees."""
    nx = 0.45 * np.cos(2 * np.pi * u)
    ny = 0.45 * np.sin(2 * np.pi * v)
    return np.stack([nx, ny, np.sqrt(1.0 - nx * nx - ny * ny)], -1)


def _frame(x):
    """The surface z = 0.3 sin(1.2 x)'s unit tangent (along u), bitangent and normal."""
    a = 0.36 * np.cos(1.2 * x)
    k = np.sqrt(1 + a * a)
    zero = np.zeros_like(a)
    return (np.stack([1 / k, zero, a / k], -1), np.stack([zero, zero + 1, zero], -1),
            np.stack([-a / k, zero, 1 / k], -1))


def _grid(coordinate_scale=1.0, object_scale=1.0):
    """The importer's result for a curved grid over UV [0, 1]^2: Image Texture (Non-Color,
    float) -> Normal Map ('UVMap') -> Principled BSDF; positions stored times
    coordinate_scale with the object scaled by object_scale (KHR_mesh_quantization's node
    scale); custom normals the surface's, as the importer sets them from NORMAL data."""
    bpy = pytest.importorskip("bpy")
    from support.materials import normal_map_material, packed_normal_image
    bpy.ops.wm.read_factory_settings(use_empty=True)
    xs = np.linspace(-1.0, 1.0, CELLS + 1)
    X, Y = np.meshgrid(xs, xs, indexing="xy")
    x, y = X.ravel(), Y.ravel()
    verts = np.stack([x, y, 0.3 * np.sin(1.2 * x)], -1) * coordinate_scale
    w = CELLS + 1
    faces = [(j * w + i, j * w + i + 1, (j + 1) * w + i + 1, (j + 1) * w + i)
             for j in range(CELLS) for i in range(CELLS)]
    mesh = bpy.data.meshes.new("Grid")
    mesh.from_pydata(verts.tolist(), [], faces)
    uv = mesh.uv_layers.new(name="UVMap")
    for loop in mesh.loops:
        vi = loop.vertex_index
        uv.data[loop.index].uv = ((x[vi] + 1) / 2, (y[vi] + 1) / 2)
    for p in mesh.polygons:
        p.use_smooth = True
    # the importer sets NORMAL as custom normals
    mesh.normals_split_custom_set_from_vertices(_frame(x)[2].tolist())
    obj = bpy.data.objects.new("Grid", mesh)
    obj.scale = (object_scale,) * 3
    bpy.context.scene.collection.objects.link(obj)
    c = (np.arange(N_IMAGE) + 0.5) / N_IMAGE
    v, u = np.meshgrid(c, c, indexing="ij")
    mat, _ = normal_map_material("Mat", packed_normal_image("wave", _wave(u, v) * 0.5 + 0.5))
    mesh.materials.append(mat)
    bpy.context.view_layer.update()
    return obj


def _baked(obj, path, space):
    import bpy
    from surfgrad_addon import api
    api.bake_normal_map(obj, str(path), space=space, resolution=SIZE, margin=0, samples=1,
                        log=None)
    img = bpy.data.images.load(str(path))
    px = np.empty(SIZE * SIZE * 4, np.float32)
    img.pixels.foreach_get(px)
    got = px.reshape(SIZE, SIZE, 4)[..., :3] * 2.0 - 1.0
    return got / np.linalg.norm(got, axis=-1, keepdims=True)


def _expected(space):
    c = (np.arange(SIZE) + 0.5) / SIZE
    v, u = np.meshgrid(c, c, indexing="ij")
    t = _wave(u, v)
    if space == "tangent":
        return t
    tan, bit, nrm = _frame(2 * u - 1)
    return t[..., :1] * tan + t[..., 1:2] * bit + t[..., 2:] * nrm


def _angles(got, want):
    return np.degrees(np.arccos(np.clip((got * want).sum(-1), -1.0, 1.0)))


@pytest.mark.parametrize("size", [0.1, 1e-4])
@pytest.mark.parametrize("space", ["tangent", "object"])
def test_quantized_positions_with_a_node_scale_bake_the_image(tmp_path, size, space):
    """1: int16 positions (mesh coordinates up to 32767) under the node scale size / 32767:
    the map holds the image's normals (tangent) or their object-space turn (object) within
    0.5 degrees; the image leans up to 27 degrees, so a flat map would be far off."""
    obj = _grid(coordinate_scale=32767.0, object_scale=size / 32767.0)
    want = _expected(space)
    err = _angles(_baked(obj, tmp_path / f"q_{space}.exr", space), want)
    assert err.max() < 0.5, err.max()
    assert np.degrees(np.arccos(_expected("tangent")[..., 2])).max() > 25

