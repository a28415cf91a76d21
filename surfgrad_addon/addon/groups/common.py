"""Pieces every group shares: the version stamp and feature gates, the Normal input with its
shading-normal fallback (.SG Safe Normal), the Bump-node surface gradient (.SG Surface Gradient,
.SG UV Gradients), and Listing 2's tangent-space decode with its DirectX switch."""

import bpy

from ..node_vocabulary import Math, VMath
from ..node_builder import ensure_group
from ..far_limits import FAR_METRES, FAR_REPEATS  # noqa: F401 (projection.py reads FAR_METRES here)
from ...reference import socket_specs as S
from ...reference.group_interfaces import INTERFACES
from ...reference.vecmath import DIVIDE_FLOOR, FLT_EPSILON, NODE_Z_FLOOR, TSPACE_Z_CLAMP


VERSION = 24


class FeatureUnavailable(ValueError):
    """A group needs a node this Blender does not have; the message names the node and the
    Blender version that has it (docs/versions.md)."""


# Groups that need a node newer than blender_version_min: name -> (node type, the first LTS
# line checked to have it, what the group does with it). Tested by the node's presence, not by
# the version number.
REQUIRES = {"SG Displace": ("GeometryNodeSetMeshNormal", "4.5", "it sets the analytic normals "
                            "with the Geometry Nodes Set Mesh Normal node")}
CLOSURE_NODE = "NodeEvaluateClosure"
SAMPLER_USE = "it evaluates your Image Texture through a Sampler closure (a Closure Zone)"
# The sampler groups (one per method, any image): name -> what the per-image group is.
SAMPLER_GROUPS = {"SG Height Map HQ (Sampler)": "SG Height Map HQ",
                  "SG Height Map One-Texel (Sampler)": "SG Height Map HQ",
                  "SG Triplanar (Sampler)": "SG Triplanar",
                  "SG Triplanar Height (Sampler)": "SG Triplanar Height",
                  "SG Parallax (Sampler)": "SG Parallax"}
REQUIRES.update({name: (CLOSURE_NODE, "5.0", SAMPLER_USE) for name in SAMPLER_GROUPS})


# Hidden helpers that only a gated group builds (absent where the gate refuses it).
GATED_HELPERS = {"SG Displace": (".SG Gradient Noise (Geometry)",)}


def unavailable_reason(name):
    """None when group `name` can be built in the running Blender, else why not."""
    need = REQUIRES.get(name)
    if need is None or hasattr(bpy.types, need[0]):
        return None
    node_type, line, use = need
    twin = SAMPLER_GROUPS.get(name)
    instead = ("" if twin is None else
               f"; on this line use {twin} with an Image Texture per plane" if
               twin == "SG Triplanar" else f"; on this line use {twin}, built per image")
    return (f"{name} needs Blender {line} or newer: {use} ({node_type}), which Blender "
            f"{bpy.app.version_string} does not have{instead}")


def require(name):
    """Raise FeatureUnavailable (naming the node and the line that has it) unless group
    `name` can be built here."""
    reason = unavailable_reason(name)
    if reason:
        raise FeatureUnavailable(reason)


def ensure(key, build, name=None, stale=None, tree_type="ShaderNodeTree", held_name=None,
           **fields):
    """ensure_group for the group INTERFACES[key] (named `name`, default `key`), at VERSION;
    `fields` fill its description (an image's or UV map's name)."""
    iface = INTERFACES[key]
    return ensure_group(name or key, VERSION, build, iface.describe(**fields), stale, tree_type,
                        iface, held_name)


def normal_input(b, spec=S.NORMAL):
    """The group's Normal input: unlinked (zero) it is the shading normal; normalised. A NaN or
    Inf is not caught here but once, by SG Resolve's final guard (.SG Safe Normal): one guard
    per stack, not one per socket. `spec` may be a tooltip, for a group without a declared
    interface."""
    raw = b.input(S.NORMAL.but(tooltip=spec) if isinstance(spec, str) else spec)
    with b.frame("Base normal: the shading normal where unlinked (zero), else normalised"):
        # Unlinked, the Compare is a constant 1 and the Mix folds to the shading normal (unit
        # already): no Normalize runs.
        return b.mix_vector(b.is_zero(raw), b.normalize(raw), b.geometry("Normal"))


def where_zero(b, v, fallback):
    """fallback where v is (0, 0, 0) (an unlinked vector input), else v (a Mix node)."""
    return b.mix_vector(b.is_zero(v), v, fallback)


