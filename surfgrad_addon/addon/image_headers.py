"""How many channels an image file itself holds, and its size (pixel_size: the memory check
counts images before they are loaded), read from its header: Blender reports 4
(Image.channels) for every image once loaded, whatever the file held. Only formats whose
header says it exactly and cheaply: PNG (the IHDR chunk's colour type, byte 25), baseline or
progressive JPEG (the frame header's component count) and single-part scanline or tiled
OpenEXR (the header's `channels` list, default layer only). Other formats, and multi-part,
deep or multi-layer EXRs, give None (unknown), never a guess. Whether a JPEG or TIFF is whole
(an end-of-image marker after its image data; strips within the file) is read from it too.

What Blender makes of too few (tests/test_exr_channels.py, every line): a grey file (PNG grey,
JPEG with one component, EXR `Y`, or an EXR with one of R, G and B) is spread over R, G and B;
an EXR with two of R, G and B loads them into R and G, and B is 0 on 4.2 but left
uninitialised on 4.5 and later (LineFacts.exr_two_colours_fill_zero); so are R, G and B of an
EXR with alpha and no channel Blender loads as colour (tests/test_faults_images33.py). X, Y
and Z load into R, G and B; channel names match in either case (but a lone y: see below);
an EXR of other channels (Z alone, a lower case y) is judged as one of alpha alone.
A luminance-chroma EXR (Y with RY and / or BY, OpenEXR's YC files) is not loaded as its colours
on any line (image_channels)."""

import re
import struct
from typing import NamedTuple

from .film_image_headers import SGI_MAGIC, film_format, film_header_size

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# PNG colour type (IHDR) -> (channels, what they are): PNG spec, section 11.2.2.
PNG_COLOUR_TYPES = {0: (1, "grey"), 2: (3, "RGB"), 3: (3, "palette of RGB colours"),
                    4: (2, "grey and alpha"), 6: (4, "RGB and alpha")}
