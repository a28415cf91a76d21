"""How many channels an image file itself holds, read from its header: Blender reports 4
(Image.channels) for every 8-bit image once loaded, whatever the file held. Only formats whose
header says it exactly and cheaply: PNG (the IHDR chunk's colour type, byte 25) and baseline
or progressive JPEG (the frame header's component count). Other formats give None (unknown),
never a guess."""

import struct

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# PNG colour type (IHDR) -> (channels, what they are): PNG spec, section 11.2.2.
PNG_COLOUR_TYPES = {0: (1, "grey"), 2: (3, "RGB"), 3: (3, "palette of RGB colours"),
                    4: (2, "grey and alpha"), 6: (4, "RGB and alpha")}
# JPEG start-of-frame markers (SOF0-SOF15 but DHT C4, JPG C8 and DAC CC): ITU T.81, B.1.1.3.
JPEG_FRAMES = set(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
JPEG_COMPONENTS = {1: "grey", 3: "YCbCr colour", 4: "CMYK"}
JPEG_SCAN_LIMIT = 1 << 20           # a frame header this far in is no file we read cheaply


def file_channels(f):
    """(channels, what they are, format) from the start of the binary file object `f`, or
    None where the header does not say (another format, or a damaged header)."""
    head = f.read(33)
    if head.startswith(PNG_SIGNATURE):
        if len(head) < 33 or head[12:16] != b"IHDR":
            return None
        known = PNG_COLOUR_TYPES.get(head[25])
        return (*known, "PNG") if known else None
    if head.startswith(b"\xff\xd8"):
        f.seek(2)
        return _jpeg_channels(f)
    return None


def _jpeg_channels(f):
    """Walk the JPEG's marker segments (lengths only) to its frame header."""
    while f.tell() < JPEG_SCAN_LIMIT:
        marker = f.read(2)
        while len(marker) == 2 and marker[0] == 0xFF and marker[1] == 0xFF:   # fill bytes
            marker = marker[1:] + f.read(1)
        if len(marker) < 2 or marker[0] != 0xFF or marker[1] in (0xD9, 0xDA):
            return None                 # end of image or start of scan: no frame header
        if 0xD0 <= marker[1] <= 0xD7 or marker[1] == 0x01:
            continue                    # markers without a segment
        size = f.read(2)
        if len(size) < 2:
            return None
        length = struct.unpack(">H", size)[0]
        if marker[1] in JPEG_FRAMES:
            frame = f.read(6)           # precision, height, width, components
            if len(frame) < 6:
                return None
            n = frame[5]
            return (n, JPEG_COMPONENTS.get(n, f"{n} components"), "JPEG")
        f.seek(length - 2, 1)
    return None
