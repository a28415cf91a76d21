"""The surface-gradient framework as shader node groups, one builder per group.

Shader nodes have no ddx/ddy. What they have instead (pinned in tests/test_blender_facts.py):
the Bump node. Fed a scalar h with Strength 1, Distance 1 and base normal N it returns
n = normalize(N - grad_S h) (its forward differences are exact for h linear on a triangle, such
as a UV coordinate), so g = N - n / dot(n, N) recovers the surface gradient grad_S h
(".SG Surface Gradient"). The surface gradients of a UV map's s and t carry everything
Listings 4 and 6 need from dP/dx, dP/dy and d(st)/dx, d(st)/dy; the formulas below are those
listings rewritten in them (the screen basis cancels).
"""

import bpy

from .node_builder import ensure_group, running_line

VERSION = 13
MENU_GROUPS = []          # (menu name, builder) in menu order, filled by @menu_group


class FeatureUnavailable(ValueError):
    """A group needs a node this Blender does not have; the message names the node and the
    Blender version that has it (docs/versions.md)."""


# Groups that need a node newer than blender_version_min: name -> (node type, the first LTS
# line checked to have it, what the group does with it). Tested by the node's presence, not by
# the version number.
REQUIRES = {"SG Displace": ("GeometryNodeSetMeshNormal", "4.5", "it sets the analytic normals "
                            "with the Geometry Nodes Set Mesh Normal node")}
# Hidden helpers that only a gated group builds (absent where the gate refuses it).
GATED_HELPERS = {"SG Displace": (".SG Gradient Noise (Geometry)",)}


def unavailable_reason(name):
    """None when group `name` can be built in the running Blender, else why not."""
    need = REQUIRES.get(name)
    if need is None or hasattr(bpy.types, need[0]):
        return None
    node_type, line, use = need
    return (f"{name} needs Blender {line} or newer: {use} ({node_type}), which Blender "
            f"{bpy.app.version_string} does not have")


def menu_group(name):
    def register(fn):
        MENU_GROUPS.append((name, fn))
        return fn
    return register


# Sockets shared by many groups -------------------------------------------------------------

def normal_input(b, description="Base normal to perturb (world space). Leave unlinked for "
                                "the shading normal; link a resolved normal for post-resolve "
                                "bump mapping"):
    """The group's Normal input, normalised; unlinked (zero), NaN or Inf it is the shading
    normal (through .SG Safe Normal)."""
    raw = b.input("Normal", "VECTOR", description, hide_value=True)
    node = b.node("ShaderNodeGroup", label="Base normal", node_tree=safe_normal_group())
    b.link(raw, node.inputs[0])
    return node.outputs[0]


def sub_group(b, tree, label, **inputs):
    kind = "GeometryNodeGroup" if b.tree.bl_idname == "GeometryNodeTree" else "ShaderNodeGroup"
    node = b.node(kind, label=label, node_tree=tree)
    for name, value in inputs.items():
        b.link(value, node.inputs[name.replace("_", " ")])
    return node


def sign_nonneg(b, x):
    """The listings' `x < 0 ? -1 : 1`."""
    return b.math("SUBTRACT", 1.0, b.math("MULTIPLY", 2.0, b.math("LESS_THAN", x, 0.0)))


# Internal helpers (names start with "." so the Group menu hides them) -----------------------

def zero_unless_finite(b, v):
    """v where every component is finite, else (0, 0, 0): Maximum/Minimum drop a NaN
    (fmaxf) and clamp an Inf, and x - x < 0.5 is false exactly for NaN and Inf."""
    comps = b.separate(v)
    finite = [b.math("LESS_THAN", b.math("SUBTRACT", c, c), 0.5) for c in comps]
    clamped = [b.math("MINIMUM", b.math("MAXIMUM", c, -1e30), 1e30) for c in comps]
    every = b.math("MULTIPLY", b.math("MULTIPLY", finite[0], finite[1]), finite[2])
    return b.scale(b.combine(*clamped), every)


def safe_normal_group():
    def build(b):
        v = b.input("Vector", "VECTOR", "A direction of any length, or nothing", hide_value=True)
        if not running_line().normal_map_replaces_non_finite:
            with b.frame("Blender 4.2/4.5: NaN or Inf to zero (their Normal Map node lets "
                         "non-finite values through)"):
                v = zero_unless_finite(b, v)
        with b.frame("normalize(v), or the shading normal where v is zero, NaN or Inf"):
            # A World-space Normal Map node normalises (c - 0.5) * 2. Cycles' replaces a zero
            # or non-finite result by the shading normal (arithmetic cannot remove a NaN,
            # this node can) and negates its result on back faces; EEVEE's does neither. So:
            # zero becomes the shading normal before the node (for EEVEE), and the input is
            # multiplied by the node's own sign on this face, measured on the shading normal.
            geo = b.node("ShaderNodeNewGeometry").outputs["Normal"]
            probe = b.node("ShaderNodeNormalMap", space="WORLD", label="sign probe")
            b.link(b.vmath("ADD", b.vmath("MULTIPLY", geo, (0.5, 0.5, 0.5)), (0.5, 0.5, 0.5)),
                   probe.inputs["Color"])
            sign = b.dot(probe.outputs[0], geo)
            zero = b.math("COMPARE", b.length(v), 0.0, 0.0)
            v = b.add(v, b.scale(geo, zero))
            color = b.vmath("ADD", b.vmath("MULTIPLY", b.scale(v, sign), (0.5, 0.5, 0.5)),
                            (0.5, 0.5, 0.5))
            nm = b.node("ShaderNodeNormalMap", space="WORLD")
            nm.inputs["Strength"].default_value = 1.0
            b.link(color, nm.inputs["Color"])
        b.output("Normal", "VECTOR", nm.outputs[0], "Unit normal, always finite")
    return ensure_group(".SG Safe Normal", VERSION, build,
                        "normalize(v) with the shading normal as fallback")


def surface_gradient_group():
    def build(b):
        value = b.input("Value", "FLOAT", "Scalar whose surface gradient is wanted (linear on "
                        "each triangle for an exact result, e.g. a UV coordinate)")
        n = b.input("Normal", "VECTOR", "Unit base normal", hide_value=True)
        with b.frame("Bump node inverted: g = N - n / (n . N)"):
            bump = b.node("ShaderNodeBump")
            bump.inputs["Strength"].default_value = 1.0
            bump.inputs["Distance"].default_value = 1.0
            if "Filter Width" in bump.inputs:
                bump.inputs["Filter Width"].default_value = BUMP_FILTER_WIDTH
            b.link(value, bump.inputs["Height"])
            b.link(n, bump.inputs["Normal"])
            nb = bump.outputs[0]
            g = b.sub(n, b.scale(nb, b.math("DIVIDE", 1.0, b.dot(nb, n))))
        b.output("Gradient", "VECTOR", g, "Surface gradient of Value")
    return ensure_group(".SG Surface Gradient", VERSION, build,
                        "Surface gradient of a scalar through the Bump node")


