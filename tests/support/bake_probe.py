"""Helpers for pinning the numpy reference against real Cycles bakes through `import bpy`.

A probe is one EMIT bake of a unit plane whose UV map covers [0, 1]^2 exactly: whatever
colour is routed into the Emission shader (strength 1) ends up, texel by texel, in a 32-bit
float Non-Color image. Cycles CPU, 1 sample, no denoising, margin 0. With one sample the bake
shades each texel at ONE fixed point (the filter jitter of sample 0 is (0.5, 0.5)), but that
point is not the texel centre: Blender's bake rasteriser (source/blender/render/intern/bake.cc,
RE_bake_pixels_populate) maps UVs to pixels as `uv * size - (0.5f + 0.001f)` in x and
`- (0.5f + 0.002f)` in y (the old workaround for bug #18685), so texel (i, j) is shaded at
((i + 0.501) / width, (j + 0.502) / height). `bake_sample_uv` gives those points.
"""

import bpy
import numpy as np
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.node_builder import NodeOps  # noqa: E402


def new_scene():
    """A fresh empty scene set up for exact Cycles CPU bakes."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    from surfgrad_addon.harness.bake import exact_cycles
    cy = exact_cycles(scene)
    # None of these touch bake output (the bake writes raw pass values), but make it explicit
    # that no display transform, exposure or clamping is in play.
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    bake = scene.render.bake
    bake.margin = 0
    bake.use_clear = True
    bake.target = "IMAGE_TEXTURES"
    return scene


def add_uv_plane(name="ProbePlane"):
    """A 2 x 2 plane at the origin (normal +Z) with one quad whose UVs are the unit square."""
    mesh = bpy.data.meshes.new(name)
    verts = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 0.0)]
    mesh.from_pydata(verts, [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    corners = {0: (0.0, 0.0), 1: (1.0, 0.0), 2: (1.0, 1.0), 3: (0.0, 1.0)}
    for loop in mesh.loops:
        uv.data[loop.index].uv = corners[loop.vertex_index]
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    return obj


def new_float_image(name, width, height, pixels=None):
    """A 32-bit float RGBA image tagged Non-Color. `pixels` is (height, width, 4), row 0 at the
    bottom (Image.pixels order)."""
    img = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.alpha_mode = "STRAIGHT"
    if pixels is not None:
        px = np.ascontiguousarray(pixels, dtype=np.float32)
        assert px.shape == (height, width, 4)
        img.pixels.foreach_set(px.ravel())
        img.update()
    return img


def image_pixels(img):
    """Image.pixels as float32 (height, width, 4), row 0 at the bottom."""
    w, h = img.size
    out = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(out)
    return out.reshape(h, w, 4)


class EmissionProbe(NodeOps):
    """A material on the probe plane: build a graph with NodeOps (the add-on's node vocabulary:
    node, math, vmath, combine, separate; sockets or constants in), then `bake(socket)`."""

    where = "a bake probe"      # named in NodeOps' errors

    def __init__(self, obj, name="ProbeMat"):
        self.obj = obj
        mat = new_material(name)
        obj.data.materials.append(mat)
        self.tree = mat.node_tree
        self.nodes = self.tree.nodes
        self.links = self.tree.links
        self.nodes.clear()
        self.out = self.nodes.new("ShaderNodeOutputMaterial")
        self.emission = self.nodes.new("ShaderNodeEmission")
        self.emission.inputs["Strength"].default_value = 1.0
        self.links.new(self.emission.outputs["Emission"], self.out.inputs["Surface"])
        self.uv = self.nodes.new("ShaderNodeUVMap")
        self.uv.uv_map = "UVMap"
        self.target_node = self.nodes.new("ShaderNodeTexImage")
        self.target_node.label = "bake target"

    def bake(self, color_socket, width, height, name="BakeTarget"):
        """Bake `color_socket` (through Emission, strength 1) into a fresh float image and
        return its pixels, float32 (height, width, 4), row 0 at v ~ 0."""
        self.links.new(color_socket, self.emission.inputs["Color"])
        img = new_float_image(name, width, height)
        self.target_node.image = img
        for n in self.nodes:
            n.select = False
        self.target_node.select = True
        self.nodes.active = self.target_node
        bpy.context.view_layer.objects.active = self.obj
        self.obj.select_set(True)
        result = bpy.ops.object.bake(type="EMIT", margin=0, use_clear=True,
                                     target="IMAGE_TEXTURES")
        assert result == {"FINISHED"}, result
        return image_pixels(img)


def texel_centre_uv(width, height):
    """float32 texture coordinates of texel centres, (height, width, 2), row 0 at v ~ 0."""
    s = ((np.arange(width, dtype=np.float32) + np.float32(0.5)) / np.float32(width))
    t = ((np.arange(height, dtype=np.float32) + np.float32(0.5)) / np.float32(height))
    ss, tt = np.meshgrid(s, t)
    return np.stack([ss, tt], axis=-1)


# Blender's bake rasteriser offsets every sample by this many texels (x, y): see the module doc.
BAKE_TEXEL_OFFSET = (0.001, 0.002)


def bake_sample_uv(width, height, dtype=np.float64):
    """The UV at which a bake of a width x height image shades texel (i, j): texel centre plus
    BAKE_TEXEL_OFFSET texels. Shape (height, width, 2), row 0 at v ~ 0."""
    s = (np.arange(width, dtype=np.float64) + 0.5 + BAKE_TEXEL_OFFSET[0]) / width
    t = (np.arange(height, dtype=np.float64) + 0.5 + BAKE_TEXEL_OFFSET[1]) / height
    ss, tt = np.meshgrid(s, t)
    return np.stack([ss, tt], axis=-1).astype(dtype)
