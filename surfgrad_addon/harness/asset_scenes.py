"""Meshes as artists unwrap them, built by code: the cases the procedural scenes (scenes.py)
do not cover. Each builder adds one object to the current scene and returns it.

- mirrored_halves: a deformed grid whose left half's UVs are its right half's mirrored onto
  them (stacked islands, as most game assets are unwrapped), a middle strip unshared;
- mirror_modifier: the right half of a deformed grid with a Mirror modifier (the copy keeps
  the UVs: every texel of it is claimed twice);
- offset_islands: a grid whose right half's island lies on the next UDIM tile (u + 1);
- outside_uvs: a grid whose every UV lies below 0 (nothing inside any bake target);
- smart_uv: a subdivided, noise-deformed cube unwrapped with Smart UV Project (many small
  islands);
- flat_subdivided: a subdivided, deformed cube shaded flat (non-planar quads);
- modifier_stack: a bent grid with Mirror, Subdivision and Array modifiers, smooth.

Smooth shading unless stated; the UV map is "UVMap"; no material.
"""

import numpy as np

ASSETS = ("mirrored_halves", "mirror_modifier", "offset_islands", "smart_uv",
          "flat_subdivided", "modifier_stack")


def _link(name, mesh):
    import bpy
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    return obj


def _grid(name, nx=16, ny=12, x0=-1.0, x1=1.0, bend=0.35, seed=0):
    """A grid over x0..x1 x -0.75..0.75 with a smooth bump and a little noise (non-planar
    quads), UVs = the x, y position scaled into 0..1 over the full -1..1 width."""
    import bpy
    rng = np.random.default_rng(seed)
    xs, ys = np.linspace(x0, x1, nx + 1), np.linspace(-0.75, 0.75, ny + 1)
    gx, gy = np.meshgrid(xs, ys)
    z = bend * np.exp(-2 * (gx ** 2 + gy ** 2)) + 0.08 * np.sin(3 * gx) * np.cos(4 * gy)
    z = z + rng.normal(0, 0.01, z.shape)
    verts = np.stack([gx, gy, z], -1).reshape(-1, 3)
    faces = [(j * (nx + 1) + i, j * (nx + 1) + i + 1, (j + 1) * (nx + 1) + i + 1,
              (j + 1) * (nx + 1) + i) for j in range(ny) for i in range(nx)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts.tolist(), [], faces)
    uv = mesh.uv_layers.new(name="UVMap")
    corner_v = np.array([v for f in faces for v in f])
    p = verts[corner_v]
    uvs = np.stack([(p[:, 0] + 1) / 2 * 0.9 + 0.05, (p[:, 1] + 0.75) / 1.5 * 0.9 + 0.05], -1)
    uv.uv.foreach_set("vector", uvs.ravel())
    mesh.polygons.foreach_set("use_smooth", np.ones(len(faces), dtype=bool))
    mesh.update()
    return mesh


def _uvs(mesh):
    uv = np.empty(len(mesh.loops) * 2)
    mesh.uv_layers["UVMap"].uv.foreach_get("vector", uv)
    return uv.reshape(-1, 2)


def _set_uvs(mesh, uv):
    mesh.uv_layers["UVMap"].uv.foreach_set("vector", np.ascontiguousarray(uv).ravel())
    mesh.update()


def _face_of_loop(mesh):
    return np.repeat(np.arange(len(mesh.polygons)), [p.loop_total for p in mesh.polygons])


def mirrored_halves(name="MirroredHalves"):
    mesh = _grid(name)
    uv = _uvs(mesh)
    centre = np.array([p.center.x for p in mesh.polygons])[_face_of_loop(mesh)]
    left = centre < -0.25                      # x < -0.25 onto x > 0.25; the middle unshared
    uv[left, 0] = 1.0 - uv[left, 0]
    _set_uvs(mesh, uv)
    return _link(name, mesh)


def mirror_modifier(name="MirrorModifier"):
    obj = _link(name, _grid(name, nx=8, x0=0.0, x1=1.0))
    mod = obj.modifiers.new("Mirror", "MIRROR")
    mod.use_axis[0] = True
    mod.use_mirror_merge = True
    return obj


def offset_islands(name="OffsetIslands"):
    mesh = _grid(name)
    uv = _uvs(mesh)
    centre = np.array([p.center.x for p in mesh.polygons])[_face_of_loop(mesh)]
    right = centre > 0
    uv[right, 0] += 1.0                          # onto UDIM tile 1002
    _set_uvs(mesh, uv)
    return _link(name, mesh)


def outside_uvs(name="OutsideUVs"):
    mesh = _grid(name, nx=4, ny=4)
    _set_uvs(mesh, _uvs(mesh) - 2.0)
    return _link(name, mesh)


def _deformed_cube(name, cuts, amount, seed):
    import bmesh
    import bpy
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.6)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=cuts, use_grid_fill=True)
    rng = np.random.default_rng(seed)
    k = rng.normal(0, 1, (4, 3))
    for v in bm.verts:
        p = np.array(v.co)
        v.co = p * (1 + amount * np.sin(p @ k[0] * 2) + 0.5 * amount * np.cos(p @ k[1] * 3))
    bm.to_mesh(mesh)
    bm.free()
    mesh.uv_layers.new(name="UVMap")
    return mesh


def _unwrap_smart(obj):
    import bpy
    view_layer = bpy.context.view_layer
    active = view_layer.objects.active
    view_layer.objects.active = obj
    obj.select_set(True)
    try:
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.uv.smart_project(angle_limit=np.radians(66), island_margin=0.02)
        bpy.ops.object.mode_set(mode="OBJECT")
    finally:
        obj.select_set(False)
        view_layer.objects.active = active


def smart_uv(name="SmartUV"):
    mesh = _deformed_cube(name, cuts=6, amount=0.18, seed=3)
    mesh.polygons.foreach_set("use_smooth", np.ones(len(mesh.polygons), dtype=bool))
    obj = _link(name, mesh)
    _unwrap_smart(obj)
    return obj


def flat_subdivided(name="FlatSubdivided"):
    mesh = _deformed_cube(name, cuts=3, amount=0.25, seed=5)
    mesh.polygons.foreach_set("use_smooth", np.zeros(len(mesh.polygons), dtype=bool))
    obj = _link(name, mesh)
    _unwrap_smart(obj)
    return obj


def modifier_stack(name="ModifierStack"):
    obj = _link(name, _grid(name, nx=6, ny=6, x0=0.0, x1=0.6, bend=0.5, seed=2))
    mirror = obj.modifiers.new("Mirror", "MIRROR")
    mirror.use_axis[0] = True
    mirror.mirror_offset_u = 0.0
    mirror.use_mirror_u = True                 # the copy's UVs flipped about u = 0.5
    sub = obj.modifiers.new("Subdivision", "SUBSURF")
    sub.levels = sub.render_levels = 1
    array = obj.modifiers.new("Array", "ARRAY")
    array.count = 2
    array.relative_offset_displace = (0, 1.1, 0)
    array.offset_v = 0.0
    return obj


BUILDERS = {"mirrored_halves": mirrored_halves, "mirror_modifier": mirror_modifier,
            "offset_islands": offset_islands, "outside_uvs": outside_uvs,
            "smart_uv": smart_uv, "flat_subdivided": flat_subdivided,
            "modifier_stack": modifier_stack}
