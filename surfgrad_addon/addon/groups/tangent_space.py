"""Sections 3.3-3.4 and Table 1: tangent-space normal maps. Listings 2 and 3 on a
MikkTSpace frame (Listing 9, SG Normal Map) or on a generated one (Listing 4, SG Procedural
Basis, SG Tangent Normal), and the classic blends of two tangent-space normals (Eq. 18)."""

from ..enum_input import choose
from ..node_vocabulary import Math, VMath
from ...reference import socket_specs as S
from ...reference.vecmath import DIVIDE_FLOOR
from .common import (directx_input, ensure, listing2_colour, normal_input, sign_nonneg,
                     sub_group, surfgrad_reaching, tangent_normal_to_surfgrad, unpack_normal,
                     uv_gradients_group, uv_input)


def procedural_basis_group(uv_map=""):
    """SG Procedural Basis; with `uv_map`, the per-map group "SG Procedural Basis [<map>]" whose
    unlinked UV is that map. Left unlinked, the choice of map is a constant that Cycles folds
    away, where a UV Map node linked in keeps it (an is-zero test and a Mix) in each of the UV
    gradients' Bump evaluations (docs/performance.md, the folded table)."""
    def build(b):
        n = normal_input(b)
        uv = uv_input(b, uv_map)
        grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
        gs, gt = grads.outputs[0], grads.outputs[1]
        with b.frame("Listing 4 in surface gradients: t = normalize(sgn (grad t x n))"):
            # sign_det * flip_sign of Listing 4 is the orientation of the unwrap, the sign
            # of n . (grad s x grad t).
            orient = sign_nonneg(b, b.dot(n, b.cross(gs, gt)))
            t = b.normalize(b.scale(b.cross(gt, n), orient))
            bt = b.scale(b.cross(n, t), orient)
        b.output(S.TANGENT_OUT, t)
        b.output(S.BITANGENT_OUT, bt)
    name = "SG Procedural Basis" + (f" [{uv_map}]" if uv_map else "")
    fields = {"uv_map": uv_map} if uv_map else {}
    return ensure("SG Procedural Basis", build, name, **fields)


def tangent_normal_group():
    def build(b):
        color = b.input(S.NORMAL_COLOR)
        directx = directx_input(b)
        strength = b.input(S.STRENGTH)
        t, bt = b.input("Tangent"), b.input("Bitangent")
        sg = tangent_normal_to_surfgrad(b, color, strength, t, bt, directx)
        b.output(S.SURFACE_GRADIENT_OUT, sg)
    return ensure("SG Tangent Normal", build)


def mikktspace_frame_group(uv_map=""):
    """Listing 9's frame for one UV map, from Normal Map nodes fed constant colours.

    The Normal Map node returns normalize(M^-T (m.x T + m.y B + m.z N)) for the interpolated,
    unnormalised MikkTSpace T, B = sign N x T and N. Unit colours give the directions of T, B
    and N; (1, 0, 1) and (0, 1, 1) the directions of T + N and B + N, which fix the lengths of
    T and B relative to N. Out come T/|N|, B/|N| and N/|N| (all through M^-T).
    """
    def probe(b, m):
        # 5.2: probe the frame itself, OpenGL
        return b.normal_map((0.5 * m[0] + 0.5, 0.5 * m[1] + 0.5, 0.5 * m[2] + 0.5, 1.0),
                            "TANGENT", uv_map=uv_map)

    def relative(b, axis_dir, sum_dir, n):
        # v = normalize(A + N) with A = |A| a: A/|N| = lam v - n, lam from cross(a, .) = 0.
        c1 = b.cross(axis_dir, n)
        c2 = b.cross(axis_dir, sum_dir)
        lam = b.math(Math.DIVIDE, b.dot(c1, c2), b.math(Math.MAXIMUM, b.dot(c2, c2), DIVIDE_FLOOR))
        return b.sub(b.scale(sum_dir, lam), n)

    def build(b):
        with b.frame("MikkTSpace frame from the Normal Map node"):
            n = probe(b, (0, 0, 1))
            t_dir, b_dir = probe(b, (1, 0, 0)), probe(b, (0, 1, 0))
            tn, bn = probe(b, (1, 0, 1)), probe(b, (0, 1, 1))
        with b.frame("Listing 9: scale t, b by 1/|n|"):
            t = relative(b, t_dir, tn, n)
            bt = relative(b, b_dir, bn, n)
        b.output(S.TANGENT_OUT, t)
        b.output(S.BITANGENT_OUT, bt)
        b.output(S.NORMAL_OUT, n)
    name = ".SG MikkTSpace Frame" + (f" [{uv_map}]" if uv_map else "")
    return ensure(".SG MikkTSpace Frame", build, name)


