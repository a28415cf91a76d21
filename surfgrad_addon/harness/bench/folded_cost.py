"""What each SG material runs at a shading sample after Cycles' constant folding, against its
built-in twin: Cycles' own SVM count (svm_counts.py), deterministic where render times are not.

Every bench-render material is counted, and beside it its options one at a time (DirectX on,
a Strength other than 1, an input linked instead of left at its default, each decal shape and
blend method, the noise's octaves and turbulence, Precise Far From Origin): an option left at
its default should cost nothing, so the count of "option off" is the count of the material
without that route (tests/test_render_cost_folding.py builds the groups without it to check).
The counts are in the running line's unit (int4 records up to 5.1, 32-bit words from 5.2):
compare within a line.
"""

from ...addon import groups as G
from ...addon.enum_input import set_choice
from ...addon.node_vocabulary import Math, VMath
from ...reference.decals import DECAL_SHAPES
from ...reference.socket_specs import PRECISE_FAR
from . import render_materials as M
from . import svm_counts as S

# A value for a group input that stands for "linked": a per-sample input of the same kind.
LINKED = "linked"
_LINKS = {"Normal": ("ShaderNodeNewGeometry", "Normal"),
          "Position": ("ShaderNodeNewGeometry", "Position"),
          "Vector": ("ShaderNodeTexCoord", "Object"),
          "Decal Coordinates": ("ShaderNodeTexCoord", "Object")}


def _settle(g, node, settings):
    """Set the group node's inputs: a constant, or LINKED (a per-sample value linked in)."""
    for name, value in settings.items():
        if value == LINKED:
            kind, output = _LINKS[name]
            g.link(g.node(kind).outputs[output], node.inputs[name])
        elif node.inputs[name].type == "MENU":
            set_choice(node.inputs[name], value)       # an item index, as on the integer lines
        else:
            node.inputs[name].default_value = value


def _material(layer, up=None, **opts):
    """A build: layer(g, ctx, up) makes the SG group node whose first output is resolved, with
    `up` set on the group that feeds it (coordinates, projector, noise); `opts` on the node."""
    def build(g, ctx):
        node = layer(g, ctx, up or {})
        _settle(g, node, opts)
        return g.resolve(node.outputs[0])
    return build


def _nm(g, ctx, up):
    return g.group(G.normal_map_group(), Color=g.image(ctx["normal"], g.uv("UVMap")))


def _bump(g, ctx, up):
    return g.group(G.height_map_forward_group(), Height=M.noise_texture(g),
                   Bump_Scale=M.BUMP_DISTANCE)


def _tri(g, ctx, up):
    coords = g.group(G.triplanar_coordinates_group())
    _settle(g, coords, up)
    tri = g.group(G.triplanar_group())
    for axis in "XYZ":
        g.link(g.image(ctx["normal"], coords.outputs[f"UV {axis}"]), tri.inputs[f"Color {axis}"])
    return tri


def _uv2(g, ctx, up):
    uv = g.uv("Detail")
    basis = g.group(G.procedural_basis_group("Detail"))
    return g.group(G.tangent_normal_group(), Color=g.image(ctx["normal"], uv),
                   Tangent=basis.outputs["Tangent"], Bitangent=basis.outputs["Bitangent"])


def _uv2_linked(g, ctx, up):
    """bench-render's uv2-sg as it was: the generic SG Procedural Basis, a UV Map node linked
    into its UV (the choice of map stays in each Bump evaluation of the UV gradients)."""
    uv = g.uv("Detail")
    basis = g.group(G.procedural_basis_group(), UV=uv)
    return g.group(G.tangent_normal_group(), Color=g.image(ctx["normal"], uv),
                   Tangent=basis.outputs["Tangent"], Bitangent=basis.outputs["Bitangent"])


def _decal(g, ctx, up):
    proj = g.group(G.projector_coordinates_group())
    _settle(g, proj, up)
    q = proj.outputs["Decal Coordinates"]
    uv = g.group(G.decal_coordinates_group(), Decal_Coordinates=q).outputs["Decal UV"]
    return g.group(G.decal_group(), Decal_Coordinates=q, Color=g.image(ctx["normal"], uv))