# JPEG start-of-frame markers (SOF0-SOF15 but DHT C4, JPG C8 and DAC CC): ITU T.81, B.1.1.3.
JPEG_FRAMES = set(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
JPEG_COMPONENTS = {1: "grey", 3: "YCbCr colour", 4: "CMYK"}
JPEG_SCAN_LIMIT = 1 << 20           # a frame header this far in is no file we read cheaply
EXR_MAGIC = b"\x76\x2f\x31\x01"
EXR_MULTI_OR_DEEP = 0x1800          # version flags: multi-part (0x1000), deep data (0x800)
EXR_MULTI_PART = 0x1000
EXR_HEADER_LIMIT = 1 << 16          # a header larger than this is not read
COLOURS = ("R", "G", "B")


class FileChannels(NamedTuple):
    channels: int       # in the file, alpha included
    kind: str           # what they are, in words
    format: str         # PNG, JPEG, EXR
    lacking: str        # "" (R, G and B there), "grey" (one grey channel), else e.g. "B"
    luma_chroma: bool = False   # an EXR of luminance Y and chroma RY / BY, no R, G or B

    @property
    def two_colours(self):
        """An EXR with two of R, G and B (Blender loads them into R and G; B: see above)."""
        return self.format == "EXR" and len(self.lacking) == 1

    @property
    def unfilled(self):
        """The colour channels Blender's load does not fill (0 on 4.2, uninitialised later: see
        image_channels): B of an EXR with two of R, G and B, all three of one with alpha and no
        colour; "" for any other file."""
        return self.lacking if self.format == "EXR" and self.lacking != "grey" else ""


def file_channels(f):
    """FileChannels from the start of the binary file object `f`, or None where the header
    does not say (another format, or a damaged header)."""
    head = f.read(33)
    if head.startswith(PNG_SIGNATURE):
        if len(head) < 33 or head[12:16] != b"IHDR":
            return None
        known = PNG_COLOUR_TYPES.get(head[25])
        return FileChannels(*known, "PNG", "grey" if known[0] < 3 else "") if known else None
    if head.startswith(b"\xff\xd8"):
        f.seek(2)
        return _jpeg_channels(f)
    if head.startswith(EXR_MAGIC):
        f.seek(0)
        return _exr_channels(f.read(EXR_HEADER_LIMIT))
    return None


class PixelSize(NamedTuple):
    width: int
    height: int
    float_buffer: bool  # Blender loads it into a float buffer (EXR, 16-bit PNG), else bytes


def pixel_size(f):
    """PixelSize from the start of the binary file object `f` (PNG, JPEG, single-part EXR,
    TIFF, Radiance HDR, BMP, WebP, TGA; DPX, Cineon, SGI and JPEG 2000: film_image_headers),
    or None where the header does not say (another format, or a damaged header)."""
    head = f.read(33)
    f.seek(0)
    if head[:4] in (b"II*\0", b"MM\0*"):
        return _tiff_size(f)
    if head.startswith(b"#?"):
        found = HDR_SIZE.search(f.read(HDR_HEADER_LIMIT))
        if found is None:
            return None
        sizes = {found.group(1)[1:]: int(found.group(2)), found.group(3)[1:]: int(found.group(4))}
        return PixelSize(sizes[b"X"], sizes[b"Y"], True) if len(sizes) == 2 else None
    if head.startswith(b"BM") and len(head) >= 26:
        w, h = struct.unpack("<ii", head[18:26])
        return PixelSize(w, abs(h), False) if w > 0 and h != 0 else None
    if head.startswith(PNG_SIGNATURE):
        if len(head) < 33 or head[12:16] != b"IHDR":
            return None
        w, h = struct.unpack(">II", head[16:24])
        return PixelSize(w, h, head[24] == 16)
    if head.startswith(b"\xff\xd8"):
        f.seek(2)
        frame = _jpeg_frame(f)
        return frame and PixelSize(*struct.unpack(">HH", frame[3:5] + frame[1:3]), False)
    if head.startswith(EXR_MAGIC):
        f.seek(0)
        data = f.read(EXR_HEADER_LIMIT)
        if len(data) < 8 or struct.unpack("<i", data[4:8])[0] & EXR_MULTI_OR_DEEP:
            return None
        box = _exr_attribute(data, b"dataWindow", b"box2i")
        if box is None or len(box) != 16:
            return None
        x0, y0, x1, y1 = struct.unpack("<iiii", box)
        return PixelSize(x1 - x0 + 1, y1 - y0 + 1, True) if x1 >= x0 and y1 >= y0 else None
    if head[:4] == b"RIFF" and head[8:12] == b"WEBP":
        return _webp_size(head)
    if film_format(head):               # (a damaged one is not read as a TGA either)
        film = film_header_size(f, head)
        return film and PixelSize(film.width, film.height, film.float_buffer)
    return _tga_size(head)


def _webp_size(head):
    """PixelSize of a WebP from its first chunk (lossy VP8, lossless VP8L, extended VP8X's
    canvas), or None. Blender loads it 8-bit."""
    kind = head[12:16]
    if kind == b"VP8X" and len(head) >= 30:
        w, h = (int.from_bytes(head[i:i + 3], "little") + 1 for i in (24, 27))
    elif kind == b"VP8L" and len(head) >= 25 and head[20] == 0x2F:
        bits = int.from_bytes(head[21:25], "little")
        w, h = (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    elif kind == b"VP8 " and len(head) >= 30 and head[23:26] == b"\x9d\x01\x2a":
        w, h = (v & 0x3FFF for v in struct.unpack("<HH", head[26:30]))
    else:
        return None
    return PixelSize(w, h, False) if w and h else None


# TGA has no magic: a header is taken as one only when every field is one TGA allows
# (colour-mapped types 1/9 with a colour map, true-colour/grey 2/3/10/11 without one).
TGA_TYPES = {1: 1, 9: 1, 2: 0, 3: 0, 10: 0, 11: 0}    # image type: its colour-map type
TGA_DEPTHS = (8, 15, 16, 24, 32)


def _tga_size(head):
    """PixelSize of a TGA from its 18-byte header, or None (not a TGA's). Blender loads it
    8-bit."""
    if len(head) < 18:
        return None
    _, cmap, kind, _, _, _, _, _, w, h, depth, _ = struct.unpack("<BBBHHBHHHHBB", head[:18])
    if TGA_TYPES.get(kind) != cmap or depth not in TGA_DEPTHS or not w or not h:
        return None
    return PixelSize(w, h, False)


def exr_layered(f):
    """True where the binary file object `f` starts an OpenEXR with layers (multi-part, or a
    channel name with a '.': what Blender loads as a multilayer image), from the header alone:
    4.2 never returns from loading such a file cut short."""
    data = f.read(EXR_HEADER_LIMIT)
    if not data.startswith(EXR_MAGIC) or len(data) < 8:
        return False
    if struct.unpack("<i", data[4:8])[0] & EXR_MULTI_PART:
        return True
    return any("." in n for n in _exr_channel_names(data) or ())


def _exr_channels(data):
    """FileChannels of a single-part EXR's header, or None."""
    if len(data) < 8 or struct.unpack("<i", data[4:8])[0] & EXR_MULTI_OR_DEEP:
        return None
    names = _exr_channel_names(data)
    return None if names is None else _exr_verdict(names)


def _exr_channel_names(data):
    """The channel names of an EXR header, or None where not found."""
    value = _exr_attribute(data, b"channels", b"chlist")
    return None if value is None else _chlist_names(value)


def _exr_attribute(data, name, kind):
    """The value bytes of attribute `name` of type `kind` in an EXR header (OpenEXR file
    layout: magic, version, then name\\0 type\\0 size value attributes up to an empty name), or
    None where not found."""
    at = 8
    while at < len(data) and data[at] != 0:
        name_end = data.find(b"\0", at)
        type_end = data.find(b"\0", name_end + 1)
        if name_end < 0 or type_end < 0 or type_end + 5 > len(data):
            return None
        size = struct.unpack("<i", data[type_end + 1:type_end + 5])[0]
        if data[at:name_end] == name and data[name_end + 1:type_end] == kind:
            return data[type_end + 5:type_end + 5 + size]
        at = type_end + 5 + size
    return None


def _chlist_names(value):
    """Names in a chlist value: name\\0 then 16 bytes (type, linear, sampling), ended by \\0."""
    names, at = [], 0
    while at < len(value) and value[at] != 0:
        end = value.find(b"\0", at)
        if end < 0:
            return None
        names.append(value[at:end].decode("latin-1"))
        at = end + 1 + 16
    return names


def _exr_verdict(names):
    if not names or any("." in n for n in names):      # a multi-layer file: not read
        return None
    # Blender matches R, G, B, A, X and Z in either case (measured on 4.2 and 5.2); a lower
    # case y alone is shown grey on 5.2 but 0 on 4.2 and 4.5, so only an upper case Y is grey
    # (a y is a channel Blender does not read as colour: below).
    upper = {n.upper() for n in names}
    present = [c for c in COLOURS if c in upper]
    order = [*COLOURS, "Y", "A"]
    kind = " and ".join("Y (grey)" if n == "Y" else n for n in
                        sorted(names, key=lambda n: (order.index(n.upper())
                                                     if n.upper() in order else 9, n)))
    if len(present) == 1:           # Blender spreads a lone R, G or B as grey
        return FileChannels(len(names), kind, "EXR", "grey")
    if present:
        return FileChannels(len(names), kind, "EXR",
                            "".join(c for c in COLOURS if c not in present))
    if {"X", "Y", "Z"} <= upper:    # loaded into R, G and B, in that order
        return FileChannels(len(names), kind, "EXR", "")
    if "Y" in upper and {"RY", "BY"} & upper:     # luminance-chroma (OpenEXR's YC files)
        rank = ("Y", "RY", "BY", "A")
        return FileChannels(len(names), " and ".join(sorted(names, key=lambda n: (
            rank.index(n.upper()) if n.upper() in rank else 9, n))), "EXR", "", True)
    if "Y" in names:
        return FileChannels(len(names), kind, "EXR", "grey")
    # Nothing Blender loads as colour (alpha alone, Z, a lower case y, other names): Cycles
    # renders one of the channels as a grey, what bpy shows differs by line (image_channels).
    return FileChannels(len(names), kind, "EXR", "".join(COLOURS))


def _jpeg_channels(f):
    """FileChannels from the JPEG's frame header, or None."""
    frame = _jpeg_frame(f)
    if frame is None:
        return None
    n = frame[5]
    return FileChannels(n, JPEG_COMPONENTS.get(n, f"{n} components"), "JPEG",
                        "grey" if n == 1 else "")


def _jpeg_frame(f):
    """The first 6 bytes of the JPEG's frame header (precision, height, width, components),
    or None."""
    for marker, _ in _jpeg_segments(f):
        if marker in JPEG_FRAMES:
            frame = f.read(6)
            return frame if len(frame) == 6 else None
    return None


def cut_short(f):
    """The format ("JPEG", "TIFF", "SGI image", "OpenEXR", "WebP") of the binary file object
    `f` where its image data does not all lie within it (a copy or download cut short), else
    None: Blender loads such a file at full size, the part missing filled in, and Cycles bakes
    that or its magenta 'missing' colour (measured on every line)."""
    head = f.read(4)
    f.seek(0)
    if head[:2] == b"\xff\xd8":
        return "JPEG" if _jpeg_cut_short(f) else None
    if head in (b"II*\0", b"MM\0*"):
        return "TIFF" if _tiff_cut_short(f) else None
    if head[:2] == SGI_MAGIC:
        return "SGI image" if _sgi_cut_short(f) else None
    if head == EXR_MAGIC:
        return "OpenEXR" if _exr_cut_short(f) else None
    if head == b"RIFF":
        return "WebP" if _webp_cut_short(f) else None
    return None


# An EXR chunk's leading fields before its data size: scanline y; tiled x, y, level x, level y.
EXR_CHUNK_FIELDS = {False: 4, True: 16}
EXR_TILED = 0x200
# Scanlines a chunk holds, by compression (OpenEXR: NONE, RLE, ZIPS 1; ZIP, PXR24 16; PIZ, B44,
# B44A, DWAA 32; DWAB 256); another: unknown, and such a file is judged by its table alone.
EXR_CHUNK_LINES = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def _exr_cut_short(f):
    """A chunk of a single-part EXR (scanline or tiled) whose data lies past the end of the
    file (OpenEXR file layout: header, offset table, chunks). 5.0 and 5.2 load one cut short
    at full size, the chunks missing black, and Cycles bakes its magenta 'missing' colour;
    4.2 and 4.5 load garbage. A table holding zeros (Blender's own packed EXRs: written to
    memory, the table never filled in) is rebuilt as OpenEXR's reader does, by walking the
    chunks in turn from the table's end; that needs the chunk count, known for scanline files
    of the compressions above."""
    data = f.read(EXR_HEADER_LIMIT)
    if len(data) < 8:
        return False
    flags = struct.unpack("<i", data[4:8])[0]
    if flags & EXR_MULTI_OR_DEEP:
        return False                    # (layered: the load itself fails when cut)
    at = _exr_header_end(data)
    if at is None:
        return False
    f.seek(0, 2)
    size = f.tell()
    tiled = bool(flags & EXR_TILED)
    fields = EXR_CHUNK_FIELDS[tiled]
    count = None if tiled else _exr_chunk_count(data)
    if count is None:                   # tiled, or lines per chunk unknown: up to the first one
        count, first = 0, size
        while at + 8 * count < first:
            f.seek(at + 8 * count)
            entry = f.read(8)
            if len(entry) < 8:
                return True             # the table itself runs past the end
            offset = struct.unpack("<Q", entry)[0]
            if offset >= size:
                return True
            if offset == 0:
                return False            # a table to rebuild: not judged
            first = min(first, offset)
            count += 1
    f.seek(at)
    table = f.read(8 * count)
    if len(table) < 8 * count:
        return True                     # the table itself runs past the end
    offsets = struct.unpack(f"<{count}Q", table)
    if any(o >= size for o in offsets):
        return True
    if 0 in offsets:
        offsets, walk = [], at + 8 * count      # rebuilt: each chunk right after the last
        for _ in range(count):
            offsets.append(walk)
            walk += fields + 4 + _exr_chunk_length(f, walk + fields)
            if walk > size:
                return True
    return any(o + fields + 4 + _exr_chunk_length(f, o + fields) > size for o in offsets)


def _exr_chunk_count(data):
    """Chunks of a scanline EXR (its dataWindow's lines over its compression's lines per
    chunk), or None where not known."""
    box = _exr_attribute(data, b"dataWindow", b"box2i")
    compression = _exr_attribute(data, b"compression", b"compression")
    if box is None or len(box) != 16 or not compression or compression[0] not in EXR_CHUNK_LINES:
        return None
    _, y0, _, y1 = struct.unpack("<iiii", box)
    lines = EXR_CHUNK_LINES[compression[0]]
    return (y1 - y0 + lines) // lines if y1 >= y0 else None


def _exr_chunk_length(f, at):
    """The data size a chunk gives at `at`, or a size past any file's end where that is not
    all in the file."""
    f.seek(at)
    length = f.read(4)
    length = struct.unpack("<i", length)[0] if len(length) == 4 else -1
    return length if length >= 0 else 1 << 62


def _exr_header_end(data):
    """Where an EXR's single header ends (after its attributes' closing empty name), or None
    where it is not all in `data`."""
    at = 8
    while at < len(data) and data[at] != 0:
        type_end = data.find(b"\0", data.find(b"\0", at) + 1)
        if type_end < 0 or type_end + 5 > len(data):
            return None
        size = struct.unpack("<i", data[type_end + 1:type_end + 5])[0]
        if size < 0:            # damaged: a negative size walked back, and could loop for ever
            return None
        at = type_end + 5 + size
    return at + 1 if at < len(data) else None


def _webp_cut_short(f):
    """A WebP (RIFF) file shorter than its RIFF header says (4.2 loads one cut short as
    transparent black at full size, and Cycles bakes its magenta 'missing' colour)."""
    head = f.read(12)
    if len(head) < 12 or head[8:12] != b"WEBP":
        return False
    f.seek(0, 2)
    return f.tell() < 8 + struct.unpack("<I", head[4:8])[0]


def _jpeg_cut_short(f):
    """No end-of-image marker after the first scan's data. Entropy-coded data never holds
    FF D9 (an FF there is followed by 00 or a restart marker): the first one is the end."""
    f.seek(-2, 2)
    if f.read(2) == b"\xff\xd9":     # the usual whole file: no need to read it all
        return False
    f.seek(2)
    for marker, length in _jpeg_segments(f):
        if marker == 0xDA:
            f.seek(length - 2, 1)
            last = b""
            while True:
                block = f.read(1 << 20)
                if not block:
                    return True
                if b"\xff\xd9" in last + block:
                    return False
                last = block[-1:]
    return False                        # no scan: the load itself fails


# TIFF tags (TIFF 6.0): the first image's size and what a sample is (3: a float).
TIFF_WIDTH, TIFF_HEIGHT, TIFF_BITS, TIFF_SAMPLE_FORMAT = 256, 257, 258, 339
TIFF_SIZE = (TIFF_WIDTH, TIFF_HEIGHT, TIFF_BITS, TIFF_SAMPLE_FORMAT)
# Radiance HDR: text lines, an empty one, then the resolution line ("-Y 512 +X 768").
HDR_SIZE = re.compile(rb"\n\n([-+][XY]) (\d+) ([-+][XY]) (\d+)\n")
HDR_HEADER_LIMIT = 1 << 16
SGI_HEADER = 512
# TIFF tags (TIFF 6.0): where the first image's strips or tiles lie and how long they are.
TIFF_DATA = {273: "offsets", 279: "counts", 324: "offsets", 325: "counts"}


def _tiff_cut_short(f):
    """A strip or tile of the first image (its IFD's offsets and byte counts) ending past
    the end of the file."""
    f.seek(0, 2)
    size = f.tell()
    f.seek(0)
    fields = _tiff_fields(f, TIFF_DATA)
    if not fields:
        return False                    # no directory: the load itself fails
    found = {TIFF_DATA[tag]: values for tag, values in fields.items()}
    ends = [o + c for o, c in zip(found.get("offsets", ()), found.get("counts", ()))]
    return bool(ends) and max(ends) > size


def _tiff_fields(f, tags):
    """{tag: values} of the entries `tags` (SHORT or LONG values) in the first image
    directory (IFD) of the TIFF `f` (at its start), or None where the directory is not all in
    the file."""
    order = "<" if f.read(2) == b"II" else ">"
    f.seek(4)
    f.seek(struct.unpack(order + "I", f.read(4))[0])
    count = f.read(2)
    if len(count) < 2:
        return None
    found = {}
    for _ in range(struct.unpack(order + "H", count)[0]):
        entry = f.read(12)
        if len(entry) < 12:
            return None
        tag, kind, n = struct.unpack(order + "HHI", entry[:8])
        if tag not in tags or kind not in (3, 4):
            continue
        width = 2 if kind == 3 else 4
        data = entry[8:8 + n * width] if n * width <= 4 else _read_at(f, entry[8:], order,
                                                                       n * width)
        found[tag] = struct.unpack(f"{order}{n}{'H' if kind == 3 else 'I'}", data)
    return found


def _sgi_cut_short(f):
    """Image data past the end of the file: verbatim, the channels' planes after the 512-byte
    header; run-length encoded, the rows its offset and length tables name (SGI image file
    format). (4.2 loads one cut short, the rest as memory held; later lines refuse it.)"""
    head = f.read(12)
    if len(head) < 12:
        return False
    rle, width, w, h, channels = struct.unpack(">xxBBxxHHH", head)
    f.seek(0, 2)
    size = f.tell()
    if not rle:
        return SGI_HEADER + w * h * channels * width > size
    f.seek(SGI_HEADER)
    rows = h * channels
    tables = f.read(8 * rows)
    if len(tables) < 8 * rows:
        return True
    starts, lengths = tables[:4 * rows], tables[4 * rows:]
    return max((a + n for a, n in zip(struct.unpack(f">{rows}I", starts),
                                      struct.unpack(f">{rows}I", lengths))), default=0) > size


def _tiff_size(f):
    """PixelSize of a TIFF's first image (its IFD's width, height, bits per sample and sample
    format): Blender loads more than 8 bits a sample, or floats, into a float buffer."""
    fields = _tiff_fields(f, TIFF_SIZE)
    if not fields or TIFF_WIDTH not in fields or TIFF_HEIGHT not in fields:
        return None
    first = {tag: values[0] for tag, values in fields.items() if values}
    return PixelSize(first[TIFF_WIDTH], first[TIFF_HEIGHT],
                     first.get(TIFF_BITS, 1) > 8 or first.get(TIFF_SAMPLE_FORMAT, 1) == 3)


def _read_at(f, offset, order, n):
    back = f.tell()
    f.seek(struct.unpack(order + "I", offset)[0])
    data = f.read(n)
    f.seek(back)
    return data if len(data) == n else b"\0" * n


def _jpeg_segments(f):
    """(marker, length) of each marker segment from `f`'s position (after the SOI) up to the
    first start of scan; after each, `f` is just past the length field (the next is found
    from there by the length, whatever the caller read)."""
    while f.tell() < JPEG_SCAN_LIMIT:
        marker = f.read(2)
        while len(marker) == 2 and marker[0] == 0xFF and marker[1] == 0xFF:   # fill bytes
            marker = marker[1:] + f.read(1)
        if len(marker) < 2 or marker[0] != 0xFF or marker[1] == 0xD9:
            return                      # end of image, or not a marker
        if 0xD0 <= marker[1] <= 0xD7 or marker[1] == 0x01:
            continue                    # markers without a segment
        size = f.read(2)
        if len(size) < 2:
            return
        length = struct.unpack(">H", size)[0]
        start = f.tell()
        yield marker[1], length
        if marker[1] == 0xDA:
            return
        f.seek(start + length - 2)
