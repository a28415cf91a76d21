"""The bench's scenarios: each a scene, its methods (node graphs baked by Cycles), and an
analytic ground truth computed by the reference in float64 from the continuous definition
(what a scenario is: scenario.py). Here the height, noise, triplanar and screen-derivative
scenarios and the list of all; the ones that blend detail with other frames are in
scenarios_blending.py.

A method's `build(g, ctx)` returns the socket of the final world-space normal; `reference`
(optional) evaluates the same method with the numpy reference, for the reference's timing.
"""

from ...addon import groups as G
from ...addon.node_vocabulary import Math, VMath
from ...reference import listings as L
from ...reference import methods as M
from ...reference import images as T
from . import scenarios_blending as B
from .scenario import (Context, Method, Scenario, bake_normal_map_from_truth,
                       exact_height_surfgrad, float_image, hemi_deriv, sphere_context)


# Scenario 1: height detail on a curved mesh --------------------------------------------------

HEIGHT_FREQ = (6.0, 3.0)
HEIGHT_SCALE = 0.1


def _height_setup(quick):
    from .. import scenes
    from ..mesh_data import mesh_arrays_from_object
    objs = scenes.new_scene(["Sphere"])
    ctx = Context(objects=objs)
    sizes = (32, 64) if quick else (32, 64, 128)
    ctx.params["sizes"] = sizes
    mesh = mesh_arrays_from_object(objs["Sphere"])

    def truth_of(td):
        return M.resolve(exact_height_surfgrad(td, T.wave_height(td.uv(), HEIGHT_FREQ)[1],
                                               HEIGHT_SCALE))
    for size in sizes:
        float_image(ctx, f"height{size}", T.wave_height_image(size, HEIGHT_FREQ))
        float_image(ctx, f"normal{size}", bake_normal_map_from_truth(mesh, "UVMap", size,
                                                                     truth_of))
    return ctx


def _height_methods(ctx):
    out = []
    for size in ctx.params["sizes"]:
        h, nm = f"height{size}", f"normal{size}"

        def bump(g, c, h=h):
            node = g.node("ShaderNodeBump")
            node.inputs["Distance"].default_value = HEIGHT_SCALE
            g.link(g.first(g.image(c.img(h), g.uv(c.uv_map))), node.inputs["Height"])
            return node.outputs["Normal"]

        def forward(g, c, h=h):
            node = g.group(G.height_map_forward_group(), Height=g.first(
                g.image(c.img(h), g.uv(c.uv_map))), Bump_Scale=HEIGHT_SCALE)
            return g.resolve(node.outputs[0])

        def tapped(variant, h=h):
            def build(g, c):
                node = g.group(G.height_map_group(c.img(h), variant), UV=g.uv(c.uv_map),
                               Bump_Scale=HEIGHT_SCALE)
                return g.resolve(node.outputs[0])
            return build

        def sg_normal_map(g, c, nm=nm):
            node = g.group(G.normal_map_group(c.uv_map),
                           Color=g.image(c.img(nm), g.uv(c.uv_map)))
            return g.resolve(node.outputs[0])

        def blender_normal_map(g, c, nm=nm):
            node = g.node("ShaderNodeNormalMap", uv_map=c.uv_map)
            g.link(g.image(c.img(nm), g.uv(c.uv_map)), node.inputs["Color"])
            return node.outputs["Normal"]

        def ref_height(variant, h=h):
            return lambda c, td: M.resolve(M.height_map_surfgrad(td, c.px(h), variant,
                                                                 HEIGHT_SCALE))
        out += [
            Method(f"Blender Bump {size}", "blender", bump),
            Method(f"SG forward {size}", "sg", forward, ref_height("forward")),
            Method(f"SG one-texel {size}", "sg", tapped("one-texel"), ref_height("one-texel")),
            Method(f"SG HQ {size}", "sg", tapped("hq"), ref_height("hq")),
            Method(f"SG normal map {size}", "sg", sg_normal_map,
                   lambda c, td, nm=nm: M.resolve(M.normal_map_surfgrad(td, c.px(nm)))),
            Method(f"Blender Normal Map {size}", "blender", blender_normal_map),
        ]
    return out


def _height_truth(ctx, td):
    return M.resolve(exact_height_surfgrad(td, T.wave_height(td.uv(), HEIGHT_FREQ)[1],
                                           HEIGHT_SCALE))