def sub_group(b, tree, label, **inputs):
    kind = "GeometryNodeGroup" if b.tree.bl_idname == "GeometryNodeTree" else "ShaderNodeGroup"
    node = b.node(kind, label=label, node_tree=tree)
    for name, value in inputs.items():
        b.link(value, node.inputs[name.replace("_", " ")])
    return node


def sign_nonneg(b, x):
    """The listings' `x < 0 ? -1 : 1`."""
    return b.math(Math.SUBTRACT, 1.0, b.math(Math.MULTIPLY, 2.0, b.math(Math.LESS_THAN, x, 0.0)))


# Squared lengths at or under this have no direction: is_zero's test (|v| <= FLT_EPSILON,
# Cycles' and EEVEE's Compare) on the squared length.
NO_DIRECTION_SQUARED = FLT_EPSILON * FLT_EPSILON


def has_direction(b, v):
    """1 where v is finite and not (nearly) zero, else 0: d * 0 + d is d where the squared length
    d is finite and NaN where it is NaN or Inf (Inf * 0), and a NaN compares false."""
    d = b.dot(v, v)
    return b.math(Math.GREATER_THAN, b.math(Math.MULTIPLY_ADD, d, 0.0, d), NO_DIRECTION_SQUARED)


def safe_normal_group():
    def build(b):
        v = b.input(S.NOISE_VECTOR)
        ns = b.geometry("Normal")
        with b.frame("normalize(v) where v has a direction, else the shading normal"):
            # Vector Normalize is NaN for a NaN or Inf v (and 0 for a zero or overflowing one);
            # Vector Maximum against -2 turns a NaN component into -2 (it drops a NaN) and
            # leaves a unit vector as it is, so the Mix, a (1 - f) + b f, gives the shading
            # normal exactly where v has no direction and the unit vector exactly elsewhere.
            # The same on every line and renderer, in arithmetic nodes only (tests/
            # test_guard_pins.py pins each piece).
            unit = b.vmath(VMath.MAXIMUM, b.normalize(v), (-2.0, -2.0, -2.0))
            out = b.mix_vector(has_direction(b, v), ns, unit)
        b.output(S.NORMAL_OUT, out)
    return ensure(".SG Safe Normal", build)


def surface_gradient_group():
    def build(b):
        value = b.input("Value")
        n = b.input(S.UNIT_NORMAL)
        with b.frame("Bump node inverted: g = N - n / (n . N)"):
            g = bump_surface_gradient(b, value, n, BUMP_FILTER_WIDTH)
        b.output(S.GRADIENT_OUT, g)
    return ensure(".SG Surface Gradient", build)


def bump_surface_gradient(b, height, n, filter_width, steep=False):
    """The Bump node inverted: its normal nb = normalize(N - grad_S h) (Strength 1, Distance 1)
    gives back g = N - nb / (nb . N). steep: for heights of any slope (a user's Height input),
    nb . N floored at FLT_EPSILON (one Maximum)."""
    nb = b.bump(height, n, filter_width)
    k = b.dot(nb, n)
    if steep:
        # nb . N = 1 / |N - grad_S h| > 0, but past slopes of about 1e7 it is float32 noise
        # around zero, and a negative k turned the normal over (180 degrees at 1e8): floored,
        # g points along nb as the truth does (tests/test_steep_heights.py).
        k = b.math(Math.MAXIMUM, k, FLT_EPSILON)
    # n + nb * (-1 / (nb . N)): one Multiply Add for the Scale and the Subtract.
    return b.vmath(VMath.MULTIPLY_ADD, nb, b.math(Math.DIVIDE, -1.0, k), n)


# Shifted copies see UV + fw * dUV: for linear attributes any step is exact, and a large one
# keeps float32 cancellation in the forward differences small.
BUMP_FILTER_WIDTH = 10.0


FORWARD_FILTER_WIDTH = 2.0      # = reference.methods.FORWARD_FILTER_WIDTH


def uv_gradients_group():
    def build(b):
        uv = b.input(S.UV)
        n = b.input(S.UNIT_NORMAL)
        s, t, _ = b.separate(uv)
        sg = surface_gradient_group()
        with b.frame("Surface gradients of s and t (Eq. 7 with H = s, H = t)"):
            gs = sub_group(b, sg, "grad s", Value=s, Normal=n).outputs[0]
            gt = sub_group(b, sg, "grad t", Value=t, Normal=n).outputs[0]
        b.output("Gradient S", gs)
        b.output("Gradient T", gt)
    return ensure(".SG UV Gradients", build)


def directx_input(b):
    """The DirectX/OpenGL switch of every group that decodes a tangent-space colour."""
    return b.input(S.DIRECTX)


