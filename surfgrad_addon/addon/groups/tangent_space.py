"""Sections 3.3-3.4 and Table 1: tangent-space normal maps. Listings 2 and 3 on a
MikkTSpace frame (Listing 9, SG Normal Map) or on a generated one (Listing 4, SG Procedural
Basis, SG Tangent Normal), and the classic blends of two tangent-space normals (Eq. 18)."""

from ..node_builder import ensure_group
from ...reference.vecmath import DIVIDE_FLOOR
from . import common
from .common import (directx_input, normal_input, sign_nonneg, sub_group, surfgrad_reaching,
                     tangent_normal_to_surfgrad, uv_gradients_group, uv_input)


def procedural_basis_group():
    def build(b):
        n = normal_input(b)
        uv = uv_input(b, "Texture coordinate of a UV map without stored tangents (link a UV Map node for another map)")
        grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
        gs, gt = grads.outputs[0], grads.outputs[1]
        with b.frame("Listing 4 in surface gradients: t = normalize(sgn (grad t x n))"):
            # sign_det * flip_sign of Listing 4 is the orientation of the unwrap, the sign
            # of n . (grad s x grad t).
            orient = sign_nonneg(b, b.dot(n, b.cross(gs, gt)))
            t = b.normalize(b.scale(b.cross(gt, n), orient))
            bt = b.scale(b.cross(n, t), orient)
        b.output("Tangent", "VECTOR", t, "Unit tangent along +s")
        b.output("Bitangent", "VECTOR", bt, "Unit bitangent toward +t")
    return ensure_group("SG Procedural Basis", common.VERSION, build,
                        "Listing 4: a tangent frame for any UV map, generated per pixel")


def tangent_normal_group():
    def build(b):
        color = b.input("Color", "COLOR", "Tangent-space normal map colour (Non-Color image)",
                        default=(0.5, 0.5, 1.0, 1.0))
        directx = directx_input(b)
        strength = b.input("Strength", "FLOAT", "Bump scale", default=1.0, min_value=-10.0,
                           max_value=10.0)
        t = b.input("Tangent", "VECTOR", "Tangent (e.g. from SG Procedural Basis)",
                    hide_value=True)
        bt = b.input("Bitangent", "VECTOR", "Bitangent (e.g. from SG Procedural Basis)",
                     hide_value=True)
        sg = tangent_normal_to_surfgrad(b, color, strength, t, bt, directx)
        b.output("Surface Gradient", "VECTOR", sg, "Surface gradient")
    return ensure_group("SG Tangent Normal", common.VERSION, build,
                        "Listings 2 and 3: tangent-space normal to surface gradient on a "
                        "given tangent frame")


