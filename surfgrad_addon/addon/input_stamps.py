"""The image files a bake reads, stamped when its request is checked and compared again
before the map is put in place.

The checks (image_checks.py) load each texture and free it again; Cycles loads it anew when
the bake starts. A file replaced or rewritten in between (an artist saving the texture on the
share while a farm bakes; a sync tool updating it) was baked as Cycles found it: cut off
mid-write, it baked Cycles' magenta 'missing' colour over the whole map, with exit 0. A
file's size, modification time and inode tell that it changed; the bake then fails instead
of publishing a map of something no check saw.
"""

import os

from . import material_inputs as MI
from .image_checks import feeds_normal, image_files, material_images


def _stat(path):
    try:
        s = os.stat(path)
    except OSError:
        return None
    return (s.st_size, s.st_mtime_ns, s.st_ino)


def stamps(obj, only=None):
    """{path: (size, mtime_ns, inode) or None} of every image file on disk obj's materials
    (or material `only`: Freeze's) read (each UDIM tile; a sequence's file for the current
    frame) that can change the baked normal: a Base Color texture saved during the bake
    changes no texel of the map (image_checks.image_problems)."""
    return {p: _stat(p) for p in read_files(obj, only=only, normal=True)}


def read_files(obj, viewport=False, only=None, normal=False):
    """The image files on disk obj's materials (or material `only`) read, sorted (each UDIM
    tile; a sequence's file for the current frame). viewport: its materials as the viewport
    evaluates it (bake_uvs.rendered_materials). normal: only those that can change the baked
    normal (normal_sources.py)."""
    import bpy
    paths, reached = set(), {}
    for mat, _path, node, image in material_images(obj, only, viewport):
        if normal and not feeds_normal(mat, node, reached):
            continue
        if image is None or image.packed_file is not None or not image.filepath or \
                image.source in ("GENERATED", "VIEWER"):
            continue
        if image.source == "SEQUENCE" and hasattr(node, "image_user"):
            file = bpy.path.abspath(image.filepath, library=image.library)
            paths.add(str(MI.sequence_frame_path(file, MI.sequence_frame(
                node.image_user, bpy.context.scene.frame_current))))
        else:
            paths.update(str(p) for p in image_files(image))
    return sorted(paths)


def changed_problem(before):
    """None when every stamped file is as it was, else the problem naming the first that is
    not and the fix."""
    for path, stamp in before.items():
        if _stat(path) != stamp:
            return (f"image file {path!r} changed while it was baked (replaced or rewritten "
                    f"after the checks read it), so the map may hold Cycles' magenta "
                    f"'missing' colour or a mix of old and new: bake again once the file is "
                    f"saved")
    return None