# Shifted copies see UV + fw * dUV: for linear attributes any step is exact, and a large one
# keeps float32 cancellation in the forward differences small.
BUMP_FILTER_WIDTH = 10.0
FORWARD_FILTER_WIDTH = 2.0      # = reference.methods.FORWARD_FILTER_WIDTH


def uv_gradients_group():
    def build(b):
        uv = b.input("UV", "VECTOR", "Texture coordinate (link a UV Map node for any UV map)",
                     hide_value=True)
        n = b.input("Normal", "VECTOR", "Unit base normal", hide_value=True)
        s, t, _ = b.separate(uv)
        sg = surface_gradient_group()
        with b.frame("Surface gradients of s and t (Eq. 7 with H = s, H = t)"):
            gs = sub_group(b, sg, "grad s", Value=s, Normal=n).outputs[0]
            gt = sub_group(b, sg, "grad t", Value=t, Normal=n).outputs[0]
        b.output("Gradient S", "VECTOR", gs, "Surface gradient of s")
        b.output("Gradient T", "VECTOR", gt, "Surface gradient of t")
    return ensure_group(".SG UV Gradients", VERSION, build, "Surface gradients of a UV map")


# Menu groups ----------------------------------------------------------------------------------

@menu_group("SG Resolve")
def resolve_group():
    def build(b):
        n = normal_input(b)
        sg = b.input("Surface Gradient", "VECTOR", "Sum of the surface gradients to apply",
                     hide_value=True)
        with b.frame("Listing 1: normalize(n - surfGrad)"):
            # Where n - surfGrad has no direction (zero, NaN, Inf) the shading normal is used:
            # the result is always a finite unit vector.
            safe = b.node("ShaderNodeGroup", label="normalize", node_tree=safe_normal_group())
            b.link(b.sub(n, sg), safe.inputs[0])
            out = safe.outputs[0]
        b.output("Normal", "VECTOR", out, "Perturbed unit normal (world space): link it to a "
                 "BSDF's Normal")
    return ensure_group("SG Resolve", VERSION, build,
                        "Listing 1: the perturbed normal from the base normal and the summed "
                        "surface gradient")


@menu_group("SG Volume Gradient")
def volume_gradient_group():
    def build(b):
        n = normal_input(b)
        grad = b.input("Gradient", "VECTOR", "Gradient of a volume bump function (world space), "
                       "e.g. SG Noise's Gradient", hide_value=True)
        strength = b.input("Strength", "FLOAT", "Bump scale (world units per unit of the "
                           "function)", default=1.0, min_value=-1000.0, max_value=1000.0)
        with b.frame("Listing 8: grad - (n . grad) n"):
            sg = b.sub(grad, b.scale(n, b.dot(n, grad)))
        b.output("Surface Gradient", "VECTOR", b.scale(sg, strength),
                 "Surface gradient: add to others, then SG Resolve")
    return ensure_group("SG Volume Gradient", VERSION, build,
                        "Listing 8: surface gradient of a volume bump map")


@menu_group("SG Object Normal")
def object_normal_group():
    def build(b):
        n = normal_input(b)
        v = b.input("Perturbed Normal", "VECTOR", "The normal to reach, world space, any "
                    "positive length (for an object-space map, convert it with a Vector "
                    "Transform node, type Normal)", hide_value=True)
        strength = b.input("Strength", "FLOAT", "Scale of the resulting bump", default=1.0,
                           min_value=-100.0, max_value=100.0)
        with b.frame("Listing 5: (k n - v) / max(eps, |k|), k = n . v"):
            k = b.dot(n, v)
            denom = b.math("MAXIMUM", b.math("ABSOLUTE", k), 1.192092896e-07)
            sg = b.scale(b.sub(b.scale(n, k), v), b.math("DIVIDE", 1.0, denom))
        b.output("Surface Gradient", "VECTOR", b.scale(sg, strength), "Surface gradient")
    return ensure_group("SG Object Normal", VERSION, build,
                        "Listing 5: surface gradient from an object- or world-space normal")


DIRECTX_TOOLTIP = ("The map is in DirectX convention (green points down, -Y: Unreal, 3ds Max, "
                   "Substance's DirectX preset): its green channel is flipped. Off: OpenGL "
                   "(+Y), Blender's own. Blender 5.2's Normal Map node calls this Convention")


def directx_input(b):
    """The DirectX/OpenGL switch of every group that decodes a tangent-space colour."""
    return b.input("DirectX", "BOOLEAN", DIRECTX_TOOLTIP, default=False)


def decode_tangent_normal(b, color, directx=None):
    """m = 2 c - 1 (m.y negated for a DirectX map) and Listing 2's derivative (abs z, 1/128
    clamp), as two float sockets."""
    m = b.vmath("SUBTRACT", b.vmath("MULTIPLY", color, (2.0, 2.0, 2.0)), (1.0, 1.0, 1.0))
    mx, my, mz = b.separate(m)
    if directx is not None:
        my = b.math("MULTIPLY", my, b.math("SUBTRACT", 1.0, b.math("MULTIPLY", directx, 2.0)))
    z_ma = b.math("MAXIMUM", b.math("ABSOLUTE", mz), b.math(
        "MULTIPLY", 1.0 / 128.0, b.math("MAXIMUM", b.math("ABSOLUTE", mx), b.math("ABSOLUTE", my))))
    inv = b.math("DIVIDE", -1.0, b.math("MAXIMUM", z_ma, 1e-30))
    return b.math("MULTIPLY", mx, inv), b.math("MULTIPLY", my, inv)


def tangent_normal_to_surfgrad(b, color, strength, t, bt, directx=None):
    """Listing 2 (abs z, 1/128 clamp) then Listing 3, scaled by strength."""
    with b.frame("Listing 2: derivative from a tangent-space normal"):
        dx, dy = decode_tangent_normal(b, color, directx)
    with b.frame("Listing 3: deriv.x t + deriv.y b"):
        return b.scale(b.add(b.scale(t, dx), b.scale(bt, dy)), strength)


