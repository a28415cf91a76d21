"""The bench's scenarios: each a scene, its methods (node graphs baked by Cycles), and an
analytic ground truth computed by the reference in float64 from the continuous definition.

A method's `build(g, ctx)` returns the socket of the final world-space normal; `reference`
(optional) evaluates the same method with the numpy reference, for the reference's timing.
"""

from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from ... import reference as R
from ...addon import groups as G
from ...reference import listings as L
from ...reference import methods as M
from ...reference import images as T


@dataclass
class Method:
    label: str
    family: str                                   # "sg" (ours), "blender", "baseline"
    build: Callable
    reference: Optional[Callable] = None
    memory_note: str = ""


@dataclass
class Context:
    objects: dict
    uv_map: str = "UVMap"
    images: dict = field(default_factory=dict)   # name -> (pixels, bpy image)
    params: dict = field(default_factory=dict)
    cleanup: list = field(default_factory=list)   # datablocks to remove afterwards

    def img(self, name):
        return self.images[name][1]

    def px(self, name):
        return self.images[name][0]


@dataclass
class Scenario:
    name: str
    title: str
    setup: Callable                               # (quick) -> Context
    methods: Callable                             # (ctx) -> [Method]
    truth: Callable                               # (ctx, td) -> unit normals (N, 3)


def float_image(ctx, name, pixels):
    """A Non-Color float image Cycles reads exactly, and the same pixels for the reference."""
    from ..compare import bpy_float_image
    img = bpy_float_image(name, pixels)
    ctx.cleanup.append(img)
    px = np.asarray(pixels, dtype=np.float32).astype(np.float64)
    ctx.images[name] = (px, img)
    return img


def exact_height_surfgrad(td, deriv_st, scale):
    """Blinn's perturbed normal of a continuous height given its exact (dH/ds, dH/dt), in
    surface-gradient form (Eq. 7 through Listing 6), on the shading normal."""
    n = M.unit_base_normal(td)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps()
    return n, scale * L.surfgrad_scale_dependent(n, dpdx, dpdy, deriv_st, dst_dx, dst_dy,
                                                 (1.0, 1.0))


def bake_normal_map_from_truth(mesh, uv_map, size, truth):
    """A tangent-space normal map of `size`^2 that encodes `truth(td)` (unit world normals) in
    the mesh's MikkTSpace frame at each texel centre: what a perfect bake from the detailed
    surface would store (float, not quantised). Texels off the mesh hold (0, 0, 1)."""
    td = R.rasterize(mesh, uv_map, size, size, sample_offset=(0.5, 0.5))
    n_f, t, b = M.mikktspace_frame(td, uv_map)
    v = truth(td)
    frame = np.stack([t, b, n_f], axis=-1)                    # columns t', b', n'
    m = np.linalg.solve(frame, v[..., None])[..., 0]
    m = m / np.linalg.norm(m, axis=-1, keepdims=True)
    out = np.tile([0.0, 0.0, 1.0], (size, size, 1))
    out[td.pixel[:, 1], td.pixel[:, 0]] = m
    return 0.5 * out + 0.5


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


def hemi_deriv(st, tiles=4, radius=0.85):
    """Listing 2 of the continuous hemisphere-tile normal: the exact derivative at st."""
    return L.tspace_normal_to_derivative(T.hemisphere_tile_normal(st, tiles, radius))


def _sphere_context(quick):
    from .. import scenes
    return Context(objects=scenes.new_scene(["Sphere"]))


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
        vg = g.group(G.volume_gradient_group(), Gradient=grad(g), Strength=NOISE_AMOUNT)
        return g.resolve(vg.outputs[0])

    def differences(central):
        def build(g, c):
            p = g.node("ShaderNodeTexCoord").outputs["Object"]

            last = [None]

            def value_at(offset):
                q = g.vmath("ADD", p, offset)
                if last[0] is not None:
                    # Serialise the evaluations (q + (v - v) is exactly q) so Cycles' SVM
                    # compiler never holds two noise evaluations' temporaries at once.
                    q = g.vmath("ADD", q, g.math("SUBTRACT", last[0], last[0]))
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
                    comps.append(g.math("DIVIDE", g.math("SUBTRACT", plus, minus), 2 * FD_STEP))
                else:
                    comps.append(g.math("DIVIDE", g.math("SUBTRACT", plus, centre), FD_STEP))
            comb = g.node("ShaderNodeCombineXYZ")
            for slot, v in zip(comb.inputs, comps):
                g.link(v, slot)
            vg = g.group(G.volume_gradient_group(), Gradient=comb.outputs[0],
                         Strength=NOISE_AMOUNT)
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
    ctx = _sphere_context(quick)
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


