"""The bench's scenarios that blend detail with other frames (scenarios.py holds the list): a
decal across two objects, detail on a second UV map, two tangent normals layered."""

import numpy as np

from ...addon import groups as G
from ...addon.node_vocabulary import VMath
from ...reference import listings as L
from ...reference import methods as M
from ...reference import images as T
from .scenario import Context, Method, Scenario, float_image, hemi_deriv, sphere_context


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
    ctx = sphere_context(quick)
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
    ctx = sphere_context(quick)
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
        correction = g.vmath(VMath.SUBTRACT, g.geometry("Normal"), frame_n)
        return g.resolve(g.vmath(VMath.SUBTRACT, g.vmath(VMath.ADD, sa, sb), correction))
    return [Method("UDN", "baseline", blend(2)), Method("Whiteout", "baseline", blend(1)),
            Method("RNM", "baseline", blend(3)), Method("PD", "baseline", blend(0)),
            Method("SG addition", "sg", addition)]


def _layer_truth(ctx, td):
    n = M.unit_base_normal(td)
    n_f, t, b = M.mikktspace_frame(td, ctx.uv_map)
    uv = td.uv(ctx.uv_map)
    d = hemi_deriv(uv) + hemi_deriv(uv, DETAIL_TILES, DETAIL_RADIUS)
    return M.resolve((n, L.surfgrad_from_tbn(d, t, b) + (n - n_f)))


DECAL = Scenario("decal", "4. Decal on a torus crossing a plane (Figure 6)", _decal_setup,
                 _decal_methods, _decal_truth)
SECOND_UV = Scenario("second-uv", "5. Detail on a second, rotated UV map (Figure 1)",
                     _second_uv_setup, _second_uv_methods, _second_uv_truth)
LAYERING = Scenario("layering", "6. Layering two tangent normals (Table 1)", _layer_setup,
                    _layer_methods, _layer_truth)
