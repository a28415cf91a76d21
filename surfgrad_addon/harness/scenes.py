"""Small procedural test scenes built by code in the current Blender session.

Every object has its primitive's UV map "UVMap" and a second map "Detail" (the first rotated by
30 degrees about the centre and tiled twice, as in the reference's meshes), smooth shading,
and no material. The torus's "UVMap" also has a rotated and a mirrored island.
"""

import numpy as np

from ..reference.meshes import detail_uv

SCENE_OBJECTS = ("Sphere", "Torus", "Plane", "Transformed")


def _uv_array(mesh, name):
    layer = mesh.uv_layers[name]
    uv = np.empty(len(mesh.loops) * 2)
    layer.uv.foreach_get("vector", uv)
    return uv.reshape(-1, 2)


def _set_uv_array(mesh, name, uv):
    layer = mesh.uv_layers.get(name) or mesh.uv_layers.new(name=name)
    layer.uv.foreach_set("vector", np.ascontiguousarray(uv, dtype=np.float64).ravel())


def _finish(obj, name):
    import bpy
    obj.name = name
    obj.data.name = name
    mesh = obj.data
    mesh.uv_layers[0].name = "UVMap"
    mesh.polygons.foreach_set("use_smooth", np.ones(len(mesh.polygons), dtype=bool))
    _set_uv_array(mesh, "Detail", detail_uv(_uv_array(mesh, "UVMap")))
    mesh.uv_layers.active = mesh.uv_layers["UVMap"]
    mesh.update()
    bpy.context.view_layer.update()
    return obj


def _split_torus_islands(mesh):
    """Rotate the UVs of faces in the lower-left quadrant by 90 degrees about its centre and
    mirror those in the lower-right quadrant about its vertical centre line: two islands of
    opposite orientation to the rest."""
    uv = _uv_array(mesh, "UVMap")
    loop_face = np.repeat(np.arange(len(mesh.polygons)),
                          [p.loop_total for p in mesh.polygons])
    centroid = np.zeros((len(mesh.polygons), 2))
    np.add.at(centroid, loop_face, uv)
    centroid /= np.bincount(loop_face)[:, None]
    lower = centroid[:, 1] < 0.5
    rot = (lower & (centroid[:, 0] < 0.5))[loop_face]
    mir = (lower & (centroid[:, 0] >= 0.5))[loop_face]
    c = np.array([0.25, 0.25])
    d = uv[rot] - c
    uv[rot] = c + np.stack([-d[:, 1], d[:, 0]], axis=-1)
    uv[mir, 0] = 1.5 - uv[mir, 0]
    _set_uv_array(mesh, "UVMap", uv)


def build(objects=SCENE_OBJECTS):
    """Add the named test objects to the current scene; returns {name: object}."""
    import bpy

    made = {}
    ops = bpy.ops.mesh
    if "Sphere" in objects:
        ops.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0, calc_uvs=True)
        made["Sphere"] = _finish(bpy.context.active_object, "Sphere")
    if "Torus" in objects:
        ops.primitive_torus_add(major_segments=32, minor_segments=12, major_radius=1.0,
                                minor_radius=0.4, generate_uvs=True, location=(3, 0, 0))
        obj = bpy.context.active_object
        _split_torus_islands(obj.data)
        made["Torus"] = _finish(obj, "Torus")
    if "Plane" in objects:
        ops.primitive_plane_add(size=2.0, location=(0, 3, 0), calc_uvs=True)
        made["Plane"] = _finish(bpy.context.active_object, "Plane")
    if "Transformed" in objects:
        ops.primitive_uv_sphere_add(segments=24, ring_count=12, radius=1.0, calc_uvs=True,
                                    location=(3, 3, 0), rotation=(0.4, -0.7, 1.1))
        obj = bpy.context.active_object
        obj.scale = (1.6, 0.6, 1.1)      # an object transform (the operator's scale is baked
        made["Transformed"] = _finish(obj, "Transformed")   # into the mesh)
    return made


def decal_stage():
    """A torus tilted through a plane (the paper's Figure 6 set-up); returns {name: object}."""
    import bpy
    ops = bpy.ops.mesh
    ops.primitive_torus_add(major_segments=48, minor_segments=16, major_radius=0.8,
                            minor_radius=0.3, rotation=(1.1, 0.0, 0.0), generate_uvs=True)
    torus = _finish(bpy.context.active_object, "DecalTorus")
    ops.primitive_plane_add(size=3.0, calc_uvs=True)
    plane = _finish(bpy.context.active_object, "DecalPlane")
    return {"DecalTorus": torus, "DecalPlane": plane}


def new_scene(objects=SCENE_OBJECTS):
    """A fresh empty Blender session holding the test objects."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return build(objects)
