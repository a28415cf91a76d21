"""What the images a bake reads take in memory, from their files' headers, before any is
loaded: an image too large for the process's address-space limit crashed Blender's load
(exit 139, no line), so the request check counts them with the bake (memory_limit)."""

from typing import NamedTuple

from . import memory_limit as ML
from .image_checks import image_files, material_images
from .image_headers import pixel_size


class ImagesMemory(NamedTuple):
    count: int          # images counted (files whose header gives their size)
    baked: int          # bytes they add to the bake, all together
    checked: int        # bytes the largest adds while the checks read its pixels
    what: str           # in words, for the message


def images_memory(obj, covered=()):
    """ImagesMemory of the file images `obj`'s materials read that are not loaded yet (a
    loaded one is in the process's size already): single files, and the UDIM tiles `covered`
    (all where empty) of a tiled image. Packed images, sequences and formats whose header
    pixel_size does not read are not counted (a lower bound)."""
    baked, checked, largest, seen = 0, 0, None, set()
    for _mat, _path, _node, image in material_images(obj):
        if image is None or image.name in seen or image.has_data or image.packed_file is not None \
                or image.source not in ("FILE", "TILED") or not image.filepath:
            continue
        seen.add(image.name)
        for path in _files(image, covered):
            size = _size(path)
            if size is None:
                continue
            texels = size.width * size.height
            held = texels * ML.IMAGE_BYTES_PER_TEXEL[size.float_buffer]
            baked += held + texels * ML.CYCLES_BYTES_PER_TEXEL[size.float_buffer]
            if size.float_buffer:
                checked = max(checked, held + texels * ML.CHECK_COPY_BYTES_PER_TEXEL)
            if largest is None or texels > largest[0]:
                largest = (texels, image.name, size)
    if largest is None:
        return ImagesMemory(0, 0, 0, "")
    _, name, size = largest
    kind = "float" if size.float_buffer else "8-bit"
    return ImagesMemory(len(seen), baked, checked,
                        f"{len(seen)} image(s) (the largest {name!r}, {size.width}x"
                        f"{size.height} {kind})")


def _files(image, covered):
    """The files of `image` the bake reads (image_files lists a tiled one's in tile order)."""
    files = image_files(image)
    if image.source == "TILED" and covered:
        wanted = set(covered)
        files = [f for f, t in zip(files, image.tiles) if t.number in wanted]
    return files


def _size(path):
    try:
        with open(path, "rb") as f:
            return pixel_size(f)
    except OSError:
        return None
