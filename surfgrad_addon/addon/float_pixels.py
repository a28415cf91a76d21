"""What a request's checks want to know of a float image's pixels, read once.

The finite-pixel refusal (image_checks) and the -1..1 range warning (normal_map_checks) both
read every pixel. For an 8192^2 float EXR each read is a load of the file and a 1 GB copy:
measured on 5.2.3, the two reads took 11 s of a 21 s bake at 256^2 (the bake itself 5 s).
Inside one_pixel_read() (bake_request.check) the pixels are read once per image and summed
up slice by slice, so no temporary array as large as the image is made."""

from dataclasses import dataclass

import numpy as np

from ..reference.input_checks import overflowing
from .read_once import ReadOnce

_pixels = ReadOnce()            # {image pointer or file path: PixelFacts} in one_pixel_read()
_probes = set()                 # pointers of the probe images _probe_read reads files with
_SLICE_TEXELS = 1 << 22         # texels per slice of the counts (bounded temporaries)
GB = 1024 ** 3
ABOVE_ONE = 1.01                # no 0..1 map, nor its rounding or filtering, holds more


class PixelsTooLarge(Exception):
    """The copy of an image's pixels the checks read does not fit this process's memory."""

    def __init__(self, image_name, nbytes):
        self.image_name, self.nbytes = image_name, nbytes
        super().__init__(
            f"image {image_name!r}: its pixels could not be read to check them ({nbytes / GB:.1f}"
            f" GB more than this process may have: an address-space limit such as `ulimit -v` "
            f"or the job's h_vmem, or the machine's memory), and the bake needs them in memory "
            f"too: raise the limit, or use a smaller image")


@dataclass(frozen=True)
class PixelFacts:
    """The counts of one float image's pixels (its first tile, for a tiled one)."""
    texels: int
    nonfinite: int              # values (not texels) that are NaN or +-Inf
    below_zero: tuple           # texels below 0 in R and in G ((0, 0) with under 2 channels)
    above_one: int = 0          # texels above ABOVE_ONE in R, G or B (the colour channels)
    largest: float = 0.0        # the largest colour value of those (0 where there are none)
    beyond: int = 0             # values past +-input_checks.OVERFLOWING (refused as NaN is)
    largest_magnitude: float = 0.0  # the largest magnitude of those (0 where there are none)

    def share_below_zero(self):
        """(R, G): the share of texels below 0 in each."""
        return tuple(n / self.texels for n in self.below_zero) if self.texels else (0.0, 0.0)


def one_pixel_read():
    """Within this block each image's pixels are read once. Nothing may change an image's
    pixels or file within it."""
    return _pixels.scope()


def pixel_facts(image):
    """PixelFacts of `image`'s float pixels, or None where it holds none (not a float image,
    or empty). An image this loads is freed again (it stays as unloaded as it was). Raises
    PixelsTooLarge where their copy does not fit the process's memory."""
    return _pixels.get(image.as_pointer(), lambda: _read(image))


def file_facts(path, probe=None):
    """PixelFacts of the float pixels of the image file `path` (a UDIM tile's, a sequence
    frame's: the image's own load reads neither), or None (not float, or not loadable). Read
    from `probe` (that file, loaded) if given, else from a probe image of its own, removed
    again, so the file's own images stay as they were. Raises PixelsTooLarge as pixel_facts."""
    return _pixels.get(("file", str(path)), lambda: _probe_read(path, probe))


ALPHA_BELOW = 0.999             # a colour times this is bent under 0.1 degrees
COLOUR_TEXELS = 2048 * 2048     # a larger byte image is counted on a copy scaled to these
FLAT_BLUE = 0.505               # blue at or below: z = 2 B - 1 <= 0.01, 89.4 degrees or past


@dataclass(frozen=True)
class ColourFacts:
    """The counts of one image's colour (byte or float pixels; its first tile)."""
    texels: int
    alpha_below: int            # texels with alpha below ALPHA_BELOW (0 without alpha)
    lowest_alpha: float         # the lowest alpha of those (1 where there are none)
    blue_flat: int              # texels with blue <= FLAT_BLUE that hold a direction: not
                                # black (a bake's untouched background) nor the zero vector
    is_float: bool = False
    scaled: bool = False        # counted on a copy scaled down to COLOUR_TEXELS (_scaled_colour)

    def share(self, count):
        """`count` of the texels, in words: exact, or a share of a scaled copy's."""
        return (f"about {100 * count / self.texels:.0f}% of its texels" if self.scaled else
                f"{count} of its {self.texels} texels")


def colour_facts(image):
    """ColourFacts of `image`'s pixels, or None where it holds none. Freed again if this loads
    it, as pixel_facts. Raises PixelsTooLarge as it does."""
    return _pixels.get(("colour", image.as_pointer()), lambda: _read_colour(image))