def _decal_builtin(g, ctx):
    """The usual decal by projection, built-in nodes only: the Image Texture at the projector's
    Object coordinates (the box [-1, 1]^3 onto UV [0, 1]^2) mixed over the flat normal colour
    by the box's mask (max |coordinate| < 1), through a tangent-space Normal Map node."""
    q = g.node("ShaderNodeTexCoord").outputs["Object"]
    x, y, z = g.separate(g.vmath(VMath.ABSOLUTE, q))
    inside = g.math(Math.LESS_THAN, g.math(Math.MAXIMUM, g.math(Math.MAXIMUM, x, y), z), 1.0)
    uv = g.vmath(VMath.MULTIPLY_ADD, q, (0.5, 0.5, 0.5), (0.5, 0.5, 0.5))
    color = g.mix_vector(inside, (0.5, 0.5, 1.0), g.image(ctx["normal"], uv))
    return g.normal_map(color, "TANGENT", uv_map="UVMap")


def _blend(g, ctx, up):
    """Two normal maps (on the two UV maps, so Cycles cannot merge them) through SG Blend
    Normals (`up` on it) into SG Normal Map."""
    blend = g.group(G.blend_normals_group(), Color_A=g.image(ctx["normal"], g.uv("UVMap")),
                    Color_B=g.image(ctx["normal"], g.uv("Detail")))
    _settle(g, blend, up)
    return g.group(G.normal_map_group(), Color=blend.outputs["Color"])


def _noise(g, ctx, up):
    noise = g.group(G.noise_group())
    _settle(g, noise, up)
    return g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"])


PRECISE = PRECISE_FAR.name
_PROJECTED = {"Decal Coordinates": LINKED}       # as the Add Decal Projector operator links it
# (key, label, layer, settings of the feeding group, settings of the layer's node, the key it
# is compared with): options against their material at the defaults.
_OPTIONS = [
    ("nm-sg:directx", "SG Normal Map, DirectX on", _nm, {}, {"DirectX": True}, "nm-sg"),
    ("nm-sg:strength", "SG Normal Map, Strength 0.5", _nm, {}, {"Strength": 0.5}, "nm-sg"),
    ("nm-sg:normal", "SG Normal Map, Normal linked", _nm, {}, {"Normal": LINKED}, "nm-sg"),
    ("bump-sg:normal", "SG Height Map Forward, Normal linked", _bump, {}, {"Normal": LINKED},
     "bump-sg"),
    ("tri-sg:directx", "SG Triplanar, DirectX on", _tri, {}, {"DirectX": True}, "tri-sg"),
    ("tri-sg:strength", "SG Triplanar, Strength 0.5", _tri, {}, {"Strength": 0.5}, "tri-sg"),
    ("tri-sg:position", "SG Triplanar, Position linked", _tri, {"Position": LINKED}, {},
     "tri-sg"),
    ("tri-sg:precise", "SG Triplanar, Precise Far From Origin on", _tri, {PRECISE: True}, {},
     "tri-sg"),
    ("uv2-sg:linked", "SG Procedural Basis (generic, UV Map node linked) + SG Tangent Normal",
     _uv2_linked, {}, {}, "uv2-sg"),
    ("uv2-sg:directx", "SG Tangent Normal, DirectX on", _uv2, {}, {"DirectX": True}, "uv2-sg"),
    ("uv2-sg:strength", "SG Tangent Normal, Strength 0.5", _uv2, {}, {"Strength": 0.5},
     "uv2-sg"),
    ("decal", "Texture Coordinate -> SG Projector + Decal Coordinates -> SG Decal (box)", _decal,
     _PROJECTED, {}, "decal-builtin"),
    ("decal:precise", "SG Decal, Precise Far From Origin on", _decal,
     {**_PROJECTED, PRECISE: True}, {}, "decal"),
    *[(f"decal:shape{k}", f"SG Decal, Shape {k} ({DECAL_SHAPES[k]})", _decal, _PROJECTED,
       {"Shape": k}, "decal") for k in range(1, len(DECAL_SHAPES))],
    ("decal:overwrite", "SG Decal, Overwrite on", _decal, _PROJECTED, {"Overwrite": True},
     "decal"),
    ("blend", "SG Blend Normals (PD) -> SG Normal Map", _blend, {}, {}, None),
    *[(f"blend:method{k}", f"SG Blend Normals, Method {k} ({name})", _blend, {"Method": k}, {},
       "blend") for k, name in ((1, "whiteout"), (2, "UDN"), (3, "RNM"))],
    ("noise", "SG Noise (4 octaves) -> SG Volume Gradient", _noise, {}, {}, None),
    *[(f"noise:octaves{k}", f"SG Noise, {k} octave{'s' * (k > 1)}", _noise, {"Octaves": k}, {},
       "noise") for k in (1, 2, 3)],
    ("noise:turbulence", "SG Noise, Turbulence on", _noise, {"Turbulence": True}, {}, "noise"),
    ("noise:world", "SG Noise, Object Space off", _noise, {"Object Space": False}, {}, "noise"),
    ("noise:vector", "SG Noise, Vector linked", _noise, {"Vector": LINKED}, {}, "noise"),
    ("noise:precise", "SG Noise, Precise Far From Origin on", _noise, {PRECISE: True}, {},
     "noise"),
]
# Built-in twins of SG layers bench-render has no case for: (key, label, build, None).
TWINS = [("decal-builtin", "Texture Coordinate (Object) -> box mask (Separate XYZ, Math) -> "
          "Mix over flat -> Normal Map node", _decal_builtin, None)]
