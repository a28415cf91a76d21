"""Where an SG material's cost above its built-in twin goes: the materials whose render-cost
target (issue 21) is missed, taken apart into their listings. Each part is a material of its
own, the part's nodes on top of a base (the twin, or no perturbation at all) whose count is
taken away; what the parts leave of the SG material's overhead is reported as the remainder.

    python -m surfgrad_addon.harness.bench.shader_instructions --parts [--out FILE]

counts them with valgrind (shader_instructions). A part that hands the BSDF a surface gradient
or a tangent, not a normal, is counted all the same: Cycles runs the nodes whatever the vector
means, and the BSDF normalises what it is given.
"""

from dataclasses import dataclass
from typing import Callable

from ...addon import groups as G
from ...addon.groups import common as C
from ...addon.groups.projection import triplanar_weights
from ...addon.node_vocabulary import Math
from . import render_materials as M


@dataclass(frozen=True)
class Part:
    key: str
    label: str
    build: Callable
    base: str           # the material whose count the part's count is taken from
    whole: str          # the SG material the part belongs to (its twin: M's row for it)
    sign: int = 1
    for_scale: bool = False


def _normal_map(g, ctx, uv_map="UVMap", color=None):
    """The twin's Image Texture -> Normal Map node (optionally on a given colour)."""
    color = g.image(ctx["normal"], g.uv(uv_map)) if color is None else color
    return g.normal_map(color, "TANGENT", 1.0, uv_map)


def _resolved(g, surface_gradient):
    return g.resolve(surface_gradient)


def nm_listing2(g, ctx):
    return _normal_map(g, ctx, color=C.listing2_colour(g, g.image(ctx["normal"], g.uv("UVMap")),
                                                       None))


def nm_listing5(g, ctx):
    n = g.geometry("Normal")
    return C.surfgrad_reaching(g, n, _normal_map(g, ctx), n)


def nm_resolve(g, ctx):
    return _resolved(g, _normal_map(g, ctx))


def nm_hand_chain(g, ctx):
    """Issue 21's hand-made chain: the Normal Map node, Listing 5 without its facing-away
    branch, the resolve without its guard (normalize(n - sg))."""
    v = _normal_map(g, ctx)
    n = g.geometry("Normal")
    sg = g.sub(n, g.scale(v, g.math(Math.DIVIDE, 1.0, g.dot(n, v))))
    return g.normalize(g.sub(n, sg))


def bump_inverted(g, ctx):
    node = g.group(G.height_map_forward_group(), Height=M.noise_texture(g),
                   Bump_Scale=M.BUMP_DISTANCE)
    return node.outputs["Surface Gradient"]


def bump_resolve(g, ctx):
    return _resolved(g, M._bump_builtin(g, ctx))


def lookup_uv(g, ctx):
    """One Image Texture on the UV map, its colour to the BSDF: what every tangent-space
    material reads before its own nodes."""
    return g.image(ctx["normal"], g.uv("UVMap"))


def lookup_detail(g, ctx):
    return g.image(ctx["normal"], g.uv("Detail"))


def tri_lookups(g, ctx):
    """SG Triplanar Coordinates and its three Image Textures, the colours added."""
    coords = g.group(G.triplanar_coordinates_group())
    colors = [g.image(ctx["normal"], coords.outputs[f"UV {axis}"]) for axis in "XYZ"]
    return g.add(g.add(colors[0], colors[1]), colors[2])


def tri_group(g, ctx):
    """SG Triplanar on its three lookups, its surface gradient to the BSDF."""
    coords = g.group(G.triplanar_coordinates_group())
    tri = g.group(G.triplanar_group())
    for axis in "XYZ":
        g.link(g.image(ctx["normal"], coords.outputs[f"UV {axis}"]), tri.inputs[f"Color {axis}"])
    return tri.outputs["Surface Gradient"]


def tri_weights(g, ctx):
    """Listing 14's blend weights on the shading normal (the group's default sharpness)."""
    k = G.triplanar_group().interface.items_tree["Sharpness"].default_value
    return g.combine(*triplanar_weights(g, g.geometry("Normal"), k))


def uv2_gradients(g, ctx):
    """The UV gradients of the Detail map (two inverted Bump nodes), added."""
    grads = g.group(G.uv_gradients_group(), UV=g.uv("Detail"))
    return g.add(grads.outputs[0], grads.outputs[1])


def uv2_basis(g, ctx):
    """SG Procedural Basis [Detail]: the gradients and Listing 4; tangent + bitangent."""
    basis = g.group(G.procedural_basis_group("Detail"))
    return g.add(basis.outputs["Tangent"], basis.outputs["Bitangent"])


def uv2_tangent_normal(g, ctx):
    """The Detail map's image into SG Tangent Normal on a fixed frame (Listings 2 and 3)."""
    tn = g.group(G.tangent_normal_group(), Color=lookup_detail(g, ctx),
                 Tangent=g.geometry("Tangent"), Bitangent=g.geometry("Parametric"))
    return tn.outputs["Surface Gradient"]