def mikktspace_frame_group(uv_map=""):
    """Listing 9's frame for one UV map, from Normal Map nodes fed constant colours.

    The Normal Map node returns normalize(M^-T (m.x T + m.y B + m.z N)) for the interpolated,
    unnormalised MikkTSpace T, B = sign N x T and N. Unit colours give the directions of T, B
    and N; (1, 0, 1) and (0, 1, 1) the directions of T + N and B + N, which fix the lengths of
    T and B relative to N. Out come T/|N|, B/|N| and N/|N| (all through M^-T).
    """
    def probe(b, m):
        node = b.node("ShaderNodeNormalMap", space="TANGENT", uv_map=uv_map)
        if hasattr(node, "convention"):       # 5.2: probe the frame itself, OpenGL
            node.convention = "OPENGL"
        node.inputs["Color"].default_value = (0.5 * m[0] + 0.5, 0.5 * m[1] + 0.5,
                                              0.5 * m[2] + 0.5, 1.0)
        return node.outputs[0]

    def relative(b, axis_dir, sum_dir, n):
        # v = normalize(A + N) with A = |A| a: A/|N| = lam v - n, lam from cross(a, .) = 0.
        c1 = b.cross(axis_dir, n)
        c2 = b.cross(axis_dir, sum_dir)
        lam = b.math("DIVIDE", b.dot(c1, c2), b.math("MAXIMUM", b.dot(c2, c2), DIVIDE_FLOOR))
        return b.sub(b.scale(sum_dir, lam), n)

    def build(b):
        with b.frame("MikkTSpace frame from the Normal Map node"):
            n = probe(b, (0, 0, 1))
            t_dir, b_dir = probe(b, (1, 0, 0)), probe(b, (0, 1, 0))
            tn, bn = probe(b, (1, 0, 1)), probe(b, (0, 1, 1))
        with b.frame("Listing 9: scale t, b by 1/|n|"):
            t = relative(b, t_dir, tn, n)
            bt = relative(b, b_dir, bn, n)
        b.output("Tangent", "VECTOR", t, "MikkTSpace tangent / |n| (world)")
        b.output("Bitangent", "VECTOR", bt, "MikkTSpace bitangent / |n| (world)")
        b.output("Normal", "VECTOR", n, "Unit interpolated vertex normal (world)")
    name = ".SG MikkTSpace Frame" + (f" [{uv_map}]" if uv_map else "")
    return ensure_group(name, common.VERSION, build, "Listing 9's MikkTSpace frame")


def normal_map_group(uv_map=""):
    """SG Normal Map for a UV map ("" = the active render UV map, the menu's group).

    One Normal Map node does Listings 3 and 9 (the MikkTSpace frame, exactly as Blender
    combines it) on the colour that Listing 2 makes of the map: the node's normal is the
    resolved normal of Listing 2's derivative. Listing 5 turns it back into a surface gradient
    against the shading normal, so it adds to other layers; resolved alone against the shading
    normal it is Blender's Normal Map node's result (to float rounding)."""
    def build(b):
        color = b.input("Color", "COLOR", "Tangent-space normal map colour (Non-Color image, "
                        "sampled on the same UV map)", default=(0.5, 0.5, 1.0, 1.0))
        directx = directx_input(b)
        strength = b.input("Strength", "FLOAT", "As the Normal Map node's Strength: 1 "
                           "reproduces the map, 0 is flat, above 1 steeper (so a converted "
                           "Normal Map node keeps its look)", default=1.0, min_value=0.0,
                           max_value=10.0)
        n = normal_input(b, "Base normal the result is resolved against (leave unlinked: "
                            "the shading normal)")
        with b.frame("Listing 2 as a colour: c - 0.5 with the DirectX flip on y, "
                     "z = max(|z|, max(|x|, |y|) / 128)"):
            dx, dy, dz = b.separate(b.vmath("SUBTRACT", color, (0.5, 0.5, 0.5)))
            flip = b.math("MULTIPLY_ADD", directx, -2.0, 1.0)
            z = b.math("MAXIMUM", b.math("ABSOLUTE", dz), b.math(
                "MULTIPLY", 1.0 / 128.0, b.math("MAXIMUM", b.math("ABSOLUTE", dx),
                                                 b.math("ABSOLUTE", dy))))
            processed = b.combine(dx, b.math("MULTIPLY", dy, flip), z)
        with b.frame("Listings 3 and 9: Blender's Normal Map node in the MikkTSpace frame, "
                     "with its own Strength"):
            node = b.node("ShaderNodeNormalMap", space="TANGENT", uv_map=uv_map)
            if hasattr(node, "convention"):      # 5.2: the colour is already OpenGL
                node.convention = "OPENGL"
            # The node applies Strength itself (x, y scaled, z blended toward 1).
            b.link(strength, node.inputs["Strength"])
            b.link(b.vmath("ADD", processed, (0.5, 0.5, 0.5)), node.inputs["Color"])
            v = node.outputs["Normal"]
        with b.frame("Listing 5 against the shading normal ns, + (n - ns): n - v / (ns . v); "
                     "n - v where v faces away from ns (strong non-uniform scale)"):
            ns = b.node("ShaderNodeNewGeometry").outputs["Normal"]
            sg = surfgrad_reaching(b, n, v, ns)
        b.output("Surface Gradient", "VECTOR", sg, "Surface gradient: add to others, then "
                 "SG Resolve")
    name = "SG Normal Map" + (f" [{uv_map}]" if uv_map else "")
    return ensure_group(name, common.VERSION, build,
                        "Tangent-space normal map to surface gradient, MikkTSpace compliant "
                        f"(Listings 2, 3, 9 through the Normal Map node, then 5) on UV map "
                        f"{uv_map or '(active render map)'}")


