"""What the images a bake reads take in memory, from their files' headers, before any is
loaded: an image too large for the process's address-space limit crashed Blender's load
(exit 139, no line), so the request check counts them with the bake (memory_limit)."""

import io
from typing import NamedTuple

from . import memory_limit as ML
from .image_checks import image_files, material_images, sequence_file
from .image_headers import pixel_size


class ImagesMemory(NamedTuple):
    count: int          # images counted (files whose header gives their size)
    baked: int          # bytes they add to the bake, all together
    checked: int        # bytes the largest adds while the checks read its pixels
    what: str           # in words, for the message


def images_memory(obj, covered=()):
    """ImagesMemory of the images `obj`'s materials read that are not loaded yet (a loaded one
    is in the process's size already): single files, packed ones, the frame file an Image
    Sequence reads now, and the UDIM tiles `covered` (all where empty) of a tiled image.
    Formats whose header pixel_size does not read are not counted (a lower bound)."""
    baked, checked, largest, seen, counted = 0, 0, None, set(), set()
    for _mat, _path, node, image in material_images(obj):
        if image is None or image.name in seen or image.has_data:
            continue
        seen.add(image.name)
        for opened in _openers(image, node, covered):
            size = _size(opened)
            if size is None:
                continue
            counted.add(image.name)
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
    return ImagesMemory(len(counted), baked, checked,
                        f"{len(counted)} image(s) (the largest {name!r}, {size.width}x"
                        f"{size.height} {kind})")


def _openers(image, node, covered):
    """A function opening each file of `image` the bake reads (packed: a copy of its data)."""
    packed = image.packed_file
    if packed is not None:
        return [lambda: io.BytesIO(packed.data)]
    if not image.filepath:
        return []
    if image.source == "SEQUENCE":
        files = [sequence_file(image, node)] if hasattr(node, "image_user") else []
    elif image.source in ("FILE", "TILED"):
        files = image_files(image)
        if image.source == "TILED" and covered:
            wanted = set(covered)
            files = [f for f, t in zip(files, image.tiles) if t.number in wanted]
    else:
        return []
    return [lambda p=p: open(p, "rb") for p in files]


def _size(opened):
    try:
        with opened() as f:
            return pixel_size(f)
    except OSError:
        return None