def flip_green(b, y, directx):
    """y, negated where the DirectX switch is on: y (1 - 2 DirectX). Off (a constant) the product
    by 1 folds away in Cycles; None builds no switch at all (what the off switch folds to)."""
    if directx is None:
        return y
    return b.math(Math.MULTIPLY, y, b.math(Math.MULTIPLY_ADD, directx, -2.0, 1.0))


def listing2_z(b, mx, my, mz):
    """Listing 2's z = max(|z|, max(|x|, |y|) / 128): the derivative stays within 128."""
    return b.math(Math.MAXIMUM, b.math(Math.ABSOLUTE, mz), b.math(
        Math.MULTIPLY, TSPACE_Z_CLAMP, b.math(Math.MAXIMUM, b.math(Math.ABSOLUTE, mx),
                                               b.math(Math.ABSOLUTE, my))))


def listing2_colour(b, color, directx):
    """Listing 2 as a colour for a Normal Map node: the colour c with its green flipped where
    DirectX is on and its blue b = 0.5 + max(|c.z - 0.5|, max(|c.x - 0.5|, |c.y - 0.5|) / 128
    + NODE_Z_FLOOR / 2).
    The node's decode 2 (c - 0.5) then gives Listing 2's m with z clamped, bit for bit as from
    the centred m (c - 0.5 is exact there); x and y pass as they are (a per-axis Mix)."""
    ax, ay, az = b.separate(b.vmath(VMath.ABSOLUTE, b.vmath(VMath.SUBTRACT, color,
                                                           (0.5, 0.5, 0.5))))
    # 0.5 + max(p, q) = max(0.5 + p, 0.5 + q), rounded alike; q = M / 128 is exact. Scalar Math
    # nodes here: a sample runs a Vector Math node at several times a Math node's instructions
    # (docs/performance.md, "Instructions per frame").
    blue = b.math(Math.MAXIMUM, b.math(Math.ADD, az, 0.5), b.math(
        Math.MULTIPLY_ADD, b.math(Math.MAXIMUM, ax, ay), TSPACE_Z_CLAMP, 0.5 + NODE_Z_FLOOR / 2))
    return b.mix_vector((0.0, 0.0, 1.0), flip_green_colour(b, color, directx), blue,
                        per_axis=True)


def flip_green_colour(b, color, directx):
    """The colour with green g turned into 1 - g where the DirectX switch is on: c (1, k, 1) +
    (0, DirectX, 0) with k = 1 - 2 DirectX. Off (a constant) both fold away in Cycles (a
    product by (1, 1, 1), a sum with zero); None builds no switch at all."""
    if directx is None:
        return color
    k = b.math(Math.MULTIPLY_ADD, directx, -2.0, 1.0)
    return b.add(b.vmath(VMath.MULTIPLY, color, b.combine(1.0, k, 1.0)),
                 b.combine(0.0, directx, 0.0))


def unpack_normal(b, color):
    """m = 2 c - 1: a tangent-space normal from its colour (one Multiply Add: 2 c is exact, so
    it rounds once, as c * 2 - 1 does)."""
    return b.vmath(VMath.MULTIPLY_ADD, color, (2.0, 2.0, 2.0), (-1.0, -1.0, -1.0))


def decode_tangent_normal(b, color, directx=None, weight=None):
    """m = 2 c - 1 (m.y negated for a DirectX map) and Listing 2's derivative (abs z, 1/128
    clamp), as two float sockets. With a `weight` w, the derivative times -w: w m.xy / z in one
    division (triplanar_surface_gradient takes the sign back for free)."""
    mx, my, mz = b.separate(unpack_normal(b, color))
    my = flip_green(b, my, directx)
    inv = b.math(Math.DIVIDE, -1.0 if weight is None else weight,
                 b.math(Math.MAXIMUM, listing2_z(b, mx, my, mz), DIVIDE_FLOOR))
    return b.math(Math.MULTIPLY, mx, inv), b.math(Math.MULTIPLY, my, inv)


def by_strength(b, v, strength):
    """v x Strength: at the default 1 (a constant) the product folds away in Cycles
    (tests/test_render_cost_folding.py)."""
    return b.scale(v, strength)


def tangent_normal_to_surfgrad(b, color, strength, t, bt, directx=None):
    """Listing 2 (abs z, 1/128 clamp) then Listing 3, scaled by strength."""
    with b.frame("Listing 2: derivative from a tangent-space normal"):
        dx, dy = decode_tangent_normal(b, color, directx)
    with b.frame("Listing 3: deriv.x t + deriv.y b"):
        return by_strength(b, b.add(b.scale(t, dx), b.scale(bt, dy)), strength)




