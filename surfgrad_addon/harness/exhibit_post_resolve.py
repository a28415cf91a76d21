"""The post-resolve exhibit (docs/exhibits/post-resolve.png, figures in post-resolve.json):
fine volume noise added on top of a normal-mapped surface (section 4.6), the usual way and the
surface-gradient way, on the same plane, the same map of domes, the same noise, the same light.

The usual way is what Blender artists are told to do: the Normal Map node's normal into the
Bump node's Normal, the noise's Value into its Height. The Bump node then uses the new normal,
but takes the height's differences along the real surface (its dP/dx, dP/dy), which section 3.7
says must be updated with the base normal too. On a dome's flank, where the resolved normal
leans far from the real one, the detail is stretched by 1 / cos(lean) across the slope and the
noise's change along the normal is lost. The surface-gradient way resolves the normal map
first (SG Normal Map, SG Resolve), then projects the noise's gradient on that resolved normal's
plane (SG Volume Gradient, Listing 8, with it as Normal) and resolves against it again.

Both are baked and compared texel by texel with the numpy reference (reference
post_resolve_bump); the usual bake is also compared with a numpy model of the Bump node
(bump_node_normal), which says where its difference comes from. The picture is a Cycles render
of the two planes above the two error maps on one scale.

    python -m surfgrad_addon.harness.exhibit_post_resolve [PICTURE]    (under a minute)
"""

import json
import math
from pathlib import Path

import numpy as np

from ..addon import groups as G
from ..reference import listings as L
from ..reference import methods as M
from ..reference.compositing import post_resolve_bump
from ..reference.cycles_bake import bump_differentials
from ..reference.images import hemisphere_tile_image
from ..reference.noise import fractal_sum
from ..reference.vecmath import transform
from . import demo_scene as S
from .exhibit_freeze import render_pixels
from .graph import Graph, surface_gradient

PICTURE = Path("docs") / "exhibits" / "post-resolve.png"
SIZE, SAMPLES = (1280, 720), 16
RENDER_ROWS = 420                 # the render's height in the picture; error maps below
BAKE_RESOLUTION = 96              # the error maps' texels (2 px each), and the JSON's figures
HEAT_PX = 192
UV_MAP = "UVMap"
DOMES = {"size": 256, "tiles": 3, "radius": 0.9}    # the macro normal map
NOISE_SCALE, NOISE_OCTAVES = 12.0, 2
DETAIL = 0.012                    # world units of relief per unit of noise, on both sides
BUMP_FILTER_WIDTH = 0.1           # the Bump node's default, set where the line has it
LEAN_ZONES = ((0, 1), (1, 30), (30, 60), (60, 90))   # degrees the resolved normal leans
ERROR_TOP = 20.0                  # degrees at the top of the error maps' scale
LABELS = ("usual: Bump node on the Normal Map's normal",
          "surface gradient: SG Volume Gradient on the resolved normal")
TITLE = "Post-resolve detail: fine noise on a normal map of domes"
X_OFFSET = 1.25                   # the planes at x -+ this (demo_scene.pair's spacing)
PLANE_TILT = 40.0                 # degrees the planes lean back from facing the camera
CAMERA_DISTANCE = 7.8


def dome_pixels():
    return hemisphere_tile_image(DOMES["size"], DOMES["tiles"], DOMES["radius"])


# The two node graphs (each returns the shading normal) ----------------------------------------

def _noise(g):
    return g.group(G.noise_group(), Scale=NOISE_SCALE, Octaves=NOISE_OCTAVES)


def usual(g, image):
    """Normal Map node -> Bump node's Normal, SG Noise's Value -> its Height."""
    base = g.normal_map(g.image(image, g.uv(UV_MAP)), "TANGENT", uv_map=UV_MAP)
    return g.bump(_noise(g).outputs["Value"], base, filter_width=BUMP_FILTER_WIDTH,
                  distance=DETAIL)


def surface_gradient_way(g, image):
    """SG Normal Map -> SG Resolve (the new base normal); SG Noise's Gradient through SG
    Volume Gradient on it, resolved against it (section 4.6)."""
    nm = g.group(G.normal_map_group(UV_MAP), Color=g.image(image, g.uv(UV_MAP)))
    base = g.resolve(surface_gradient(nm))
    detail = g.group(G.volume_gradient_group(), Gradient=_noise(g).outputs["Gradient"],
                     Bump_Scale=DETAIL, Normal=base)
    return g.resolve(surface_gradient(detail), normal=base)


SIDES = {"usual": usual, "surface gradient": surface_gradient_way}


# The numpy side --------------------------------------------------------------------------------

def resolved_base(td, pixels):
    """(n, sg, n1): the shading normal, the map's surface gradient on it, and the resolved
    normal both sides put the detail on."""
    n, sg = M.normal_map_surfgrad(td, pixels, UV_MAP)
    return n, sg, M.resolve((n, sg))


