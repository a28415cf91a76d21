"""What the images a bake reads take in memory, from their files' headers, before any is
loaded: an image too large for the process's address-space limit crashed Blender's load
(exit 139, no line), so the request check counts them with the bake (memory_limit)."""

from typing import NamedTuple

from . import memory_limit as ML
from .header_reads import image_headers, path_headers
from .image_checks import data_key, material_images, sequence_file


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
        if image is None or data_key(image) in seen or image.has_data:
            continue
        seen.add(data_key(image))              # (a library's image may share a name)
        for size in _sizes(image, node, covered):
            if size is None:
                continue
            counted.add(data_key(image))
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


def _sizes(image, node, covered):
    """PixelSize (or None) of each file of `image` the bake reads (image_headers lists a tiled
    one's in tile order)."""
    if image.source == "SEQUENCE":
        if not image.filepath or image.packed_file is not None or \
                not hasattr(node, "image_user"):
            return []
        found = path_headers(sequence_file(image, node))
        return [found and found.size]
    files = image_headers(image)
    if image.source == "TILED" and covered:
        wanted = set(covered)
        numbers = [p.tile_number for p in image.packed_files] if len(image.packed_files) > 1 \
            else [t.number for t in image.tiles]
        files = [f for f, number in zip(files, numbers) if number in wanted]
    return [found.size for _, found in files if found is not None]