def uv2_resolve(g, ctx):
    return _resolved(g, _normal_map(g, ctx, "Detail"))


RESOLVE = "SG Resolve (its Subtract and the guard)"
TWIN_NM = "less the twin's Normal Map node, which the SG material does not run"

# A part's cost is count(key) - count(base); a part with build None is an existing material
# (a twin) whose cost the SG material does not pay: it enters with sign -1.
PARTS = [
    Part("part-nm-listing2", "Listing 2's colour (the 1/128 clamp of z)", nm_listing2,
         "nm-builtin", "nm-sg"),
    Part("part-nm-listing5", "Listing 5 (with its facing-away branch)", nm_listing5,
         "nm-builtin", "nm-sg"),
    Part("part-nm-resolve", RESOLVE, nm_resolve, "nm-builtin", "nm-sg"),
    Part("part-nm-hand", "for scale (not a part): issue 21's hand chain (Listing 5 without its "
         "branch, normalize without the guard)", nm_hand_chain, "nm-builtin", "nm-sg",
         for_scale=True),
    Part("part-bump-inverted", "the Bump node inverted (Dot, Divide, Multiply Add) and "
         "Bump Scale", bump_inverted, "bump-builtin", "bump-sg"),
    Part("part-bump-resolve", RESOLVE, bump_resolve, "bump-builtin", "bump-sg"),
    Part("part-tri-lookups", "SG Triplanar Coordinates and three image lookups, beyond one "
         "lookup on the UV map", tri_lookups, "part-lookup-uv", "tri-sg"),
    Part("part-tri-group", "SG Triplanar: Listing 14's weights, Listing 2 per plane times "
         "its weight, Listing 13", tri_group, "part-tri-lookups", "tri-sg"),
    Part("part-tri-weights", "of which Listing 14's weights alone (not a part)", tri_weights,
         "none", "tri-sg", for_scale=True),
    Part("part-tri-resolve", RESOLVE, nm_resolve, "nm-builtin", "tri-sg"),
    Part("tri-builtin", "less the twin's Box lookup and Normal Map node beyond one lookup on "
         "the UV map", None, "part-lookup-uv", "tri-sg", sign=-1),
    Part("part-uv2-gradients", "the UV gradients (two inverted Bump nodes, six UV "
         "evaluations)", uv2_gradients, "none", "uv2-sg"),
    Part("part-uv2-basis", "Listing 4 on the gradients", uv2_basis, "part-uv2-gradients",
         "uv2-sg"),
    Part("part-uv2-tangent-normal", "Listings 2 and 3 (SG Tangent Normal) on the lookup",
         uv2_tangent_normal, "part-lookup-detail", "uv2-sg"),
    Part("part-uv2-resolve", RESOLVE, uv2_resolve, "uv2-builtin", "uv2-sg"),
    Part("uv2-builtin", TWIN_NM, None, "part-lookup-detail", "uv2-sg", sign=-1),
]

BASES = [("part-lookup-uv", "one Image Texture on the UV map", lookup_uv),
         ("part-lookup-detail", "one Image Texture on the Detail map", lookup_detail)]


def cases():
    """The parts and their bases as bench-render cases (key, label, build, twin, ...) for the
    counting child."""
    return [(p.key, p.label, p.build, None, None, None) for p in PARTS if p.build] + \
        [(key, label, build, None, None, None) for key, label, build in BASES]


def keys():
    """Every key the parts table needs: the parts, their bases, the whole materials and their
    twins."""
    twins = {c[0]: c[3] for c in M.CASES}
    out = []
    for p in PARTS:
        for k in (p.base, p.whole, twins.get(p.whole), p.key):
            if k and k not in out:
                out.append(k)
    return out


def rows(now):
    """Per whole material: its overhead above the twin, each part's cost, and the remainder
    (the overhead less the parts; a part "for scale" is not taken off)."""
    twins = {c[0]: c[3] for c in M.CASES}
    labels = {c[0]: c[1] for c in M.CASES}
    out = []
    for whole in dict.fromkeys(p.whole for p in PARTS):
        overhead = now[whole] - now[twins[whole]]
        parts, summed = [], 0
        for p in (p for p in PARTS if p.whole == whole):
            cost = p.sign * (now[p.key] - now[p.base])
            parts.append({"key": p.key, "label": p.label, "instructions": cost,
                          "share": cost / overhead if overhead else None,
                          "for_scale": p.for_scale})
            summed += 0 if p.for_scale else cost
        out.append({"key": whole, "label": labels[whole], "twin": twins[whole],
                    "overhead": overhead, "parts": parts, "remainder": overhead - summed})
    return out


def build_materials():
    """In svm_counts' child: every material keys() names, each named by its key."""
    ctx = M.images(normal_size=16, height_size=16)      # the counts do not depend on the size
    found = {c[0]: c[2] for c in M.cases() + cases()}
    for key in keys():
        M.material(key, found[key], ctx)