@menu_group("SG Procedural Basis")
def procedural_basis_group():
    def build(b):
        n = normal_input(b)
        uv = b.input("UV", "VECTOR", "Texture coordinate of a UV map without stored tangents "
                     "(link a UV Map node)", hide_value=True)
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
    return ensure_group("SG Procedural Basis", VERSION, build,
                        "Listing 4: a tangent frame for any UV map, generated per pixel")


@menu_group("SG Tangent Normal")
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
    return ensure_group("SG Tangent Normal", VERSION, build,
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
        lam = b.math("DIVIDE", b.dot(c1, c2), b.math("MAXIMUM", b.dot(c2, c2), 1e-30))
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
    return ensure_group(name, VERSION, build, "Listing 9's MikkTSpace frame")


def normal_map_group(uv_map=""):
    """SG Normal Map for a UV map ("" = the active render UV map, the menu's group)."""
    def build(b):
        color = b.input("Color", "COLOR", "Tangent-space normal map colour (Non-Color image, "
                        "sampled on the same UV map)", default=(0.5, 0.5, 1.0, 1.0))
        directx = directx_input(b)
        strength = b.input("Strength", "FLOAT", "Bump scale (1 reproduces the map)",
                           default=1.0, min_value=-10.0, max_value=10.0)
        n = normal_input(b, "Base normal the result is resolved against (leave unlinked: "
                            "the shading normal)")
        frame = sub_group(b, mikktspace_frame_group(uv_map), "MikkTSpace frame")
        sg = tangent_normal_to_surfgrad(b, color, strength, frame.outputs[0], frame.outputs[1],
                                        directx)
        with b.frame("+ (n - n_frame): resolve against n lands on the frame's normal"):
            sg = b.add(sg, b.sub(n, frame.outputs[2]))
        b.output("Surface Gradient", "VECTOR", sg, "Surface gradient: add to others, then "
                 "SG Resolve")
    name = "SG Normal Map" + (f" [{uv_map}]" if uv_map else "")
    return ensure_group(name, VERSION, build,
                        "Tangent-space normal map to surface gradient, MikkTSpace compliant "
                        f"(Listings 2, 3, 9) on UV map {uv_map or '(active render map)'}")


menu_group("SG Normal Map")(normal_map_group)


@menu_group("SG Blend Normals")
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
    return ensure_group("SG Blend Normals", VERSION, build,
                        "Classic blends of two tangent-space normals on one UV map (Table 1, "
                        "Eq. 18); through SG Normal Map each equals its surface-gradient form")


def gradient_noise_group(tree_type="ShaderNodeTree"):
    """One octave of the reference's gradient noise (reference/noise.py), value and exact
    gradient: lattice gradients 2 WhiteNoise(corner) - 1, quintic fade, trilinear weights.
    Accumulated corner by corner (value += w v, grad += w g + v grad w) so that few values
    are live at once: Cycles' SVM stack is small. The same nodes exist in Geometry Nodes,
    which gets its own copy (tree_type "GeometryNodeTree")."""
    corners = [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)]

    def build(b):
        p = b.input("Vector", "VECTOR", "Position to evaluate", hide_value=True)
        with b.frame("Cell and fade: f = p - floor(p), u = 6f^5 - 15f^4 + 10f^3"):
            cell = b.vmath("FLOOR", p)
            f = b.sub(p, cell)
            f2 = b.vmath("MULTIPLY", f, f)
            # u = f^3 (f (6 f - 15) + 10), du = 30 f^2 (f (f - 2) + 1)
            inner = b.vmath("ADD", b.vmath("MULTIPLY", f, b.vmath("SUBTRACT", b.vmath(
                "MULTIPLY", f, (6.0, 6.0, 6.0)), (15.0, 15.0, 15.0))), (10.0, 10.0, 10.0))
            u = b.vmath("MULTIPLY", b.vmath("MULTIPLY", f2, f), inner)
            dinner = b.vmath("ADD", b.vmath("MULTIPLY", f, b.vmath("SUBTRACT", f,
                                                                   (2.0, 2.0, 2.0))),
                             (1.0, 1.0, 1.0))
            du = b.vmath("MULTIPLY", b.vmath("MULTIPLY", f2, (30.0, 30.0, 30.0)), dinner)
            # Per axis, the weight is u where the corner is 1 and 1 - u where it is 0.
            w1 = b.separate(u)
            w0 = b.separate(b.vmath("SUBTRACT", (1.0, 1.0, 1.0), u))
            d1 = b.separate(du)
            d0 = b.separate(b.vmath("MULTIPLY", du, (-1.0, -1.0, -1.0)))
        value, grad = 0.0, (0.0, 0.0, 0.0)
        with b.frame("Corners: g = 2 WhiteNoise(cell + c) - 1, v = g . (f - c); "
                     "value += w v, grad += w g + v grad w"):
            for c in corners:
                cf = tuple(float(x) for x in c)
                noise = b.node("ShaderNodeTexWhiteNoise", noise_dimensions="3D")
                b.link(b.vmath("ADD", cell, cf), noise.inputs["Vector"])
                g = b.vmath("SUBTRACT", b.vmath("MULTIPLY", noise.outputs["Color"],
                                                (2.0, 2.0, 2.0)), (1.0, 1.0, 1.0))
                v = b.dot(g, b.vmath("SUBTRACT", f, cf))
                wx, wy, wz = [(w0, w1)[c[a]][a] for a in range(3)]
                dx, dy, dz = [(d0, d1)[c[a]][a] for a in range(3)]
                wyz = b.math("MULTIPLY", wy, wz)
                w = b.math("MULTIPLY", wx, wyz)
                dw = b.combine(b.math("MULTIPLY", dx, wyz),
                               b.math("MULTIPLY", wx, b.math("MULTIPLY", dy, wz)),
                               b.math("MULTIPLY", b.math("MULTIPLY", wx, wy), dz))
                value = b.math("ADD", value, b.math("MULTIPLY", w, v))
                grad = b.add(grad, b.add(b.scale(g, w), b.scale(dw, v)))
        b.output("Value", "FLOAT", value, "Noise value")
        b.output("Gradient", "VECTOR", grad, "Exact gradient with respect to Vector")
    geometry = tree_type == "GeometryNodeTree"
    return ensure_group(".SG Gradient Noise" + (" (Geometry)" if geometry else ""), VERSION,
                        build, "One octave of gradient noise with its analytic gradient",
                        tree_type=tree_type)


NOISE_OCTAVES = 4


