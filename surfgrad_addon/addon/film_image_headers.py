"""The size of the images film and VFX pipelines hand over, from their headers alone: DPX
(SMPTE 268M), Cineon (Kodak's Cineon 4.5 file format), SGI (the SGI image file format) and
JPEG 2000 (ISO/IEC 15444-1: a JP2 file's Image Header box, or a bare codestream's SIZ
marker). Which ones Blender loads into a float buffer was measured against its loads
(tests/test_image_memory.py, every line): more than 8 bits per sample, for each of them (a
16-bit SGI, which Blender does not write, made by hand there)."""

import struct
from typing import NamedTuple

DPX_MAGIC = {b"SDPX": ">", b"XPDS": "<"}            # the file's byte order
DPX_HEADER = 804             # file header (768) + image header to element 1's bit size
# DPX image element descriptor -> channels (SMPTE 268M table 1; 50 RGB, 51 RGBA, 52 ABGR).
DPX_CHANNELS = {1: 1, 2: 1, 3: 1, 4: 1, 6: 1, 50: 3, 51: 4, 52: 4}
CINEON_MAGIC = {b"\x80\x2a\x5f\xd7": ">", b"\xd7\x5f\x2a\x80": "<"}
CINEON_HEADER = 208          # file header (192) + image header to element 1's line count
SGI_MAGIC = b"\x01\xda"
SGI_FIELDS = 12              # magic, storage, bytes per channel, dimension, x, y, z sizes
JP2_SIGNATURE = b"\0\0\0\x0cjP  \r\n\x87\n"
J2K_START = b"\xff\x4f\xff\x51"                      # SOC, then the SIZ marker
J2K_SIZ = 38                 # SIZ, after its marker, up to the components' depths
J2K_MAX_COMPONENTS = 16384
JP2_HEADER_LIMIT = 1 << 16   # the Image Header box further in is no file we read cheaply


class HeaderSize(NamedTuple):
    width: int
    height: int
    channels: int
    bits: int            # per sample (the largest, where they differ)

    @property
    def float_buffer(self):
        """Blender loads it into a float buffer (measured on every line)."""
        return self.bits > 8


def film_format(head):
    """True where `head`, a file's first bytes, starts one of these formats."""
    return head[:4] in DPX_MAGIC or head[:4] in CINEON_MAGIC or head.startswith(SGI_MAGIC) \
        or head.startswith(JP2_SIGNATURE) or head.startswith(J2K_START)


def film_header_size(f, head):
    """HeaderSize of a DPX, Cineon, SGI or JPEG 2000 file (binary file object `f`, at its
    start, whose first bytes are `head`), or None: another format, or a header that is not
    whole or not one these formats allow."""
    if head[:4] in DPX_MAGIC:
        return _dpx(f.read(DPX_HEADER), DPX_MAGIC[head[:4]])
    if head[:4] in CINEON_MAGIC:
        return _cineon(f.read(CINEON_HEADER), CINEON_MAGIC[head[:4]])
    if head.startswith(SGI_MAGIC):
        return _sgi(f.read(SGI_FIELDS))
    if head.startswith(JP2_SIGNATURE):
        return _jp2(f.read(JP2_HEADER_LIMIT))
    if head.startswith(J2K_START):
        return _j2k_siz(f.read(4 + J2K_SIZ + 3 * J2K_MAX_COMPONENTS)[4:])
    return None


def _checked(width, height, channels, bits):
    return HeaderSize(width, height, channels, bits) \
        if width > 0 and height > 0 and channels > 0 and 0 < bits <= 64 else None


def _dpx(data, order):
    """Image information header at 768: orientation, element count, pixels per line, lines
    per element; the first element (780) has its descriptor at 800, bit size at 803."""
    if len(data) < DPX_HEADER:
        return None
    _, elements, width, height = struct.unpack(order + "HHII", data[768:780])
    channels = DPX_CHANNELS.get(data[800])
    if not 1 <= elements <= 8 or channels is None:
        return None
    return _checked(width, height, channels, data[803])


def _cineon(data, order):
    """Image information header at 192: orientation, channel count; each channel's record
    (28 bytes from 196) holds its designator, bits per pixel, pixels per line and lines."""
    if len(data) < CINEON_HEADER:
        return None
    channels, bits = data[193], data[198]
    width, height = struct.unpack(order + "II", data[200:208])
    return _checked(width, height, channels, bits) if channels <= 8 else None


def _sgi(data):
    """Big-endian: magic, storage (0 verbatim, 1 RLE), bytes per channel (1 or 2), dimension
    (1: one row, 2: one channel, 3: ZSIZE channels), XSIZE, YSIZE, ZSIZE."""
    if len(data) < SGI_FIELDS:
        return None
    storage, per_channel, dimension, x, y, z = struct.unpack(">xxBBHHHH", data)
    if storage > 1 or per_channel not in (1, 2) or dimension not in (1, 2, 3):
        return None
    return _checked(x, y if dimension > 1 else 1, z if dimension == 3 else 1, 8 * per_channel)


def _jp2(data):
    """The Image Header box ('ihdr': height, width, component count, bits per component - 1,
    255 where they differ, then given one per component in a 'bpcc' box) in the JP2 Header
    box ('jp2h'), among the top-level boxes after the signature."""
    jp2h = _box(data, 12, b"jp2h")
    ihdr = jp2h and _box(jp2h, 0, b"ihdr")
    if ihdr is None or len(ihdr) < 11:
        return None
    height, width, channels, depth = struct.unpack(">IIHB", ihdr[:11])
    if depth == 255:
        each = _box(jp2h, 0, b"bpcc")
        if not each:
            return None
        depth = max(b & 0x7F for b in each)
    return _checked(width, height, channels, (depth & 0x7F) + 1)


def _box(data, at, kind):
    """The contents of the first box of type `kind` from offset `at` of `data` (each box:
    its length, 4 bytes, including these 8; 1: an 8-byte length follows; 0: to the end), or
    None where it is not there."""
    while at + 8 <= len(data):
        length, found = struct.unpack(">I4s", data[at:at + 8])
        start = at + 8
        if length == 1:
            if at + 16 > len(data):
                return None
            length, start = struct.unpack(">Q", data[at + 8:at + 16])[0], at + 16
        elif length == 0:
            length = len(data) - at
        if length < start - at:
            return None
        if found == kind:
            return data[start:at + length] if at + length <= len(data) else None
        at += length
    return None


def _j2k_siz(siz):
    """SIZ marker segment (after its marker): length, capabilities, the reference grid's size
    and image offset (Xsiz, Ysiz, XOsiz, YOsiz), tiles, component count, then each
    component's depth - 1 (Ssiz, its high bit: signed) and subsampling."""
    if len(siz) < J2K_SIZ:
        return None
    xs, ys, xo, yo = struct.unpack(">IIII", siz[4:20])
    channels = struct.unpack(">H", siz[36:38])[0]
    depths = siz[38:38 + 3 * channels:3]
    if not channels or len(depths) < channels:
        return None
    return _checked(xs - xo, ys - yo, channels, max(d & 0x7F for d in depths) + 1)
