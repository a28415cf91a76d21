"""The report page's heat maps: every case's error on one shared, logarithmic scale.

compare-all's heat PNGs (heat_map.write_heat_map) each scale their error to their own top,
max(0.5 deg, the case's max). Their palette indices are read back into degrees here, using the
case's report for the top: a level is sqrt(error / top) to 1/500 (about 6 % of a value down to
1e-4 of the top). The texels the writer painted in a reason's colour (not compared, contested,
excluded) keep that reason.
"""

from pathlib import Path

import numpy as np
from PIL import Image

# The shared scale (degrees): log10 from LOW to the max bar; darker is a larger error.
LOW = 1e-5
OVER_BAR = (214, 39, 40)          # red: above the max bar
LIGHT, DARK = 248.0, 24.0         # grey levels at LOW and at the bar
LEGEND_STEPS = 512


def reason_colours():
    """{reason code: RGB bytes} as the compare writer paints them (its palette's slots)."""
    from ..heat_map import HEAT_COLOURS, LEVELS, heat_palette
    palette = heat_palette()
    return {code: tuple(int(c) for c in palette[LEVELS + code]) for code in HEAT_COLOURS}


def decode_heat_png(path, max_deg):
    """(error (H, W) in degrees, NaN where the picture shows a reason; reasons (H, W) int8:
    0 where an error was read, -1 not compared, else the compare's reason code) from a compare
    heat PNG (indexed: heat_map.write_heat_map) whose case's max error is max_deg. Rows stay
    in the PNG's order."""
    from ..heat_map import LEVELS, level_value
    image = Image.open(path)
    if image.mode != "P":
        raise ValueError(f"{path} is not a compare heat map (an indexed PNG); run compare-all "
                         f"again to write it")
    index = np.asarray(image).astype(np.int32)
    top = max(0.5, float(max_deg or 0.0))
    # A slot past the levels is a reason (LEVELS + code); code 0, "no error" (not covered by
    # both sides), is a reason of its own on the page: -1.
    reasons = np.where(index >= LEVELS, index - LEVELS, 0).astype(np.int8)
    reasons[index == LEVELS] = -1
    error = np.where(reasons == 0, level_value(np.minimum(index, LEVELS - 1)) * top, np.nan)
    return error, reasons


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
        error, reasons = decode_heat_png(source, r["max_deg"])
        Image.fromarray(shared_rgba(error, reasons, bar, colours)).save(out_dir / name,
                                                                        format="PNG")
        paths[i] = out_dir / name
    legend = legend_strip(out_dir / "legend.png", bar)
    return paths, legend, colours


def case_label(report):
    """compare-all's label of a case: the method, with its variant when it has one and its
    settings when not the defaults (compare_all._label)."""
    from ..compare_settings import label
    at = label(report.get("settings"))
    return (report["method"] + (f"-{report['variant']}" if report.get("variant") else "")
            + (f"-{at}" if at else ""))