# Scenario 2: volume noise bump ----------------------------------------------------------------

NOISE_SCALE, NOISE_AMOUNT, FD_STEP = 4.0, 0.05, 2e-3
# Two octaves: Blender's Bump node compiles three shifted copies of its height graph side by
# side, and Cycles' SVM stack (255 floats) holds them for at most two octaves of SG Noise.
NOISE_OCTAVES = 2


def _noise_value(g, vector=None):
    node = g.group(G.noise_group(), Scale=NOISE_SCALE, Octaves=NOISE_OCTAVES)
    if vector is not None:
        g.link(vector, node.inputs["Vector"])
    return node


def _noise_methods(ctx):
    def grad(g):
        return _noise_value(g).outputs["Gradient"]

    def perlin(g, c):
        return g.perlin(g.geometry("Normal"), g.scale(grad(g), NOISE_AMOUNT))

    def analytic(g, c):
        vg = g.group(G.volume_gradient_group(), Gradient=grad(g), Bump_Scale=NOISE_AMOUNT)
        return g.resolve(vg.outputs[0])

    def differences(central):
        def build(g, c):
            p = g.node("ShaderNodeTexCoord").outputs["Object"]

            last = [None]

            def value_at(offset):
                q = g.vmath(VMath.ADD, p, offset)
                if last[0] is not None:
                    # Serialise the evaluations (q + (v - v) is exactly q) so Cycles' SVM
                    # compiler never holds two noise evaluations' temporaries at once.
                    q = g.vmath(VMath.ADD, q, g.math(Math.SUBTRACT, last[0], last[0]))
                last[0] = _noise_value(g, q).outputs["Value"]
                return last[0]
            comps = []
            centre = None if central else value_at((0.0, 0.0, 0.0))
            for axis in range(3):
                e = [0.0, 0.0, 0.0]
                e[axis] = FD_STEP
                plus = value_at(tuple(e))
                if central:
                    minus = value_at(tuple(-x for x in e))
                    comps.append(g.math(Math.DIVIDE, g.math(Math.SUBTRACT, plus, minus), 2 * FD_STEP))
                else:
                    comps.append(g.math(Math.DIVIDE, g.math(Math.SUBTRACT, plus, centre), FD_STEP))
            comb = g.node("ShaderNodeCombineXYZ")
            for slot, v in zip(comb.inputs, comps):
                g.link(v, slot)
            vg = g.group(G.volume_gradient_group(), Gradient=comb.outputs[0],
                         Bump_Scale=NOISE_AMOUNT)
            return g.resolve(vg.outputs[0])
        return build

    def bump(g, c):
        node = g.node("ShaderNodeBump")
        node.inputs["Distance"].default_value = NOISE_AMOUNT
        g.link(_noise_value(g).outputs["Value"], node.inputs["Height"])
        return node.outputs["Normal"]
    return [
        Method("Perlin 1985", "baseline", perlin,
               lambda c, td: M.volume_noise_perlin1985(td, NOISE_SCALE, NOISE_AMOUNT,
                                                       NOISE_OCTAVES)),
        Method("SG analytic gradient", "sg", analytic,
               lambda c, td: M.resolve(M.volume_noise_surfgrad(td, NOISE_SCALE, NOISE_AMOUNT,
                                                               NOISE_OCTAVES))),
        Method("SG forward differences", "sg", differences(False)),
        Method("SG central differences", "sg", differences(True)),
        Method("Blender Bump on the noise", "blender", bump),
    ]


def _noise_truth(ctx, td):
    return M.resolve(M.volume_noise_surfgrad(td, NOISE_SCALE, NOISE_AMOUNT, NOISE_OCTAVES))


# Scenario 3: triplanar --------------------------------------------------------------------------

TRI_SCALE = 1.0


def _triplanar_setup(quick):
    ctx = sphere_context(quick)
    float_image(ctx, "hemi", T.hemisphere_tile_image(128 if quick else 256))
    return ctx


def _triplanar_colors(g, c):
    coords = g.group(G.triplanar_coordinates_group(), Scale=TRI_SCALE)
    return [g.image(c.img("hemi"), coords.outputs[f"UV {a}"]) for a in "XYZ"]