# Scenario 4: decal on a torus crossing a plane ---------------------------------------------------

DECAL_FALLOFF = 0.2


def _decal_setup(quick):
    import bpy
    from mathutils import Euler, Matrix
    from .. import scenes
    bpy.ops.wm.read_factory_settings(use_empty=True)
    ctx = Context(objects=scenes.decal_stage())
    empty = bpy.data.objects.new("Projector", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.matrix_world = (Matrix.Translation((0.1, 0.05, 0.1)) @ Euler((0.3, -0.2, 0.4))
                          .to_matrix().to_4x4() @ Matrix.Diagonal((0.9, 0.7, 1.2, 1.0)))
    bpy.context.view_layer.update()
    ctx.params["projector"] = empty
    float_image(ctx, "hemi", T.hemisphere_tile_image(128 if quick else 256))
    return ctx


def _decal_inputs(g, c):
    tc = g.node("ShaderNodeTexCoord", object=c.params["projector"])
    coords = g.group(G.decal_coordinates_group())
    g.link(tc.outputs["Object"], coords.inputs[0])
    color = g.image(c.img("hemi"), coords.outputs[0])
    ax, ay, az, _ = M.decal_frame(np.array(c.params["projector"].matrix_world))
    return tc.outputs["Object"], color, ax, ay, az


def _decal_methods(ctx):
    from . import baseline_groups as BG

    def engine(g, c):
        q, color, ax, ay, az = _decal_inputs(g, c)
        node = g.group(BG.decal_engine_group(), Decal_Coordinates=q, Color=color,
                       Axis_X=tuple(ax), Axis_Y=tuple(ay), Axis_Z=tuple(az),
                       Falloff=DECAL_FALLOFF)
        return node.outputs[0]

    def sg(g, c):
        q, color, ax, ay, az = _decal_inputs(g, c)
        node = g.group(G.decal_group(), Decal_Coordinates=q, Color=color, Axis_X=tuple(ax),
                       Axis_Y=tuple(ay), Falloff=DECAL_FALLOFF)
        return g.resolve(node.outputs[0])
    return [
        Method("Engine decal (projector normal)", "baseline", engine),
        Method("SG Decal", "sg", sg, lambda c, td: M.resolve(M.decal_surfgrad(
            td, c.px("hemi"), np.array(c.params["projector"].matrix_world),
            falloff=DECAL_FALLOFF))),
    ]


def _decal_truth(ctx, td):
    n = M.unit_base_normal(td)
    ax, ay, _, to_local = M.decal_frame(np.array(ctx.params["projector"].matrix_world))
    q = td.position @ to_local[:3, :3].T + to_local[:3, 3]
    inside = np.all(np.abs(q[:, :2]) <= 1.0, axis=-1)
    fade = np.clip((1.0 - np.abs(q[:, 2])) / DECAL_FALLOFF, 0.0, 1.0)
    sg = L.surfgrad_from_decal(n, hemi_deriv(q[:, :2] * 0.5 + 0.5), ax, ay)
    return M.resolve((n, (inside * fade)[:, None] * sg))


# Scenario 5: detail on a second UV map -------------------------------------------------------------

def _second_uv_setup(quick):
    ctx = _sphere_context(quick)
    float_image(ctx, "hemi", T.hemisphere_tile_image(128 if quick else 256))
    return ctx


def _second_uv_methods(ctx):
    def normal_map_node(tangent_map):
        def build(g, c):
            nm = g.node("ShaderNodeNormalMap", uv_map=tangent_map)
            g.link(g.image(c.img("hemi"), g.uv("Detail")), nm.inputs["Color"])
            return nm.outputs["Normal"]
        return build

    def sg(g, c):
        uv = g.uv("Detail")
        basis = g.group(G.procedural_basis_group(), UV=uv)
        tn = g.group(G.tangent_normal_group(), Color=g.image(c.img("hemi"), uv),
                     Tangent=basis.outputs[0], Bitangent=basis.outputs[1])
        return g.resolve(tn.outputs[0])
    corners = 3 * sum(len(p.vertices) - 2 for p in ctx.objects["Sphere"].data.polygons)
    return [
        Method("First UV map's tangents", "baseline", normal_map_node("UVMap")),
        Method("Blender Normal Map (per-UV tangents)", "blender", normal_map_node("Detail"),
               memory_note=f"+{16 * corners / 1024:.0f} KiB: tangent and sign per corner "
                           f"for the second UV map ({corners} corners)"),
        Method("SG Procedural Basis", "sg", sg, lambda c, td: M.resolve(
            M.procedural_basis_surfgrad(td, c.px("hemi"), "Detail"))),
    ]


def _second_uv_truth(ctx, td):
    n = M.unit_base_normal(td)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps("Detail")
    t, b = L.gen_basis_tb(n, dpdx, dpdy, dst_dx, dst_dy)
    return M.resolve((n, L.surfgrad_from_tbn(hemi_deriv(td.uv("Detail")), t, b)))


# Scenario 6: layering two tangent normals ----------------------------------------------------------

DETAIL_TILES, DETAIL_RADIUS = 12, 0.6


def _layer_setup(quick):
    ctx = _sphere_context(quick)
    size = 128 if quick else 256
    float_image(ctx, "a", T.hemisphere_tile_image(size))
    float_image(ctx, "b", T.hemisphere_tile_image(size, DETAIL_TILES, DETAIL_RADIUS))
    return ctx


def _layer_methods(ctx):
    def blend(mode):
        def build(g, c):
            uv = g.uv(c.uv_map)
            bl = g.group(G.blend_normals_group(), Color_A=g.image(c.img("a"), uv),
                         Color_B=g.image(c.img("b"), uv), Method=mode)
            nm = g.group(G.normal_map_group(c.uv_map), Color=bl.outputs[0])
            return g.resolve(nm.outputs[0])
        return build

    def addition(g, c):
        uv = g.uv(c.uv_map)
        sa = g.group(G.normal_map_group(c.uv_map), Color=g.image(c.img("a"), uv)).outputs[0]
        sb = g.group(G.normal_map_group(c.uv_map), Color=g.image(c.img("b"), uv)).outputs[0]
        # Each SG Normal Map carries the (n - n_frame) correction; count it once.
        frame_n = g.group(G.mikktspace_frame_group(c.uv_map)).outputs[2]
        correction = g.vmath("SUBTRACT", g.geometry("Normal"), frame_n)
        return g.resolve(g.vmath("SUBTRACT", g.vmath("ADD", sa, sb), correction))
    return [Method("UDN", "baseline", blend(2)), Method("Whiteout", "baseline", blend(1)),
            Method("RNM", "baseline", blend(3)), Method("PD", "baseline", blend(0)),
            Method("SG addition", "sg", addition)]


def _layer_truth(ctx, td):
    n = M.unit_base_normal(td)
    n_f, t, b = M.mikktspace_frame(td, ctx.uv_map)
    uv = td.uv(ctx.uv_map)
    d = hemi_deriv(uv) + hemi_deriv(uv, DETAIL_TILES, DETAIL_RADIUS)
    return M.resolve((n, L.surfgrad_from_tbn(d, t, b) + (n - n_f)))


# Scenario 7: screen-derivative bump -----------------------------------------------------------------

def _screen_setup(quick):
    ctx = _sphere_context(quick)
    float_image(ctx, "height", T.wave_height_image(64, HEIGHT_FREQ))
    return ctx


def _screen_methods(ctx):
    from . import baseline_groups as BG

    def lx(g, c):
        res = c.params["resolution"]
        uv = g.uv(c.uv_map)
        taps = [g.first(g.image(c.img("height"), g.vmath("ADD", uv, off)))
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
    Scenario("noise", "2. Volume noise bump (Figure 4)", _sphere_context, _noise_methods,
             _noise_truth),
    Scenario("triplanar", "3. Triplanar hemispheres (Figure 5)", _triplanar_setup,
             _triplanar_methods, _triplanar_truth),
    Scenario("decal", "4. Decal on a torus crossing a plane (Figure 6)", _decal_setup,
             _decal_methods, _decal_truth),
    Scenario("second-uv", "5. Detail on a second, rotated UV map (Figure 1)", _second_uv_setup,
             _second_uv_methods, _second_uv_truth),
    Scenario("layering", "6. Layering two tangent normals (Table 1)", _layer_setup,
             _layer_methods, _layer_truth),
    Scenario("screen-derivative", "7. Screen-derivative bump (LxEngine)", _screen_setup,
             _screen_methods, _height_truth),
]
