"""The pieces demo.blend's exhibits are made of (demo.py): packed images, materials, labels,
meshes, a pair of objects (the usual way and the surface-gradient way), exhibit cameras with
the spots demo_pictures.py enlarges, decal projectors, and a fresh file with sky and sun."""

import json
import math

import numpy as np

from .graph import Graph
from ..addon import compat


def image(name, pixels):
    """A float image packed into the file (as OpenEXR: generated images need a format and a
    path before pack() keeps their pixels)."""
    import bpy
    px = np.asarray(pixels, dtype=np.float32)
    if px.ndim == 2:
        px = np.repeat(px[..., None], 3, axis=-1)
    h, w = px.shape[:2]
    px = np.concatenate([px[..., :3], np.ones((h, w, 1), np.float32)], axis=-1)
    img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    img.colorspace_settings.is_data = True
    img.pixels.foreach_set(px.ravel())
    img.file_format = "OPEN_EXR"
    img.filepath_raw = f"//{name}.exr"
    img.pack()
    return img


def material(name, build):
    """A Principled BSDF material whose Normal is build(g) (None: the plain normal)."""
    import bpy
    mat = compat.new_material(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.62, 0.6, 0.58, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.45
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    g = Graph(tree.nodes, tree.links)
    normal = build(g)
    if normal is not None:
        tree.links.new(normal, bsdf.inputs["Normal"])
    return mat


def label(text, location, size=0.32):
    import bpy
    curve = bpy.data.curves.new(text, "FONT")
    curve.body = text
    curve.size = size
    curve.align_x = "CENTER"
    obj = bpy.data.objects.new(f"Label: {text}", curve)
    obj.location = location
    obj.rotation_euler = (math.radians(90), 0, 0)
    bpy.context.scene.collection.objects.link(obj)
    curve.materials.append(label_material())
    return obj


def label_material():
    """Near-black matte text on the grey sky, in the renders (its node tree's Principled BSDF:
    every line makes one from 5.0) and in the viewport (diffuse_color)."""
    import bpy
    mat = bpy.data.materials.get("Label")
    if mat is None:
        mat = compat.new_material("Label")
        bsdf = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
        bsdf.inputs["Base Color"].default_value = (0.012, 0.012, 0.014, 1.0)
        bsdf.inputs["Roughness"].default_value = 1.0
        mat.diffuse_color = (0.05, 0.05, 0.05, 1)
    return mat


def mesh(kind, location, name, **kw):
    import bpy
    from . import scenes
    ops = bpy.ops.mesh
    if kind == "sphere":
        ops.primitive_uv_sphere_add(segments=48, ring_count=24, radius=1.0, location=location)
    elif kind == "rock":          # a dense UV sphere; SG Displace makes it a rock
        ops.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0, location=location)
    elif kind == "plane":
        ops.primitive_plane_add(size=2.2, location=location, rotation=(math.radians(70), 0, 0))
    elif kind == "torus":
        ops.primitive_torus_add(major_radius=0.8, minor_radius=0.3, location=location,
                                rotation=(1.1, 0, 0), generate_uvs=True)
    obj = bpy.context.active_object
    return scenes._finish(obj, name)


def pair(x, title, left, right, kind="sphere", left_label="usual", right_label="surface "
          "gradient", extra=None):
    """Two objects at x +- 1.2 with their materials and a label; returns the objects."""
    a = mesh(kind, (x - 1.25, 0, 1.1), f"{title} | {left_label}")
    b = mesh(kind, (x + 1.25, 0, 1.1), f"{title} | {right_label}")
    a.data.materials.append(material(f"{title}: {left_label}", left))
    b.data.materials.append(material(f"{title}: {right_label}", right))
    label(title, (x, 0, 2.65))
    label(left_label, (x - 1.25, 0, -0.25), 0.2)
    label(right_label, (x + 1.25, 0, -0.25), 0.2)
    return a, b


PAIR_DISTANCE = 8.4          # a pair with its title and labels in a 16:9 frame


def camera(name, x, z=1.2, distance=PAIR_DISTANCE, crops=(), ortho_scale=None,
           reference=None):
    """An exhibit camera looking along +Y. crops: (label, object, world offset from its centre)
    spots that render_pictures enlarges side by side (kept on the camera as JSON, so the saved
    file has them too). ortho_scale: an orthographic camera that wide (units). reference: the
    label of the crop the others are differenced against (an error row under the crops)."""
    import bpy
    cam = bpy.data.cameras.new(name)
    cam.lens = 50
    if ortho_scale:
        cam.type = "ORTHO"
        cam.ortho_scale = ortho_scale
    obj = bpy.data.objects.new(name, cam)
    obj.location = (x, -distance, z)
    obj.rotation_euler = (math.radians(90), 0, 0)
    bpy.context.scene.collection.objects.link(obj)
    if crops:
        obj[CROPS_KEY] = json.dumps([{"label": label, "object": o.name, "offset": list(off)}
                                     for label, o, off in crops])
    if reference:
        obj[CROP_REFERENCE_KEY] = reference
    return obj


CROPS_KEY = "surfgrad_crops"
CROP_REFERENCE_KEY = "surfgrad_crop_reference"
# A spot on the front of a unit sphere (camera at -Y), up and to the left, where the sun rakes.
FRONT_SPOT = (-0.38, -0.8, 0.42)


def pair_crops(a, b, offset, labels=("usual", "surface gradient")):
    return [(labels[0], a, offset), (labels[1], b, offset)]


def decal_projector(name, location, rotation, scale):
    import bpy
    from mathutils import Euler, Matrix
    empty = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(empty)
    empty.matrix_world = (Matrix.Translation(location) @ Euler(rotation).to_matrix().to_4x4()
                          @ Matrix.Diagonal((*scale, 1.0)))
    return empty


def new_file():
    """A fresh file: Cycles on the CPU, a grey sky and a raking sun."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    world = bpy.data.worlds.new("World")
    world.use_nodes = True if world.node_tree is None else world.use_nodes
    bg = world.node_tree.nodes.get("Background") if world.node_tree else None
    if bg is not None:
        bg.inputs["Color"].default_value = (0.55, 0.58, 0.62, 1.0)
        bg.inputs["Strength"].default_value = 0.9
    world.color = (0.55, 0.58, 0.62)
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 4.0
    sun.data.angle = math.radians(3)
    # Light from the camera's side, high and to the left: it rakes across the bumps.
    sun.rotation_euler = (math.radians(52), 0.0, math.radians(-48))
    scene.collection.objects.link(sun)
    return scene