class ImageTaps:
    """Image lookups of a per-image group: an Image Texture node per tap, bound to `image`."""

    def __init__(self, b, image, extension):
        self.b, self.image, self.extension = b, image, extension

    def color(self, vector, interpolation="Linear"):
        node = self.b.node("ShaderNodeTexImage", interpolation=interpolation,
                           extension=self.extension)
        node.image = self.image
        self.b.link(vector, node.inputs["Vector"])
        return node.outputs["Color"]

    def height(self, vector, interpolation="Linear"):
        return self.b.separate(self.color(vector, interpolation))[0]


class SamplerTaps(ImageTaps):
    """Image lookups of a sampler group (Blender 5.0+): the Sampler closure input evaluated
    per tap. The artist's Image Texture sets interpolation and extension; taps that want
    Closest sample texel centres, where Linear gives the texel's own value."""

    def __init__(self, b):
        super().__init__(b, None, None)
        self.sampler = b.input(S.SAMPLER)

    def color(self, vector, interpolation=None):
        ev = self.b.node(CLOSURE_NODE, label="Sampler")
        ev.input_items.new("VECTOR", "Vector")
        ev.output_items.new("RGBA", "Color")
        self.b.link(self.sampler, ev.inputs[0])
        self.b.link(vector, ev.inputs["Vector"])
        return ev.outputs["Color"]


def texel_count_inputs(b):
    """Width and Height of a sampler group's image (the Add menu fills them from the image)."""
    return b.input(S.IMAGE_WIDTH), b.input(S.IMAGE_HEIGHT)


def select(b, pick, a, v):
    """a where pick is 0, v where it is 1, exactly: a (1 - pick) + v pick as separate products
    (an interpolation a + pick (v - a) would round v to a's precision)."""
    return b.add(b.scale(a, b.math(Math.SUBTRACT, 1.0, pick)), b.scale(v, pick))


POSITION_ATTRIBUTE = "position"


def object_position(b):
    """Object-space position, precise far from the origin: the mesh's own 'position' attribute,
    interpolated like a UV map (Cycles' Texture Coordinate Object output is the float32 world
    position transformed back, off by ~1e-3 at 10 km; tests/test_far.py pins both). Where a
    renderer has no such attribute (it reads zero), the Texture Coordinate node's Object."""
    with b.frame("Object position: the 'position' attribute (precise far away), else Object"):
        attr = b.node("ShaderNodeAttribute", attribute_type="GEOMETRY",
                      attribute_name=POSITION_ATTRIBUTE).outputs["Vector"]
        coords = b.node("ShaderNodeTexCoord").outputs["Object"]
        return select(b, b.is_zero(attr), attr, coords)




def _fraction_of_product(b, t, s):
    """frac(t s) for a float32 vector t (|t| < 2^24) and scale s, without the float32 rounding
    of t s: t = i_hi + i_lo + f (integers of 12 bits each times 4096 and 1, and f in [0, 1)),
    s = s_hi + s_lo (Veltkamp's split into 12-bit halves), so every integer product is exact and
    its fraction too; only f s rounds, relative to s, not to t s."""
    c = b.math(Math.MULTIPLY, s, 4097.0)
    s_hi = b.math(Math.SUBTRACT, c, b.math(Math.SUBTRACT, c, s))
    s_lo = b.math(Math.SUBTRACT, s, s_hi)
    i = b.vmath(VMath.FLOOR, t)
    f = b.sub(t, i)
    i_hi = b.vmath(VMath.MULTIPLY,
                   b.vmath(VMath.FLOOR, b.vmath(VMath.MULTIPLY, i, (1 / 4096,) * 3)),
                   (4096.0,) * 3)
    i_lo = b.sub(i, i_hi)
    total = b.vmath(VMath.FRACTION, b.scale(f, s))
    for part, half in ((i_hi, s_hi), (i_hi, s_lo), (i_lo, s_hi), (i_lo, s_lo)):
        total = b.add(total, b.vmath(VMath.FRACTION, b.scale(part, half)))
    return b.vmath(VMath.FRACTION, total)