@menu_group("SG Noise")
def noise_group():
    def build(b):
        vec = b.input("Vector", "VECTOR", "Where to evaluate (unlinked: object coordinates)",
                      hide_value=True)
        scale = b.input("Scale", "FLOAT", "Frequency of the first octave", default=4.0,
                        min_value=0.0, max_value=1e4)
        octaves = b.input("Octaves", "INT", f"Octaves of the fractal sum (1 to {NOISE_OCTAVES})",
                          default=4, min_value=1, max_value=NOISE_OCTAVES)
        gain = b.input("Gain", "FLOAT", "Amplitude ratio between octaves (frequency doubles)",
                       default=0.5, min_value=0.0, max_value=1.0)
        turb = b.input("Turbulence", "BOOLEAN", "Sum |noise| (Perlin's turbulence) instead of "
                       "noise (fractal sum)", default=False)
        obj_space = b.input("Object Space", "BOOLEAN", "Vector is in object space: return the "
                            "gradient in world space (for SG Volume Gradient)", default=True)
        with b.frame("Unlinked Vector: object coordinates"):
            coords = b.node("ShaderNodeTexCoord").outputs["Object"]
            unlinked = b.math("COMPARE", b.length(vec), 0.0, 0.0)
            p = b.scale(b.mix_vector(unlinked, vec, coords), scale)
        value, grad = 0.0, (0.0, 0.0, 0.0)
        octave_tree = gradient_noise_group()
        with b.frame("Fractal sum / turbulence: sum gain^i noise(2^i p), chain rule"):
            prev = None
            for i in range(NOISE_OCTAVES):
                freq = 2.0 ** i
                q = b.scale(p, freq) if i else p
                if prev is not None:
                    # q + (v - v): exactly q, but it makes this octave wait for the previous
                    # one, so Cycles' SVM compiler never holds two octaves' temporaries (its
                    # stack overflows otherwise).
                    q = b.vmath("ADD", q, b.math("SUBTRACT", prev, prev))
                node = sub_group(b, octave_tree, f"octave {i + 1}", Vector=q)
                v, g = node.outputs[0], node.outputs[1]
                prev = v
                sgn = sign_nonneg(b, v)
                v = b.math("ADD", v, b.math("MULTIPLY", turb, b.math("SUBTRACT", b.math(
                    "ABSOLUTE", v), v)))
                g = b.mix_vector(turb, g, b.scale(g, sgn))
                on = b.math("LESS_THAN", float(i), octaves)
                amp = b.math("MULTIPLY", on, b.math("POWER", gain, float(i)))
                value = b.math("ADD", value, b.math("MULTIPLY", amp, v))
                grad = b.add(grad, b.scale(g, b.math("MULTIPLY", amp, freq)))
            grad = b.scale(grad, scale)
        with b.frame("Object to world: (M^-T g)_i = (M^-1 e_i) . g"):
            comps = []
            for axis in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
                vt = b.node("ShaderNodeVectorTransform", vector_type="VECTOR",
                            convert_from="WORLD", convert_to="OBJECT")
                vt.inputs[0].default_value = axis
                comps.append(b.dot(vt.outputs[0], grad))
            world = b.combine(*comps)
            grad = b.mix_vector(obj_space, grad, world)
        b.output("Value", "FLOAT", value, "Noise value (for displacement or masks)")
        b.output("Gradient", "VECTOR", grad, "Exact gradient of Value (world space when Object "
                 "Space is on): feed SG Volume Gradient")
    return ensure_group("SG Noise", VERSION, build,
                        "The reference's 3-D gradient noise (fractal sum or turbulence) with its "
                        "exact gradient, bit-compatible lattice (White Noise hash)")


def position_input(b, description):
    """A Position input; unlinked (zero) it is the world position of the shading point."""
    raw = b.input("Position", "VECTOR", description, hide_value=True)
    world = b.node("ShaderNodeNewGeometry").outputs["Position"]
    unlinked = b.math("COMPARE", b.length(raw), 0.0, 0.0)
    return b.mix_vector(unlinked, raw, world)


def triplanar_weights(b, n, k):
    """Listing 14: w = max(|n| - 0.2, 0)^k, normalised; returns the three weight sockets."""
    with b.frame("Listing 14: w = max(|n| - 0.2, 0)^k, normalised"):
        base = b.separate(b.vmath("MAXIMUM", b.vmath("SUBTRACT", b.vmath("ABSOLUTE", n),
                                                      (0.2, 0.2, 0.2)), (0.0, 0.0, 0.0)))
        wx, wy, wz = (b.math("POWER", c, k) for c in base)
        total = b.math("MAXIMUM", b.math("ADD", b.math("ADD", wx, wy), wz), 1e-30)
        return tuple(b.math("DIVIDE", c, total) for c in (wx, wy, wz))


def triplanar_surface_gradient(b, n, weights, derivs):
    """Listing 13: the volume gradient of Eq. 19 from the planes' derivatives (sampled at
    (z, y), (x, z), (x, y)), projected by Listing 8."""
    w0, w1, w2 = weights
    (dxx, dxy), (dyx, dyy), (dzx, dzy) = derivs
    with b.frame("Listing 13: volume gradient of Eq. 19, then Listing 8"):
        grad = b.combine(
            b.math("ADD", b.math("MULTIPLY", w2, dzx), b.math("MULTIPLY", w1, dyx)),
            b.math("ADD", b.math("MULTIPLY", w2, dzy), b.math("MULTIPLY", w0, dxy)),
            b.math("ADD", b.math("MULTIPLY", w0, dxx), b.math("MULTIPLY", w1, dyy)))
        return b.sub(grad, b.scale(n, b.dot(n, grad)))


def images_stale(expected):
    """A `stale` test for image-bound groups: rebuild when their Image Texture nodes no longer
    hold `expected` (in node order), e.g. an image was replaced or removed."""
    def stale(tree):
        taps = [nd.image for nd in tree.nodes if nd.bl_idname == "ShaderNodeTexImage"]
        return taps != list(expected(len(taps)))
    return stale


@menu_group("SG Triplanar Coordinates")
def triplanar_coordinates_group():
    def build(b):
        p = position_input(b, "Where to project from (unlinked: world position)")
        scale = b.input("Scale", "FLOAT", "Texture repeats per unit", default=1.0,
                        min_value=0.0, max_value=1e4)
        with b.frame("Eq. 19 planes: X samples (z, y), Y (x, z), Z (x, y)"):
            x, y, z = b.separate(b.scale(p, scale))
            uvx, uvy, uvz = b.combine(z, y), b.combine(x, z), b.combine(x, y)
        b.output("UV X", "VECTOR", uvx, "Coordinates for the image projected along X")
        b.output("UV Y", "VECTOR", uvy, "Coordinates for the image projected along Y")
        b.output("UV Z", "VECTOR", uvz, "Coordinates for the image projected along Z")
    return ensure_group("SG Triplanar Coordinates", VERSION, build,
                        "The three planar projections of triplanar mapping (Eq. 19): feed "
                        "three Image Texture nodes, then SG Triplanar")