def reference_normal(td, pixels):
    """Section 4.6: resolve the map, make it the base normal, Listing 8 on it, resolve again."""
    n, sg, _ = resolved_base(td, pixels)
    _, grad = M.noise_gradient_world(td, NOISE_SCALE, NOISE_OCTAVES)
    return post_resolve_bump(n, sg, lambda n1: DETAIL * L.surfgrad_from_volume_gradient(n1,
                                                                                        grad))


def bump_node_normal(td, pixels, exact=False):
    """Cycles' Bump node given the resolved normal N: the noise's forward differences along
    the bake's dP/dx, dP/dy of the real surface (Filter Width steps long), into Listing 6 with
    screen-space derivatives on N (Mikkelsen 2010, what the node computes). exact: the
    noise's exact change along those steps (the node without its forward differences' error),
    which leaves only what comes of N leaning away from the real surface."""
    _, _, n1 = resolved_base(td, pixels)
    fw = td.facts.bump_step_scale(BUMP_FILTER_WIDTH)
    dpdx, dpdy = (fw * d for d in bump_differentials(td))
    p, to_object = td.position_object, td.mesh.normal_matrix     # v @ M^-T is M^-1 v
    if exact:
        _, grad = M.noise_gradient_world(td, NOISE_SCALE, NOISE_OCTAVES)
        steps = [np.sum(grad * d, axis=-1) for d in (dpdx, dpdy)]
    else:
        def height(step):
            return fractal_sum((p + transform(step, to_object)) * NOISE_SCALE,
                               octaves=NOISE_OCTAVES)[0]
        h_c = height(np.zeros_like(dpdx))
        steps = [height(dpdx) - h_c, height(dpdy) - h_c]
    deriv = DETAIL * np.stack(steps, axis=-1)
    sg = L.surfgrad_scale_dependent(n1, dpdx, dpdy, deriv, None, None, None,
                                    is_deriv_screen_space=True)
    return M.resolve((n1, sg))


# Scene, bakes and figures ----------------------------------------------------------------------

def build_scene():
    """A fresh file with the two planes (demo_scene's plane, tilted PLANE_TILT back) and the
    one packed map of domes; returns ({side: object}, the image, its pixels)."""
    S.new_file()
    pixels = dome_pixels()
    image = S.image("Domes", pixels)
    objs = {}
    for dx, (side, build) in zip((-X_OFFSET, X_OFFSET), SIDES.items()):
        obj = S.mesh("plane", (dx, 0, 1.1), f"Post-resolve | {side}")
        obj.rotation_euler.x = math.radians(90.0 - PLANE_TILT)
        obj.data.materials.append(S.material(f"Post-resolve: {side}",
                                             lambda g, build=build: build(g, image)))
        objs[side] = obj
    return objs, image, pixels


def lean_image(obj, pixels, resolution):
    """Per texel of obj's bake, the angle (degrees) between the shading normal and the normal
    map's resolved normal (NaN where no triangle covers it): how far the base leans."""
    import bpy
    from . import bake as B
    from .mesh_data import mesh_arrays_from_object
    from ..reference import raster
    from ..reference.agreement import angle_deg
    bpy.context.view_layer.update()
    td = raster.rasterize(mesh_arrays_from_object(obj), UV_MAP, resolution, resolution,
                          facts=B.running_line(), as_baked=True)
    n, _, n1 = resolved_base(td, pixels)
    return td.to_image(angle_deg(n, n1))


def _stats(err):
    err = err[np.isfinite(err)]
    return {"mean_deg": float(err.mean()), "p99_deg": float(np.percentile(err, 99)),
            "max_deg": float(err.max()), "texels": int(err.size)}


def measure(objs, image, pixels, resolution=BAKE_RESOLUTION):
    """Bake each side on its plane and compare it with the reference (and the usual one with
    the Bump node's model too): (figures, {name: error image (H, W) in degrees}). The figures
    hold each comparison's mean, p99 and max, and by LEAN_ZONES of the base's lean."""
    import bpy
    from .compare import Inputs, compare_graph
    figures, heats = {}, {}
    cases = (("usual", "reference", reference_normal),
             ("usual", "bump node model", bump_node_normal),
             ("surface gradient", "reference", reference_normal))
    lean = lean_image(objs["usual"], pixels, resolution)     # the planes are alike
    for side, against, truth in cases:
        obj = objs[side]
        inp = Inputs(obj=obj, uv_map=UV_MAP, detail_uv=UV_MAP)

        def graph(inp, nodes, links, side=side):
            return SIDES[side](Graph(nodes, links), image)

        def ref(inp, td, truth=truth):
            normal = truth(td, pixels)
            return normal, np.zeros_like(normal)
        _, heat = compare_graph(inp, obj, graph, ref, resolution)
        heat = np.asarray(heat, dtype=np.float64)
        name = f"{side} vs {against}"
        figures[name] = _stats(heat)
        figures[name]["by_lean"] = {f"{lo:g}-{hi:g}": _stats(heat[(lean >= lo) & (lean < hi)])
                                    for lo, hi in LEAN_ZONES}
        heats[name] = heat
    figures["blender"] = bpy.app.version_string
    figures["resolution"] = resolution
    return figures, heats


