"""Helpers for test files that also run as scripts in a child interpreter, where the checkout's
surfgrad_addon may be absent (an installed extension's session): import only bpy."""


def new_material(name):
    """A material with a node tree on every line (before 5.0 it needs use_nodes)."""
    import bpy
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    return mat


def missing_image(name, folder):
    """An image whose file is not there (a folder moved): Blender keeps it, unloaded."""
    import bpy
    image = bpy.data.images.new(name, 4, 4)
    image.source = "FILE"
    image.filepath = f"/nonexistent/{folder}/{name}.png"
    return image