@menu_group("SG Triplanar")
def triplanar_group():
    def build(b):
        n = normal_input(b)
        cx = b.input("Color X", "COLOR", "Tangent-space normal map sampled at UV X",
                     default=(0.5, 0.5, 1.0, 1.0))
        cy = b.input("Color Y", "COLOR", "Tangent-space normal map sampled at UV Y",
                     default=(0.5, 0.5, 1.0, 1.0))
        cz = b.input("Color Z", "COLOR", "Tangent-space normal map sampled at UV Z",
                     default=(0.5, 0.5, 1.0, 1.0))
        directx = directx_input(b)
        k = b.input("Sharpness", "FLOAT", "Blend sharpness k of Listing 14", default=3.0,
                    min_value=1.0, max_value=64.0)
        strength = b.input("Strength", "FLOAT", "Bump scale", default=1.0, min_value=-10.0,
                           max_value=10.0)
        weights = triplanar_weights(b, n, k)
        with b.frame("Listing 2 per plane"):
            derivs = [decode_tangent_normal(b, c, directx) for c in (cx, cy, cz)]
        sg = triplanar_surface_gradient(b, n, weights, derivs)
        w = b.combine(*weights)
        b.output("Surface Gradient", "VECTOR", b.scale(sg, strength), "Surface gradient")
        b.output("Weights", "VECTOR", w, "The blend weights (x, y, z)")
    return ensure_group("SG Triplanar", VERSION, build,
                        "Listings 13 and 14: triplanar normal mapping as a volume bump map")


@menu_group("SG Decal Coordinates")
def decal_coordinates_group():
    def build(b):
        q = b.input("Decal Coordinates", "VECTOR", "Position in the projector's space (a "
                    "Texture Coordinate node's Object output, the projector as its object)",
                    hide_value=True)
        with b.frame("[-1, 1]^2 of the projector to [0, 1]^2"):
            uv = b.vmath("ADD", b.vmath("MULTIPLY", q, (0.5, 0.5, 0.0)), (0.5, 0.5, 0.0))
        b.output("Decal UV", "VECTOR", uv, "Where to sample the decal image (its Image "
                 "Texture's Vector)")
    return ensure_group("SG Decal Coordinates", VERSION, build,
                        "Image coordinates of a decal projector: feed the decal's Image "
                        "Texture, then SG Decal")


@menu_group("SG Decal")
def decal_group():
    def build(b):
        n = normal_input(b)
        q = b.input("Decal Coordinates", "VECTOR", "Position in the projector's space: a "
                    "Texture Coordinate node's Object output with the projector (an empty) "
                    "as its object; the decal covers [-1, 1] in x and y", hide_value=True)
        color = b.input("Color", "COLOR", "Tangent-space normal map sampled at the Decal UV "
                        "of SG Decal Coordinates", default=(0.5, 0.5, 1.0, 1.0))
        directx = directx_input(b)
        axis_x = b.input("Axis X", "VECTOR", "The projector's X axis in world space (unit "
                         "length; the Add Decal Projector operator drives it)",
                         default=(1.0, 0.0, 0.0), subtype="DIRECTION")
        axis_y = b.input("Axis Y", "VECTOR", "The projector's Y axis in world space (unit "
                         "length)", default=(0.0, 1.0, 0.0), subtype="DIRECTION")
        strength = b.input("Strength", "FLOAT", "Bump scale", default=1.0, min_value=-10.0,
                           max_value=10.0)
        falloff = b.input("Falloff", "FLOAT", "Depth over which the decal fades out toward the "
                          "projector box's near and far faces (fraction of its depth)",
                          default=0.2, min_value=0.0, max_value=1.0)
        qx, qy, qz = b.separate(q)
        with b.frame("Falloff as a bump scale: box mask times depth fade"):
            inside = b.math("MULTIPLY", b.math("LESS_THAN", b.math("ABSOLUTE", qx), 1.000001),
                            b.math("LESS_THAN", b.math("ABSOLUTE", qy), 1.000001))
            fade = b.math("DIVIDE", b.math("SUBTRACT", 1.0, b.math("ABSOLUTE", qz)),
                          b.math("MAXIMUM", falloff, 1e-6))
            fade = b.math("MINIMUM", b.math("MAXIMUM", fade, 0.0), 1.0)
            scale = b.math("MULTIPLY", b.math("MULTIPLY", inside, fade), strength)
        with b.frame("Listing 2"):
            dx, dy = decode_tangent_normal(b, color, directx)
        with b.frame("Listing 15: grad = deriv.x X + deriv.y Y, then Listing 8"):
            grad = b.add(b.scale(axis_x, dx), b.scale(axis_y, dy))
            sg = b.sub(grad, b.scale(n, b.dot(n, grad)))
        b.output("Surface Gradient", "VECTOR", b.scale(sg, scale), "Surface gradient")
    return ensure_group("SG Decal", VERSION, build,
                        "Listing 15: a decal projector as a volume bump map, faded by its "
                        "falloff")


@menu_group("SG Combine")
def combine_group():
    def build(b):
        a = b.input("A", "VECTOR", "First surface gradient", hide_value=True)
        c = b.input("B", "VECTOR", "Second surface gradient", hide_value=True)
        scale_a = b.input("Scale A", "FLOAT", "Weight of A (negative inverts that bump)",
                          default=1.0, min_value=-100.0, max_value=100.0)
        scale_b = b.input("Scale B", "FLOAT", "Weight of B (negative inverts that bump)",
                          default=1.0, min_value=-100.0, max_value=100.0)
        mask = b.input("Mask B", "FLOAT", "Mask for B (0 hides it, 1 keeps it)", default=1.0,
                       min_value=0.0, max_value=1.0, subtype="FACTOR")
        with b.frame("Eq. 14: surface gradients add linearly"):
            out = b.add(b.scale(a, scale_a), b.scale(c, b.math("MULTIPLY", scale_b, mask)))
        b.output("Surface Gradient", "VECTOR", out, "Scale A x A + Scale B x Mask B x B")
    return ensure_group("SG Combine", VERSION, build,
                        "Layering (Eq. 13-14): add, scale, mask or invert surface gradients")