# The picture ---------------------------------------------------------------------------------

def camera():
    """Framing the two planes, for a render RENDER_ROWS tall."""
    import bpy
    cam = S.camera("Camera post-resolve", 0.0, z=1.1, distance=CAMERA_DISTANCE)
    cam.data.sensor_fit = "HORIZONTAL"
    bpy.context.scene.camera = cam
    return cam


def degrees(v):
    """Two significant figures (under 0.001: "<0.001"), as the picture prints them."""
    return (f"{v:.0f}" if v >= 10 else f"{v:.1f}" if v >= 1 else f"{v:.2g}" if v >= 1e-3
            else "<0.001")


def _stats_text(r):
    return (f"mean {degrees(r['mean_deg'])}\u00b0, p99 {degrees(r['p99_deg'])}\u00b0, "
            f"max {degrees(r['max_deg'])}\u00b0")


def _lean_text(r):
    """The mean error per zone of the base's lean, a line each."""
    rows = [f"{lo:g}-{hi:g}\u00b0: {degrees(r['by_lean'][f'{lo:g}-{hi:g}']['mean_deg'])}\u00b0"
            for lo, hi in LEAN_ZONES]
    return "mean error where the\nmap leans the normal\n" + "\n".join(rows)


def compose(render, figures, heats, path):
    """The title, the render with each side's label over it, and below each side its error
    against the reference on one scale (a colour bar between them). Layout in pixels from the
    top of the 1280 x 720 picture."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    w, h = SIZE

    def box(left, top, width, height):          # pixels -> the figure's fractions
        return (left / w, 1.0 - (top + height) / h, width / w, height / h)

    def text(x, top, words, **kw):
        fig.text(x / w, 1.0 - top / h, words, ha="center", va="top", **kw)
    fig = plt.figure(figsize=(w / 100, h / 100), dpi=100, facecolor="white")
    text(w / 2, 4, TITLE, fontsize=17)
    render_top = 60
    ax = fig.add_axes(box(0, render_top, w, RENDER_ROWS))
    ax.imshow(render, interpolation="nearest", aspect="auto")
    ax.set_axis_off()
    heat_top = render_top + RENDER_ROWS + 28
    for x, label, name, outward in zip((w / 4, 3 * w / 4), LABELS,
                                       ("usual vs reference", "surface gradient vs reference"),
                                       (-1, 1)):
        text(x, 35, label, fontsize=13)
        text(x, render_top + RENDER_ROWS + 5, "error against the reference: "
             + _stats_text(figures[name]), fontsize=11.5)
        ex = fig.add_axes(box(x - HEAT_PX / 2, heat_top, HEAT_PX, HEAT_PX))
        fig.text((x + outward * (HEAT_PX / 2 + 16)) / w, 1.0 - (heat_top + HEAT_PX / 2) / h,
                 _lean_text(figures[name]), ha="right" if outward < 0 else "left",
                 va="center", fontsize=10.5, linespacing=1.35)
        im = ex.imshow(heats[name][::-1], cmap="inferno", vmin=0.0, vmax=ERROR_TOP,
                       interpolation="nearest", aspect="auto")
        ex.set_xticks([])
        ex.set_yticks([])
    bar = fig.add_axes(box(w / 2 - 12, heat_top + 8, 24, HEAT_PX - 16))
    cb = fig.colorbar(im, cax=bar, extend="max")
    cb.set_label("degrees", fontsize=10)
    note = (f"error maps: each plane's UV square, baked at {figures['resolution']} x "
            f"{figures['resolution']} (Blender {figures['blender']}), against the numpy "
            f"reference of section 4.6")
    fig.text(0.5, 2 / h, note, ha="center", va="bottom", fontsize=9, color="0.35")
    fig.savefig(path, dpi=100, facecolor="white")
    plt.close(fig)
    return path


def write_figures(figures, path):
    path.write_text(json.dumps(figures, indent=1, sort_keys=True) + "\n")
    return path


def render(path=PICTURE, samples=SAMPLES, resolution=BAKE_RESOLUTION, log=print):
    """Build the exhibit, bake and measure both sides, render them and write `path` (PNG,
    1280 x 720) with its figures beside it (same name, .json); returns (path, figures).
    Replaces the open file."""
    objs, image, pixels = build_scene()
    figures, heats = measure(objs, image, pixels, resolution)
    camera()
    render_rows = render_pixels((SIZE[0], RENDER_ROWS), samples, denoise=True)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    compose(render_rows, figures, heats, path)
    write_figures(figures, path.with_suffix(".json"))
    log(f"rendered {path} and {path.with_suffix('.json')}")
    return path, figures


if __name__ == "__main__":
    import sys
    render(sys.argv[1] if len(sys.argv) > 1 else PICTURE)