OPTIONS = [(key, label, _material(layer, up, **opts), against)
           for key, label, layer, up, opts, against in _OPTIONS]
STACKS = [(f"layers{k}-{side}", f"{k} normal-map layer{'s' * (k > 1)} ({side})",
           (M.layers_sg if side == "sg" else M.layers_builtin)(k),
           f"layers{k}-builtin" if side == "sg" else None)
          for k in (1, 4) for side in ("builtin", "sg")]


def materials():
    """[(key, label, build, compared with)]: bench-render's cases, the twins bench-render
    lacks, the options, the stacks."""
    base = [(key, label, build, twin) for key, label, build, twin, *_ in M.cases()]
    return base + TWINS + OPTIONS + STACKS


def build_materials():
    """In svm_counts' child: one material per entry of materials(), named by its key."""
    ctx = M.images(normal_size=16, height_size=16)      # the counts do not depend on the size
    for key, _, build, _ in materials():
        M.material(key, build, ctx)


def counts(python=None):
    """[{key, label, svm, unit, against, ratio}] on the line of `python` (this one by default):
    `ratio` is svm over the compared material's svm."""
    found = S.svm_counts([key for key, *_ in materials()], python=python,
                         build="surfgrad_addon.harness.bench.folded_cost:build_materials")
    rows = []
    for key, label, _, against in materials():
        row = {"key": key, "label": label, "svm": found[key].nodes, "unit": found[key].unit}
        if against:
            row["against"] = against
            row["ratio"] = found[key].nodes / found[against].nodes
        rows.append(row)
    return rows


def markdown(rows, blender=""):
    unit = rows[0]["unit"] if rows else ""
    on = f" (Blender {blender})" if blender else ""
    lines = [f"SVM program size after Cycles' constant folding{on}, in {unit} units (compare "
             f"within a line)", "",
             "| material | SVM | against | ratio |", "|---|---|---|---|"]
    for r in rows:
        ratio = f"{r['ratio']:.3f}x" if "ratio" in r else ""
        lines.append(f"| {r['label']} | {r['svm']} | {r.get('against', '')} | {ratio} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    # python -m surfgrad_addon.harness.bench.folded_cost [out.json]: the table on this line.
    import json
    import sys

    import bpy
    table = counts()
    print(markdown(table, bpy.app.version_string))
    if sys.argv[1:]:
        with open(sys.argv[1], "w") as f:
            json.dump({"blender": bpy.app.version_string, "rows": table}, f, indent=1)