def scaled_position_inputs(b):
    """The Position and Scale inputs of a projection: returns (Position x Scale, Scale).
    Linked, the Position as given. Unlinked, the world position; where the object's origin is
    more than FAR_REPEATS repeats out, rebuilt from precise parts: frac(origin x Scale) (exact,
    _fraction_of_product) plus the object-space position turned to world axes (a small offset,
    precise) x Scale. The same modulo one repeat, which a Repeat image cannot tell apart."""
    raw = b.input(S.POSITION)
    scale = b.input(S.TEXTURE_SCALE)
    unlinked = b.is_zero(raw)
    world = b.scale(b.geometry("Position"), scale)
    with b.frame("Precise Far From Origin: where the object's origin is far, modulo one repeat "
                 "from precise parts (object origin, object-space offset)"):
        def precise():
            origin = b.node("ShaderNodeObjectInfo").outputs["Location"]
            turn = b.node("ShaderNodeVectorTransform", vector_type="VECTOR",
                          convert_from="OBJECT", convert_to="WORLD")
            b.link(object_position(b), turn.inputs[0])
            parts = b.add(_fraction_of_product(b, origin, scale),
                          b.scale(turn.outputs[0], scale))
            ox, oy, oz = b.separate(b.vmath(VMath.ABSOLUTE, origin))
            reach = b.math(Math.MULTIPLY, b.math(Math.MAXIMUM, b.math(Math.MAXIMUM, ox, oy), oz),
                           scale)
            return select(b, b.math(Math.GREATER_THAN, reach, FAR_REPEATS), world, parts)
        world = precise_far_route(b, world, precise)
    return select(b, unlinked, b.scale(raw, scale), world), scale


def precise_far_route(b, plain, precise):
    """plain, or precise() where the group's Precise Far From Origin input is on. Off by
    default, a constant: Cycles folds the precise route away (tests/test_render_cost_folding.py
    counts it), so a group near the origin costs what it did before the route existed."""
    return select(b, b.input(S.PRECISE_FAR), plain, precise())


def surfgrad_reaching(b, n, v, against):
    """Listing 5 for a normal v to reach from base n: n - v / (a . v) with a = `against`
    (the normal v is measured from), and n - v (v unit) where v faces away from a, which still
    resolves to v. A surface gradient that adds to others."""
    k = b.dot(against, v)
    # w = 1 / k, or 1 where v faces away (k < FLT_EPSILON): max(k, [k < FLT_EPSILON]) is k or 1;
    # n - v w as one Multiply Add, v (-w) + n.
    neg_w = b.math(Math.DIVIDE, -1.0,
                   b.math(Math.MAXIMUM, k, b.math(Math.LESS_THAN, k, FLT_EPSILON)))
    return b.vmath(VMath.MULTIPLY_ADD, v, neg_w, n)


def uv_input(b, uv_map=""):
    """A UV input; unlinked (zero) it is UV map `uv_map`, by default ("") the active render one,
    as Blender's own texture nodes take it."""
    raw = b.input(S.UV)
    where = f"UV map {uv_map!r}" if uv_map else "the active render UV map"
    with b.frame(f"UV: {where} where unlinked (zero)"):
        return where_zero(b, raw, b.node("ShaderNodeUVMap", uv_map=uv_map).outputs["UV"])


def image_group_name(key, images, extension):
    """The name of group `key` built for `images` (one per Image Texture role, None for none)
    and `extension`: what makes two such groups differ is in it, so that a second use never
    rebuilds over the first one's group (which other materials use): a linked image by its
    library too (Blender's name_full, "A [lib.blend]"), three different planes each, and an
    extension other than REPEAT. Where there are several (triplanar planes), each is escaped
    ("\\" and "|" get a backslash) before they are joined by " | ", so that no image name
    holding the separator names another set: "A | B", "C", "C" and "A", "B | C", "C"."""
    named = [im.name_full for im in images if im is not None]
    if len(images) > 1:
        named = [n.replace("\\", "\\\\").replace("|", "\\|") for n in named]
    label = named[0] if len(set(named)) == 1 and len(named) == len(images) else " | ".join(named)
    return key + (f" [{label}]" if label else "") + \
        ("" if extension == "REPEAT" else f" ({extension})")


def held_images(tree, planes=1):
    """(the images, one per plane, and the extension) the Image Texture nodes of per-image
    group `tree` hold now, or None where one is gone."""
    taps = [nd for nd in tree.nodes if nd.bl_idname == "ShaderNodeTexImage"]
    images = [t.image for t in taps]
    if not images or None in images or len(images) % planes:
        return None
    return images[::len(images) // planes], taps[0].extension


def held_images_name(key, planes=1):
    """held_name for ensure: the name per-image group `key` gets for the images a tree holds."""
    def held_name(tree):
        held = held_images(tree, planes)
        return held and image_group_name(key, *held)
    return held_name


def images_stale(expected):
    """A `stale` test for image-bound groups: rebuild when their Image Texture nodes no longer
    hold `expected` (in node order), e.g. an image was replaced or removed."""
    def stale(tree):
        taps = [nd.image for nd in tree.nodes if nd.bl_idname == "ShaderNodeTexImage"]
        return taps != list(expected(len(taps)))
    return stale