def blend_normals_group():
    def build(b):
        # No DirectX switch: every blend commutes with flipping green on both inputs, so two
        # DirectX maps blend into the DirectX map of the blend (set DirectX downstream).
        ca = b.input("Color A", "COLOR", "First (base) tangent-space normal colour, OpenGL or "
                     "DirectX like Color B (the result keeps the convention)",
                     default=(0.5, 0.5, 1.0, 1.0))
        cb = b.input("Color B", "COLOR", "Second (detail) tangent-space normal colour",
                     default=(0.5, 0.5, 1.0, 1.0))
        method = b.input("Method", "INT", "0: partial derivatives (PD), 1: whiteout, 2: UDN, "
                         "3: reoriented normal mapping (RNM)", default=0, min_value=0,
                         max_value=3)
        with b.frame("Decode: m = 2 c - 1"):
            a = b.vmath("SUBTRACT", b.vmath("MULTIPLY", ca, (2.0, 2.0, 2.0)), (1.0, 1.0, 1.0))
            bb = b.vmath("SUBTRACT", b.vmath("MULTIPLY", cb, (2.0, 2.0, 2.0)), (1.0, 1.0, 1.0))
            ax, ay, az = b.separate(a)
            bx, by, bz = b.separate(bb)
        with b.frame("PD: a.xy b.z + b.xy a.z, a.z b.z"):
            pd = b.combine(b.math("ADD", b.math("MULTIPLY", ax, bz), b.math("MULTIPLY", bx, az)),
                           b.math("ADD", b.math("MULTIPLY", ay, bz), b.math("MULTIPLY", by, az)),
                           b.math("MULTIPLY", az, bz))
        with b.frame("Whiteout: a.xy + b.xy, a.z b.z"):
            sx, sy = b.math("ADD", ax, bx), b.math("ADD", ay, by)
            wo = b.combine(sx, sy, b.math("MULTIPLY", az, bz))
        with b.frame("UDN: a.xy + b.xy, a.z"):
            udn = b.combine(sx, sy, az)
        with b.frame("RNM, Eq. 18"):
            ap = b.vmath("ADD", a, (0.0, 0.0, 1.0))
            bp = b.vmath("MULTIPLY", bb, (-1.0, -1.0, 1.0))
            k = b.math("DIVIDE", b.dot(ap, bp), b.math("ADD", az, 1.0))
            rnm = b.sub(b.scale(ap, k), bp)
        with b.frame("Select the method, encode as colour"):
            out = pd
            for index, candidate in ((1, wo), (2, udn), (3, rnm)):
                pick = b.math("COMPARE", method, float(index), 0.5)
                out = b.mix_vector(pick, out, candidate)
            color = b.vmath("ADD", b.vmath("MULTIPLY", b.normalize(out), (0.5, 0.5, 0.5)),
                            (0.5, 0.5, 0.5))
        b.output("Color", "COLOR", color, "Blended tangent-space normal colour: feed it to "
                 "SG Normal Map")
    return ensure_group("SG Blend Normals", common.VERSION, build,
                        "Classic blends of two tangent-space normals on one UV map (Table 1, "
                        "Eq. 18); through SG Normal Map each equals its surface-gradient form")
