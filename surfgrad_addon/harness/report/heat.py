"""The report page's heat maps: every case's error on one shared, logarithmic scale.

compare-all's heat PNGs (heat_map.heat_map_rgb) each scale their error to their own top,
max(0.5 deg, the case's max). Their pixels are read back into degrees here, using the case's
report for the top: the green channel (0.8 sqrt(v)) where the error is small, which keeps about
6 % of a value down to 1e-4 of the top, the red one (v) above. The texels the writer painted in
a reason's colour (not compared, contested, excluded) keep that reason.
"""

from pathlib import Path

import numpy as np
from PIL import Image

# The shared scale (degrees): log10 from LOW to the max bar; darker is a larger error.
LOW = 1e-5
OVER_BAR = (214, 39, 40)          # red: above the max bar
LIGHT, DARK = 248.0, 24.0         # grey levels at LOW and at the bar
# Below this green byte the green channel is the finer measure (v < 0.16: 0.8 sqrt(v) * 255).
GREEN_SWITCH = 82
LEGEND_STEPS = 512


def reason_colours():
    """{reason code: RGB bytes} as heat_map.heat_map_rgb paints them (asked of the writer)."""
    from ..heat_map import HEAT_COLOURS, heat_map_rgb
    from ..texel_report import ErrorImage
    codes = sorted(HEAT_COLOURS)
    heat = ErrorImage(np.full((1, len(codes)), np.nan), np.array([codes], dtype=np.int8))
    rgb = heat_map_rgb(heat)[0]
    return {code: tuple(int(c) for c in rgb[i]) for i, code in enumerate(codes)}


def decode_heat_png(path, max_deg, colours):
    """(error (H, W) in degrees, NaN where the picture shows a reason; reasons (H, W) int8:
    0 where an error was read, -1 not compared, else the compare's reason code) from a compare
    heat PNG whose case's max error is max_deg. Rows stay in the PNG's order."""
    rgb = np.asarray(Image.open(path).convert("RGB")).astype(np.int32)
    top = max(0.5, float(max_deg or 0.0))
    reasons = np.zeros(rgb.shape[:2], dtype=np.int8)
    for code, colour in colours.items():
        if code != 0:
            reasons[np.all(rgb == np.array(colour), axis=-1)] = code
    red, green = rgb[..., 0] / 255.0, rgb[..., 1] / (0.8 * 255.0)
    v = np.where(rgb[..., 1] < GREEN_SWITCH, np.square(green), red)
    # Colour 0 is "no error" (not covered by both sides): a reason of its own on the page, -1.
    reasons[np.all(rgb == np.array(colours[0]), axis=-1)] = -1
    return np.where(reasons == 0, v * top, np.nan), reasons


def scale_position(error_deg, bar):
    """Position on the shared scale, 0 at LOW (or below) to 1 at the bar."""
    e = np.maximum(np.nan_to_num(np.asarray(error_deg, dtype=np.float64), nan=LOW), LOW)
    return np.clip(np.log10(e / LOW) / np.log10(bar / LOW), 0.0, 1.0)


def shared_rgba(error, reasons, bar, colours):
    """(H, W, 4) uint8 on the shared scale: grey by error, red above the bar, a reason's
    colour where the compare painted one, transparent where nothing was compared."""
    grey = np.rint(LIGHT + (DARK - LIGHT) * scale_position(error, bar)).astype(np.uint8)
    out = np.empty(error.shape + (4,), dtype=np.uint8)
    out[..., :3] = grey[..., None]
    out[..., 3] = 255
    out[np.nan_to_num(error, nan=0.0) > bar, :3] = OVER_BAR
    for code, colour in colours.items():
        if code != 0:
            out[reasons == code, :3] = colour
    out[reasons == -1] = 0
    return out


def legend_strip(path, bar):
    """The scale as a picture, LEGEND_STEPS x 1 (the page stretches it): LOW to the bar."""
    t = np.linspace(0.0, 1.0, LEGEND_STEPS)
    grey = np.rint(LIGHT + (DARK - LIGHT) * t).astype(np.uint8)
    Image.fromarray(np.repeat(grey[None, :, None], 3, axis=-1)).save(path, format="PNG")
    return path


def write_shared_heat_maps(reports, heat_dir, out_dir, bar):
    """One shared-scale PNG per report whose compare heat map exists: {index: path or None},
    and the legend strip. heat_dir holds compare-all's <label>_<object>.png."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    colours = reason_colours()
    paths = {}
    for i, r in enumerate(reports):
        name = f"{case_label(r)}_{r['object']}.png"
        source = Path(heat_dir) / name
        if not source.is_file():
            paths[i] = None
            continue
        error, reasons = decode_heat_png(source, r["max_deg"], colours)
        Image.fromarray(shared_rgba(error, reasons, bar, colours)).save(out_dir / name,
                                                                        format="PNG")
        paths[i] = out_dir / name
    legend = legend_strip(out_dir / "legend.png", bar)
    return paths, legend, colours


def case_label(report):
    """compare-all's label of a case: the method, with its variant when it has one."""
    return report["method"] + (f"-{report['variant']}" if report.get("variant") else "")