def _triplanar_methods(ctx):
    from . import baseline_groups as BG

    def box(g, c):
        p = g.scale(g.node("ShaderNodeTexCoord").outputs["Object"], TRI_SCALE)
        color = g.image(c.img("hemi"), p, projection="BOX")
        color.node.projection_blend = 0.3
        nm = g.node("ShaderNodeNormalMap", uv_map=c.uv_map)
        g.link(color, nm.inputs["Color"])
        return nm.outputs["Normal"]

    def with_group(tree_fn):
        def build(g, c):
            node = g.group(tree_fn())
            for axis, color in zip("XYZ", _triplanar_colors(g, c)):
                g.link(color, node.inputs[f"Color {axis}"])
            return node.outputs[0]
        return build

    def sg(g, c):
        node = g.group(G.triplanar_group())
        for axis, color in zip("XYZ", _triplanar_colors(g, c)):
            g.link(color, node.inputs[f"Color {axis}"])
        return g.resolve(node.outputs["Surface Gradient"])
    return [
        Method("Blender Box + Normal Map", "blender", box),
        Method("Geiss traditional", "baseline", with_group(BG.triplanar_geiss_group),
               lambda c, td: M.triplanar_geiss_normal(td, c.px("hemi"), TRI_SCALE)),
        Method("Derivatives + Perlin", "baseline",
               with_group(BG.triplanar_derivative_perlin_group)),
        Method("SG Triplanar", "sg", sg,
               lambda c, td: M.resolve(M.triplanar_surfgrad(td, c.px("hemi"), TRI_SCALE))),
    ]


def _triplanar_truth(ctx, td):
    n = M.unit_base_normal(td)
    w = L.determine_triplanar_weights(n)
    p = td.position * TRI_SCALE
    d = [hemi_deriv(p[:, list(ax)]) for ax in ((2, 1), (0, 2), (0, 1))]
    return M.resolve((n, L.surfgrad_from_triplanar_projection(n, w, *d)))


# Scenario 7: screen-derivative bump -----------------------------------------------------------------

def _screen_setup(quick):
    ctx = sphere_context(quick)
    float_image(ctx, "height", T.wave_height_image(64, HEIGHT_FREQ))
    return ctx


def _screen_methods(ctx):
    from . import baseline_groups as BG

    def lx(g, c):
        res = c.params["resolution"]
        uv = g.uv(c.uv_map)
        taps = [g.first(g.image(c.img("height"), g.vmath(VMath.ADD, uv, off)))
                for off in ((0.0, 0.0, 0.0), (1.0 / res, 0.0, 0.0), (0.0, 1.0 / res, 0.0))]
        node = g.group(BG.lxengine_group(), UV=uv, Height=taps[0], **{"Height +X": taps[1], "Height +Y": taps[2]},
                       Bump_Scale=HEIGHT_SCALE)
        return node.outputs[0]

    def tapped(variant):
        def build(g, c):
            node = g.group(G.height_map_group(c.img("height"), variant), UV=g.uv(c.uv_map),
                           Bump_Scale=HEIGHT_SCALE)
            return g.resolve(node.outputs[0])
        return build

    def forward(g, c):
        node = g.group(G.height_map_forward_group(), Height=g.first(
            g.image(c.img("height"), g.uv(c.uv_map))), Bump_Scale=HEIGHT_SCALE)
        return g.resolve(node.outputs[0])
    return [Method("LxEngine screen derivatives", "baseline", lx,
                   lambda c, td: M.height_map_lxengine(td, c.px("height"), HEIGHT_SCALE)),
            Method("SG forward", "sg", forward),
            Method("SG one-texel", "sg", tapped("one-texel")),
            Method("SG HQ", "sg", tapped("hq"))]


SCENARIOS = [
    Scenario("height", "1. Height detail on a curved mesh (Figure 8)", _height_setup,
             _height_methods, _height_truth),
    Scenario("noise", "2. Volume noise bump (Figure 4)", sphere_context, _noise_methods,
             _noise_truth),
    Scenario("triplanar", "3. Triplanar hemispheres (Figure 5)", _triplanar_setup,
             _triplanar_methods, _triplanar_truth),
    B.DECAL,
    B.SECOND_UV,
    B.LAYERING,
    Scenario("screen-derivative", "7. Screen-derivative bump (LxEngine)", _screen_setup,
             _screen_methods, _height_truth),
]