def _height_image_node(b, image, vector, interpolation, extension):
    node = b.node("ShaderNodeTexImage", interpolation=interpolation, extension=extension)
    node.image = image
    b.link(vector, node.inputs["Vector"])
    return b.separate(node.outputs["Color"])[0]


def height_map_group(image=None, variant="hq", extension="REPEAT"):
    """SG Height Map for one height image: Listing 16 at level 0 ('one-texel': three Linear
    taps one texel apart; 'hq': the 4x4 Closest block of Eq. 20/21), through Listing 6 in
    surface gradients: grad_S H = W dH/du grad s + H dH/dv grad t."""
    if variant not in ("one-texel", "hq"):
        raise ValueError(f"height map variant {variant!r}: use 'one-texel' or 'hq' (the "
                         f"forward variant is SG Height Map Forward)")
    w, h = (image.size[0], image.size[1]) if image is not None else (1024, 1024)

    def build(b):
        n = normal_input(b)
        uv = b.input("UV", "VECTOR", "Texture coordinate of the height image (link a UV Map "
                     "node)", hide_value=True)
        scale = b.input("Bump Scale", "FLOAT", "World units of displacement per unit of height",
                        default=0.05, min_value=-1000.0, max_value=1000.0)
        grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
        if variant == "one-texel":
            with b.frame("Listing 16 (level 0): forward differences one texel apart"):
                hc = _height_image_node(b, image, uv, "Linear", extension)
                hr = _height_image_node(b, image, b.vmath("ADD", uv, (1.0 / w, 0.0, 0.0)),
                                        "Linear", extension)
                hu = _height_image_node(b, image, b.vmath("ADD", uv, (0.0, 1.0 / h, 0.0)),
                                        "Linear", extension)
                du, dv = b.math("SUBTRACT", hr, hc), b.math("SUBTRACT", hu, hc)
        else:
            with b.frame("Eq. 20/21: Sobel derivatives of the 4x4 block, bilinearly blended"):
                f = b.vmath("SUBTRACT", b.vmath("MULTIPLY", uv, (float(w), float(h), 0.0)),
                            (0.5, 0.5, 0.0))
                fl = b.vmath("FLOOR", f)
                tx, ty, _ = b.separate(b.sub(f, fl))
                ax, ay = b.math("SUBTRACT", 1.0, tx), tx
                bx, by = b.math("SUBTRACT", 1.0, ty), ty

                def weights(p, q):
                    smooth = [b.math("MULTIPLY", p, 0.25),
                              b.math("MULTIPLY", b.math("ADD", b.math("MULTIPLY", p, 2.0), q), 0.25),
                              b.math("MULTIPLY", b.math("ADD", p, b.math("MULTIPLY", q, 2.0)), 0.25),
                              b.math("MULTIPLY", q, 0.25)]
                    diff = [b.math("MULTIPLY", p, -0.5), b.math("MULTIPLY", q, -0.5),
                            b.math("MULTIPLY", p, 0.5), b.math("MULTIPLY", q, 0.5)]
                    return smooth, diff
                smooth_u, diff_u = weights(ax, ay)
                smooth_v, diff_v = weights(bx, by)
                du, dv = 0.0, 0.0
                for i in range(4):          # rows (v)
                    for j in range(4):      # columns (u)
                        centre = b.vmath("DIVIDE", b.vmath("ADD", fl, (j - 0.5, i - 0.5, 0.0)),
                                         (float(w), float(h), 1.0))
                        q = _height_image_node(b, image, centre, "Closest", extension)
                        du = b.math("ADD", du, b.math("MULTIPLY", b.math(
                            "MULTIPLY", smooth_v[i], diff_u[j]), q))
                        dv = b.math("ADD", dv, b.math("MULTIPLY", b.math(
                            "MULTIPLY", diff_v[i], smooth_u[j]), q))
        with b.frame("Listing 6 in surface gradients: W dH/du grad s + H dH/dv grad t"):
            sg = b.add(b.scale(grads.outputs[0], b.math("MULTIPLY", du, float(w))),
                       b.scale(grads.outputs[1], b.math("MULTIPLY", dv, float(h))))
        b.output("Surface Gradient", "VECTOR", b.scale(sg, scale), "Surface gradient")
    same_image = images_stale(lambda count: [image] * count)

    def stale(tree):
        # Rebuild when the image it samples was replaced or removed, or changed size.
        return same_image(tree) or tree.get("surfgrad_size") != [w, h]

    label = {"hq": "HQ", "one-texel": "One-Texel"}[variant]
    name = f"SG Height Map {label}" + (f" [{image.name}]" if image is not None else "")
    tree = ensure_group(name, VERSION, build,
                        f"Scale-dependent bump from a height image ({label}, Listing 16 and "
                        f"Listing 6); image {image.name if image else '(none: use Add Height Map)'}",
                        stale=stale)
    tree["surfgrad_size"] = [w, h]
    return tree


menu_group("SG Height Map HQ")(height_map_group)


@menu_group("SG Height Map Forward")
def height_map_forward_group(filter_width=None):
    """Forward differences through the Bump node, Filter Width differentials apart (default
    FORWARD_FILTER_WIDTH, about a texel; another width gives a variant group, e.g. to keep the
    look of a converted Bump node)."""
    fw = FORWARD_FILTER_WIDTH if filter_width is None else float(filter_width)
    def build(b):
        n = normal_input(b)
        height = b.input("Height", "FLOAT", "Height (link an Image Texture or any scalar "
                         "graph)", default=0.0, hide_value=True)
        scale = b.input("Bump Scale", "FLOAT", "World units of displacement per unit of height",
                        default=0.05, min_value=-1000.0, max_value=1000.0)
        with b.frame("Listing 7: forward differences along the render's differentials "
                     "(the Bump node, inverted: g = N - n / (n . N))"):
            bump = b.node("ShaderNodeBump")
            bump.inputs["Strength"].default_value = 1.0
            bump.inputs["Distance"].default_value = 1.0
            if "Filter Width" in bump.inputs:
                bump.inputs["Filter Width"].default_value = fw
            b.link(height, bump.inputs["Height"])
            b.link(n, bump.inputs["Normal"])
            nb = bump.outputs[0]
            g = b.sub(n, b.scale(nb, b.math("DIVIDE", 1.0, b.dot(nb, n))))
        b.output("Surface Gradient", "VECTOR", b.scale(g, scale), "Surface gradient")
    name = "SG Height Map Forward" + ("" if fw == FORWARD_FILTER_WIDTH else f" (filter {fw:g})")
    return ensure_group(name, VERSION, build,
                        "Scale-dependent bump from any height by forward differences "
                        "(Listing 7, Listing 6)")


