"""PNG pictures of the harness (heat maps, the main job's maps), encoded by Pillow.

The one thing done here is the quantisation: [0, 1] floats become 0-255 by rounding (NaN as 0)
and rows are flipped from Blender's bottom-up order, so the pixel values are the ones the
pictures have always had."""

from pathlib import Path

import numpy as np
from PIL import Image

_CHANNELS = (1, 3, 4)      # grey (L), RGB, RGBA


def write_png(path, pixels, bottom_up=True, overwrite=False, compress_level=6, palette=None):
    """Write 8-bit pixels (H, W), (H, W, 3) or (H, W, 4): [0, 1] floats or 0-255 integers.
    bottom_up: row 0 is the bottom of the picture (Blender's order). Refuses to replace an
    existing file unless overwrite. compress_level: zlib's 0-9 (Pillow's default 6); the
    pixels are the same at any level. palette: (K <= 256, 3) uint8 colours, pixels (H, W)
    their indices (an indexed PNG)."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True (--overwrite) to replace it")
    a = np.asarray(pixels)
    if a.dtype.kind == "f":
        a = np.clip(np.nan_to_num(a, nan=0.0) * 255.0 + 0.5, 0, 255)
    a = a.astype(np.uint8, copy=False)
    channels = 1 if a.ndim == 2 else a.shape[-1]
    if a.ndim not in (2, 3) or channels not in _CHANNELS:
        raise ValueError(f"PNG needs 1, 3 or 4 channels, got shape {a.shape}")
    if a.ndim == 3 and channels == 1:
        a = a[..., 0]
    if bottom_up:
        a = a[::-1]
    image = Image.fromarray(np.ascontiguousarray(a))      # uint8: L, RGB or RGBA by shape
    if palette is not None:
        if a.ndim != 2:
            raise ValueError(f"an indexed PNG needs (H, W) indices, got shape {a.shape}")
        # putpalette makes the grey (L) image an indexed (P) one, its bytes the indices.
        image.putpalette(np.asarray(palette, dtype=np.uint8).reshape(-1).tolist())
    image.save(path, format="PNG", compress_level=compress_level)
    return path
