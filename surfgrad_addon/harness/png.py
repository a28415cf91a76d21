"""A minimal PNG writer (8-bit RGB/RGBA or grey) using zlib, so images need no extra package."""

import struct
import zlib
from pathlib import Path

import numpy as np


def _chunk(kind, data):
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)


def write_png(path, pixels, bottom_up=True, overwrite=False):
    """Write uint8-convertible pixels (H, W), (H, W, 3) or (H, W, 4) in [0, 1] floats or 0-255
    integers. bottom_up: row 0 is the bottom of the picture (Blender's order)."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True (--overwrite) to replace it")
    a = np.asarray(pixels)
    if a.dtype.kind == "f":
        a = np.clip(np.nan_to_num(a, nan=0.0) * 255.0 + 0.5, 0, 255)
    a = a.astype(np.uint8)
    if a.ndim == 2:
        a = a[..., None]
    h, w, c = a.shape
    color_type = {1: 0, 3: 2, 4: 6}.get(c)
    if color_type is None:
        raise ValueError(f"PNG needs 1, 3 or 4 channels, got {c}")
    if bottom_up:
        a = a[::-1]
    raw = b"".join(b"\x00" + row.tobytes() for row in a)
    data = (b"\x89PNG\r\n\x1a\n"
            + _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color_type, 0, 0, 0))
            + _chunk(b"IDAT", zlib.compress(raw, 6)) + _chunk(b"IEND", b""))
    path.write_bytes(data)
    return path