def triplanar_height_group(image=None, extension="REPEAT", images=None):
    """SG Triplanar Height for height images: `image` on all three planes, or `images`, one
    per plane (X, Y, Z). Per plane the one-texel derivative of Listing 16 (three Linear taps),
    in world units, into Listing 13's volume gradient with Listing 14's weights; Listing 8
    projects it."""
    plane_images = list(images) if images is not None else [image] * 3
    if len(plane_images) != 3:
        raise ValueError("triplanar height needs one image or three (for X, Y and Z)")
    sizes = [(im.size[0], im.size[1]) if im is not None else (1024, 1024)
             for im in plane_images]

    def build(b):
        n = normal_input(b)
        p = position_input(b, "Where to project from (unlinked: world position)")
        scale = b.input("Scale", "FLOAT", "Texture repeats per unit", default=1.0,
                        min_value=0.0, max_value=1e4)
        k = b.input("Sharpness", "FLOAT", "Blend sharpness k of Listing 14", default=3.0,
                    min_value=1.0, max_value=64.0)
        bump = b.input("Bump Scale", "FLOAT", "World units of displacement per unit of height",
                       default=0.05, min_value=-1000.0, max_value=1000.0)
        weights = triplanar_weights(b, n, k)
        x, y, z = b.separate(b.scale(p, scale))
        derivs = []
        planes = (("X: (z, y)", (z, y)), ("Y: (x, z)", (x, z)), ("Z: (x, y)", (x, y)))
        for (label, (u, v)), img, (w, h) in zip(planes, plane_images, sizes):
            with b.frame(f"Plane {label}: Listing 16 one-texel derivative, per world unit"):
                uv = b.combine(u, v)
                hc = _height_image_node(b, img, uv, "Linear", extension)
                hr = _height_image_node(b, img, b.vmath("ADD", uv, (1.0 / w, 0.0, 0.0)),
                                        "Linear", extension)
                hu = _height_image_node(b, img, b.vmath("ADD", uv, (0.0, 1.0 / h, 0.0)),
                                        "Linear", extension)
                derivs.append((b.math("MULTIPLY", b.math("SUBTRACT", hr, hc), b.math("MULTIPLY", scale, float(w))),
                               b.math("MULTIPLY", b.math("SUBTRACT", hu, hc), b.math("MULTIPLY", scale, float(h)))))
        sg = triplanar_surface_gradient(b, n, weights, derivs)
        b.output("Surface Gradient", "VECTOR", b.scale(sg, bump), "Surface gradient")

    stale = images_stale(lambda count: [im for im in plane_images for _ in range(3)])

    named = [im.name for im in plane_images if im is not None]
    label = named[0] if len(set(named)) == 1 and len(named) == 3 else " | ".join(named)
    name = "SG Triplanar Height" + (f" [{label}]" if label else "")
    return ensure_group(name, VERSION, build,
                        "Listings 13 and 14 from a height image on all three planes",
                        stale=stale)


menu_group("SG Triplanar Height")(triplanar_height_group)


POM_STEPS = 8


def parallax_group(image=None, extension="REPEAT"):
    """SG Parallax for one height image (heights in [0, 1], 1 = Bump Scale above the surface):
    Listing 11 in surface gradients (the change of st along dir is (grad s . dir,
    grad t . dir)), Welsh's offset limiting, a POM_STEPS-step parallax-occlusion march with
    linear refinement (reference/parallax.py), and Listing 12 for the surface offset."""
    def build(b):
        n = normal_input(b)
        uv = b.input("UV", "VECTOR", "Texture coordinate of the height image (link a UV Map "
                     "node)", hide_value=True)
        view = b.input("View", "VECTOR", "Unit direction toward the viewer, world space "
                       "(unlinked: the Geometry node's Incoming)", hide_value=True)
        scale = b.input("Bump Scale", "FLOAT", "World distance of height 1 above the surface",
                        default=0.05, min_value=0.0, max_value=100.0)
        with b.frame("Unlinked View: Incoming"):
            incoming = b.node("ShaderNodeNewGeometry").outputs["Incoming"]
            unlinked = b.math("COMPARE", b.length(view), 0.0, 0.0)
            view = b.mix_vector(unlinked, view, incoming)
        grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
        gs, gt = grads.outputs[0], grads.outputs[1]
        with b.frame("Listing 11: dir to texture space"):
            dir_tex = b.combine(b.dot(gs, view), b.dot(gt, view), 0.0)
            limited_v = b.scale(dir_tex, scale)
            proj = b.math("DIVIDE", scale, b.math("MAXIMUM", b.math("ABSOLUTE", b.dot(n, view)),
                                                  1.192092896e-07))
            v = b.scale(dir_tex, proj)
        with b.frame("Welsh: offset limiting, H(st) v"):
            h0 = _height_image_node(b, image, uv, "Linear", extension)
            limited = b.scale(limited_v, h0)
        with b.frame(f"Parallax occlusion: {POM_STEPS} steps from height 1 down, refined"):
            hit, found = 0.0, 0.0
            prev_level, prev_gap = None, None
            for k in range(POM_STEPS + 1):
                level = 1.0 - k / POM_STEPS
                hk = _height_image_node(b, image, b.add(uv, b.scale(v, level)), "Linear",
                                        extension)
                gap = b.math("SUBTRACT", level, hk)
                below = b.math("LESS_THAN", gap, 1e-30)          # gap <= 0
                cross = b.math("MULTIPLY", below, b.math("SUBTRACT", 1.0, found))
                if prev_gap is None:
                    refined = level
                else:
                    t = b.math("DIVIDE", prev_gap, b.math("SUBTRACT", prev_gap, gap))
                    refined = b.math("ADD", prev_level, b.math("MULTIPLY", level - prev_level, t))
                hit = b.math("ADD", hit, b.math("MULTIPLY", cross, refined))
                found = b.math("MAXIMUM", found, cross)
                prev_level, prev_gap = level, gap
            offset = b.scale(v, hit)
        with b.frame("Listing 12: texture offset back onto the surface"):
            # The dual basis of (grad s, grad t) in the tangent plane: dP/ds, dP/dt.
            es = b.cross(gt, n)
            es = b.scale(es, b.math("DIVIDE", 1.0, b.dot(gs, es)))
            et = b.cross(n, gs)
            et = b.scale(et, b.math("DIVIDE", 1.0, b.dot(gt, et)))
            ox, oy, _ = b.separate(offset)
            surface = b.add(b.scale(es, ox), b.scale(et, oy))
        b.output("UV", "VECTOR", b.add(uv, offset), "Parallax-occlusion corrected texture "
                 "coordinate: sample the material's other maps here")
        b.output("UV Limited", "VECTOR", b.add(uv, limited), "Parallax with offset limiting "
                 "(cheaper, one height sample)")
        b.output("Surface Offset", "VECTOR", surface, "World offset of the corrected point "
                 "along the surface (Listing 12)")
        b.output("Height", "FLOAT", hit, "Height where the view ray meets the height field")

    stale = images_stale(lambda count: [image] * count)
    name = "SG Parallax" + (f" [{image.name}]" if image is not None else "")
    return ensure_group(name, VERSION, build,
                        "Listings 11 and 12: parallax mapping with offset limiting and "
                        "parallax occlusion", stale=stale)