def normal_map_group(uv_map=""):
    """SG Normal Map for a UV map ("" = the active render UV map, the menu's group).

    One Normal Map node does Listings 3 and 9 (the MikkTSpace frame, exactly as Blender
    combines it) on the colour that Listing 2 makes of the map: the node's normal is the
    resolved normal of Listing 2's derivative. Listing 5 turns it back into a surface gradient
    against the shading normal, so it adds to other layers; resolved alone against the shading
    normal it is Blender's Normal Map node's result (to float rounding)."""
    def build(b):
        color = b.input(S.NORMAL_COLOR)
        directx = directx_input(b)
        strength = b.input(S.NODE_STRENGTH)
        n = normal_input(b)
        with b.frame("Listing 2 as a colour: the DirectX flip on green, "
                     "z = max(|z|, max(|x|, |y|) / 128)"):
            processed = listing2_colour(b, color, directx)
        with b.frame("Listings 3 and 9: Blender's Normal Map node in the MikkTSpace frame, "
                     "with its own Strength"):
            # The node applies Strength itself (x, y scaled, z blended toward 1); on 5.2 the
            # colour is already OpenGL.
            v = b.normal_map(processed, "TANGENT", strength, uv_map)
        with b.frame("Listing 5 against the shading normal ns, + (n - ns): n - v / (ns . v); "
                     "n - v where v faces away from ns (strong non-uniform scale)"):
            sg = surfgrad_reaching(b, n, v, b.geometry("Normal"))
        b.output(S.SUMMABLE_GRADIENT_OUT, sg)
    name = "SG Normal Map" + (f" [{uv_map}]" if uv_map else "")
    fields = {"uv_map": uv_map} if uv_map else {}
    return ensure("SG Normal Map", build, name, **fields)


def select_blend(b, method, candidates):
    """candidates[method] (PD, whiteout, UDN, RNM): a Menu Switch, or on older lines a chain of
    Mix nodes on the integer (enum_input). A constant Method folds it to that one blend, the
    others' nodes gone (tests/test_render_cost_folding.py)."""
    return choose(b, method, candidates)


def blend_normals_group():
    def build(b):
        # No DirectX switch: every blend commutes with flipping green on both inputs, so two
        # DirectX maps blend into the DirectX map of the blend (set DirectX downstream).
        ca, cb, method = b.input("Color A"), b.input("Color B"), b.input("Method")
        with b.frame("Decode: m = 2 c - 1"):
            a, bb = unpack_normal(b, ca), unpack_normal(b, cb)
            ax, ay, az = b.separate(a)
            bx, by, bz = b.separate(bb)
        with b.frame("PD: a.xy b.z + b.xy a.z, a.z b.z"):
            def cross_term(p, q):          # p b.z + q a.z
                return b.math(Math.ADD, b.math(Math.MULTIPLY, p, bz), b.math(Math.MULTIPLY, q, az))
            pd = b.combine(cross_term(ax, bx), cross_term(ay, by), b.math(Math.MULTIPLY, az, bz))
        with b.frame("Whiteout: a.xy + b.xy, a.z b.z"):
            sx, sy = b.math(Math.ADD, ax, bx), b.math(Math.ADD, ay, by)
            wo = b.combine(sx, sy, b.math(Math.MULTIPLY, az, bz))
        with b.frame("UDN: a.xy + b.xy, a.z"):
            udn = b.combine(sx, sy, az)
        with b.frame("RNM, Eq. 18"):
            ap = b.vmath(VMath.ADD, a, (0.0, 0.0, 1.0))
            bp = b.vmath(VMath.MULTIPLY, bb, (-1.0, -1.0, 1.0))
            k = b.math(Math.DIVIDE, b.dot(ap, bp), b.math(Math.ADD, az, 1.0))
            rnm = b.sub(b.scale(ap, k), bp)
        with b.frame("Select the method, encode as colour"):
            out = select_blend(b, method, (pd, wo, udn, rnm))
            color = b.vmath(VMath.ADD, b.vmath(VMath.MULTIPLY, b.normalize(out), (0.5, 0.5, 0.5)),
                            (0.5, 0.5, 0.5))
        b.output("Color", color)
    return ensure("SG Blend Normals", build)
