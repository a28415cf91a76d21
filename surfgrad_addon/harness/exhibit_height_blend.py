"""The height-blend exhibit (docs/exhibits/height-blend.png): sand on cobblestones, laid on by
the usual masked mix (a mask that knows nothing of the heights, sand over the stones' tops) and
by SG Height Blend (the sand settles between the stones, the stones' tops stay clean). Both
planes carry the same two layers: cobbles (a Voronoi distance-to-edge height through SG Height
Map Forward) and fine sand (SG Noise through SG Volume Gradient); the colour follows each
blend's weight."""

import math
from pathlib import Path

from ..addon import groups as G
from ..addon.node_vocabulary import Math
from . import demo_scene as S
from .graph import surface_gradient

PICTURE = Path("docs") / "exhibits" / "height-blend.png"
SIZE, SAMPLES = (1280, 720), 8
ROCK_COLOR, SAND_COLOR = (0.17, 0.165, 0.16, 1.0), (0.55, 0.38, 0.18, 1.0)
SAND_LEVEL = 0.55         # Offset B: how high the sand fills between the stones
SAND_RELIEF = 0.1         # the sand's own height: SG Noise's Value times this
COBBLE_SCALE = 3.5


def _layers(g):
    """(rock SG, rock height, sand SG, sand height) on the object coordinates."""
    coords = g.node("ShaderNodeTexCoord").outputs["Object"]
    edge = g.node("ShaderNodeTexVoronoi", voronoi_dimensions="3D", feature="DISTANCE_TO_EDGE")
    g.set(edge, Vector=coords, Scale=COBBLE_SCALE)
    cell = g.node("ShaderNodeTexVoronoi", voronoi_dimensions="3D", feature="F1")
    g.set(cell, Vector=coords, Scale=COBBLE_SCALE)
    grain = g.node("ShaderNodeTexNoise")
    g.set(grain, Vector=coords, Scale=9.0, Detail=4.0)
    # Rounded stones with flat tops (the distance to the cell's edge, saturated), each stone
    # its own height (the cell's random colour), and some grain on top.
    dome = g.math(Math.POWER, g.math(Math.MINIMUM, g.math(Math.MULTIPLY, edge.outputs[
        "Distance"], 7.0), 1.0), 0.5)
    stone = g.math(Math.MULTIPLY_ADD, g.first(cell.outputs["Color"]), 0.5, 0.5)
    rock_h = g.math(Math.MULTIPLY_ADD, grain.outputs["Fac"], 0.2, g.math(Math.MULTIPLY, dome,
                                                                        stone))
    rock = g.group(G.height_map_forward_group(), Height=rock_h, Bump_Scale=0.03)
    noise = g.group(G.noise_group(), Scale=40.0, Octaves=3)
    sand = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                   Bump_Scale=0.0015)
    sand_h = g.math(Math.MULTIPLY, noise.outputs["Value"], SAND_RELIEF)
    return surface_gradient(rock), rock_h, surface_gradient(sand), sand_h


def _colour(g, weight_b):
    """Base colour and roughness of the rock and the sand, mixed by the sand's weight."""
    bsdf = next(n for n in g.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    mix = g.node("ShaderNodeMix", data_type="RGBA")
    ins = {s.identifier: s for s in mix.inputs}
    g.link(weight_b, ins["Factor_Float"])
    ins["A_Color"].default_value, ins["B_Color"].default_value = ROCK_COLOR, SAND_COLOR
    g.link({s.identifier: s for s in mix.outputs}["Result_Color"], bsdf.inputs["Base Color"])
    g.link(g.math(Math.MULTIPLY_ADD, weight_b, 0.5, 0.45), bsdf.inputs["Roughness"])


def masked_mix(g):
    """The usual way: a mask of its own (large noise patches), A (1 - m) + B m."""
    rock, _, sand, _ = _layers(g)
    patches = g.node("ShaderNodeTexNoise")
    g.set(patches, Vector=g.node("ShaderNodeTexCoord").outputs["Object"], Scale=1.2,
          Detail=2.0)
    ramp = g.node("ShaderNodeMapRange")
    g.set(ramp, Value=patches.outputs["Fac"], From_Min=0.47, From_Max=0.55)
    mask = ramp.outputs["Result"]
    combine = g.group(G.combine_group(), A=rock, B=sand,
                      Scale_A=g.math(Math.SUBTRACT, 1.0, mask), Mask_B=mask)
    _colour(g, mask)
    return g.resolve(combine.outputs[0])


def height_blend(g):
    rock, rock_h, sand, sand_h = _layers(g)
    blend = g.group(G.height_blend_group(), A=rock, Height_A=rock_h, B=sand, Height_B=sand_h,
                    Offset_B=SAND_LEVEL)
    _colour(g, blend.outputs["Weight B"])
    return g.resolve(blend.outputs[0])


# A spot on a plane of the pair (demo_scene.mesh "plane": 2.2 wide, tilted 70 degrees toward
# the camera), up and to the right of its centre: its local (0.25, 0.3) in world offsets.
PLANE_SPOT = (0.25, 0.3 * math.cos(math.radians(70)), 0.3 * math.sin(math.radians(70)))


def add_height_blend_exhibit(x):
    """The two planes, their labels and a camera (with a crop spot on each plane, for
    demo_pictures) at x in the open file; returns the camera."""
    a, b = S.pair(x, "Sand on cobbles", masked_mix, height_blend, kind="plane",
                  left_label="masked mix (SG Combine)",
                  right_label="height blend (SG Height Blend)")
    return S.camera("Camera height blend", x, crops=S.pair_crops(
        a, b, PLANE_SPOT, labels=("masked mix", "height blend")))


def build_height_blend_exhibit():
    """A fresh file with the exhibit alone; returns its camera."""
    S.new_file()
    return add_height_blend_exhibit(0.0)


def render_height_blend(path=PICTURE, samples=SAMPLES, size=SIZE, log=print):
    """Build the exhibit and render it with Cycles on the CPU to `path` (PNG, 1280 x 720 by
    default); returns the path. Replaces the open file."""
    import bpy
    cam = build_height_blend_exhibit()
    scene = bpy.context.scene
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = bool(getattr(bpy.app.build_options, "openimagedenoise", False))
    scene.render.image_settings.file_format = "PNG"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    scene.render.filepath = str(path.resolve())
    bpy.ops.render.render(write_still=True)
    log(f"rendered {path}")
    return path