def _read_colour(image):
    had_data = image.has_data
    try:
        w, h = image.size
        channels, is_float = image.channels, image.is_float
        if w * h == 0 or channels < 3:
            return None
        # A copy reads the image's file, packed data or generator, not pixels painted or
        # set since (is_dirty): those are read in full, as Cycles bakes them.
        if not is_float and w * h > COLOUR_TEXELS and not image.is_dirty:
            return _scaled_colour(image, w, h, channels)
        try:
            px = np.empty(w * h * channels, dtype=np.float32)
            image.pixels.foreach_get(px)
        except MemoryError:
            raise PixelsTooLarge(image.name, w * h * channels * 4) from None
    finally:
        if not had_data and image.has_data:
            image.buffers_free()
    return colour_counts(px.reshape(-1, channels), is_float)


def _scaled_colour(image, w, h, channels):
    """ColourFacts of a byte image above COLOUR_TEXELS, read from a copy scaled down to fit
    them (box filtered): its float copy at full size would cost more than the bake (16384^2:
    15 s and 4 GB more, measured on 5.2). The counts are then of the scaled texels."""
    import bpy
    f = (COLOUR_TEXELS / (w * h)) ** 0.5
    sw, sh = max(1, int(w * f)), max(1, int(h * f))
    copy = image.copy()
    try:
        copy.scale(sw, sh)
        px = np.empty(sw * sh * channels, dtype=np.float32)
        copy.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(copy)
    facts = colour_counts(px.reshape(-1, channels), False)
    return ColourFacts(facts.texels, facts.alpha_below, facts.lowest_alpha, facts.blue_flat,
                       False, scaled=True)


def colour_counts(texels, is_float):
    """ColourFacts of (N, C) texels, C >= 3, slice by slice; the rarer counts only where a
    slice has any candidate (an 8192^2 byte map: 0.3 s of counting after a 2 s read)."""
    below, lowest, flat = 0, 1.0, 0
    for i in range(0, len(texels), _SLICE_TEXELS):
        part = texels[i:i + _SLICE_TEXELS]
        if texels.shape[1] > 3:
            alpha = part[:, 3]
            if alpha.min() < ALPHA_BELOW:           # (NaN is refused by image_checks)
                low = alpha < ALPHA_BELOW
                below += int(np.count_nonzero(low))
                lowest = min(lowest, float(alpha[low].min()))
        blue = part[:, 2] <= FLAT_BLUE
        if blue.any():
            rgb = part[blue, :3]
            black = (rgb[:, 0] < 0.02) & (rgb[:, 1] < 0.02)
            zero = (np.abs(rgb - 0.5) < 0.01).all(axis=1)
            flat += int(np.count_nonzero(~black & ~zero))
    return ColourFacts(len(texels), below, lowest, flat, is_float)


def _probe_read(path, probe):
    import bpy
    if probe is not None:
        return _read(probe)
    try:
        probe = bpy.data.images.load(str(path), check_existing=False)
    except RuntimeError:
        return None
    _probes.add(probe.as_pointer())     # (removed after: its pointer may be reused)
    try:
        return _read(probe)
    finally:
        _probes.discard(probe.as_pointer())
        bpy.data.images.remove(probe)


def _read(image):
    had_data = image.has_data       # (is_float, size and channels load the image)
    try:
        w, h = image.size
        channels = image.channels
        if not image.is_float or w * h == 0 or channels == 0:
            return None
        try:
            px = np.empty(w * h * channels, dtype=np.float32)
            image.pixels.foreach_get(px)
        except MemoryError:                 # (an address-space limit: `ulimit -v`, h_vmem)
            raise PixelsTooLarge(image.name, w * h * channels * 4) from None
    finally:
        if not had_data and image.has_data:
            image.buffers_free()
    texels = px.reshape(-1, channels)
    if channels >= 3 and image.as_pointer() not in _probes:   # colour_facts' read too
        _pixels.get(("colour", image.as_pointer()), lambda: colour_counts(texels, True))
    return summed(texels)


def summed(texels):
    """PixelFacts of (N, C) float texels, counted slice by slice. A slice whose float64 sum is
    finite has no NaN or Inf (float32 values cannot overflow it): only others are counted
    value by value, which is several times slower."""
    nonfinite, below, above, largest, beyond, magnitude = 0, [0, 0], 0, 0.0, 0, 0.0
    colours = min(3, texels.shape[1])
    for i in range(0, len(texels), _SLICE_TEXELS):
        part = texels[i:i + _SLICE_TEXELS]
        with np.errstate(invalid="ignore"):             # (Inf + -Inf: NaN, as wanted)
            finite = np.isfinite(np.add.reduce(part, axis=None, dtype=np.float64))
        if not finite:
            nonfinite += int(np.count_nonzero(~np.isfinite(part)))
        else:
            n, most = overflowing(part)
            beyond, magnitude = beyond + n, max(magnitude, most)
        for c in range(min(2, texels.shape[1])):
            below[c] += int(np.count_nonzero(part[:, c] < 0))
        high = part[:, :colours] > ABOVE_ONE
        if high.any():
            above += int(np.count_nonzero(high.any(axis=1)))
            largest = max(largest, float(part[:, :colours][high].max()))
    if texels.shape[1] < 2:
        below = [0, 0]
    return PixelFacts(len(texels), nonfinite, tuple(below), above, largest, beyond, magnitude)