menu_group("SG Parallax")(parallax_group)


REST_ATTRIBUTE = "sg_rest_position"


def displace_group():
    """Gustavson's displacement (Eq. 3-8) in Geometry Nodes: P = P0 + amount h(scale P0) N0,
    and the new normal normalize(N0 - amount (g - (g . N0) N0)) set analytically with Set
    Mesh Normal; h and g are the reference's fractal-sum noise (SG Noise's lattice).
    Raises FeatureUnavailable where Set Mesh Normal does not exist (before 4.5)."""
    reason = unavailable_reason("SG Displace")
    if reason is not None:
        raise FeatureUnavailable(reason)

    def build(b):
        geo = b.input("Geometry", "GEOMETRY", "Mesh to displace")
        amount = b.input("Amount", "FLOAT", "Displacement along the normal per unit of noise "
                         "(object units)", default=0.1, min_value=-100.0, max_value=100.0)
        scale = b.input("Scale", "FLOAT", "Frequency of the first octave", default=2.0,
                        min_value=0.0, max_value=1e4)
        octaves = b.input("Octaves", "INT", f"Octaves of the fractal sum (1 to {NOISE_OCTAVES})",
                          default=1, min_value=1, max_value=NOISE_OCTAVES)
        gain = b.input("Gain", "FLOAT", "Amplitude ratio between octaves", default=0.5,
                       min_value=0.0, max_value=1.0)
        analytic = b.input("Analytic Normals", "BOOLEAN", "Set the normals from the noise's "
                           "gradient (Eq. 4-8); off: Blender recomputes them from the "
                           "displaced geometry, which needs a dense mesh", default=True)
        p0 = b.node("GeometryNodeInputPosition").outputs[0]
        n0 = b.normalize(b.node("GeometryNodeInputNormal").outputs[0])
        p = b.scale(p0, scale)
        value, grad = 0.0, (0.0, 0.0, 0.0)
        octave_tree = gradient_noise_group("GeometryNodeTree")
        with b.frame("Fractal sum: sum gain^i noise(2^i scale P0), exact gradient"):
            for i in range(NOISE_OCTAVES):
                freq = 2.0 ** i
                node = sub_group(b, octave_tree, f"octave {i + 1}",
                                 Vector=b.scale(p, freq) if i else p)
                on = b.math("LESS_THAN", float(i), octaves)
                amp = b.math("MULTIPLY", on, b.math("POWER", gain, float(i)))
                value = b.math("ADD", value, b.math("MULTIPLY", amp, node.outputs[0]))
                grad = b.add(grad, b.scale(node.outputs[1], b.math("MULTIPLY", amp, freq)))
            grad = b.scale(grad, scale)
        with b.frame("Eq. 4-8: N = normalize(N0 - amount (g - (g . N0) N0))"):
            g_perp = b.sub(grad, b.scale(n0, b.dot(grad, n0)))
            normal = b.normalize(b.sub(n0, b.scale(g_perp, amount)))
        with b.frame("Keep the rest position (for bump on top) and the new normal"):
            store = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_VECTOR",
                           domain="POINT")
            b.link(geo, store.inputs["Geometry"])
            store.inputs["Name"].default_value = REST_ATTRIBUTE
            b.link(p0, store.inputs["Value"])
            capture = b.node("GeometryNodeCaptureAttribute", domain="POINT")
            capture.capture_items.new("VECTOR", "Normal")
            b.link(store.outputs["Geometry"], capture.inputs["Geometry"])
            b.link(normal, capture.inputs["Normal"])      # by name: 5.1 added Selection
        with b.frame("Eq. 3: P = P0 + amount h N0, then the analytic normals"):
            setpos = b.node("GeometryNodeSetPosition")
            b.link(capture.outputs["Geometry"], setpos.inputs["Geometry"])
            b.link(b.scale(n0, b.math("MULTIPLY", value, amount)), setpos.inputs["Offset"])
            setn = b.node("GeometryNodeSetMeshNormal", mode="FREE", domain="POINT")
            b.link(setpos.outputs["Geometry"], setn.inputs["Mesh"])
            b.link(capture.outputs["Normal"], setn.inputs["Custom Normal"])
            switch = b.node("GeometryNodeSwitch", input_type="GEOMETRY")
            b.link(analytic, switch.inputs["Switch"])
            b.link(setpos.outputs["Geometry"], switch.inputs["False"])
            b.link(setn.outputs[0], switch.inputs["True"])
        b.output("Geometry", "GEOMETRY", switch.outputs[0], "Displaced mesh with analytic normals "
                 f"and its rest position in the '{REST_ATTRIBUTE}' attribute")
    return ensure_group("SG Displace", VERSION, build,
                        "Gustavson's procedural displacement: noise along the normal, normals "
                        "recomputed analytically (Eq. 3-8)", tree_type="GeometryNodeTree")


GEOMETRY_MENU_GROUPS = [("SG Displace", displace_group)]


@menu_group("SG Rest Position")
def rest_position_group():
    def build(b):
        with b.frame(f"Attribute '{REST_ATTRIBUTE}' written by SG Displace"):
            attr = b.node("ShaderNodeAttribute", attribute_type="GEOMETRY",
                          attribute_name=REST_ATTRIBUTE)
        b.output("Rest Position", "VECTOR", attr.outputs["Vector"], "Object-space position "
                 "before SG Displace moved it: feed SG Noise's Vector for bump on top")
    return ensure_group("SG Rest Position", VERSION, build,
                        "The undisplaced object coordinates stored by SG Displace")


def build_all():
    """Create (or update) every menu group and its helpers; returns {name: tree}."""
    return {name: fn() for name, fn in MENU_GROUPS}
