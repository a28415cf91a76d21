"""The materials bench-render times and folded_cost counts: each SG material and its built-in
twin (Blender's own nodes for the same job). A build(g, ctx) returns the socket for the BSDF's
Normal (None: unperturbed); ctx holds the two images (a tangent-space normal map, a height map)."""

from ... import reference as R
from ...addon import groups as G
from ...addon.compat import new_material
from ..graph import Graph

BUMP_DISTANCE = 0.05
NOISE_SCALE = 8.0


def noise_texture(g):
    n = g.node("ShaderNodeTexNoise")
    n.inputs["Scale"].default_value = NOISE_SCALE
    return n.outputs["Fac"]


def _nm_builtin(g, ctx, uv_map="UVMap", image=None):
    nm = g.node("ShaderNodeNormalMap", space="TANGENT", uv_map=uv_map)
    g.link(g.image(image or ctx["normal"], g.uv(uv_map)), nm.inputs["Color"])
    return nm.outputs["Normal"]


def _nm_sg_layer(g, ctx, uv_map="UVMap", image=None):
    node = g.group(G.normal_map_group(uv_map), Color=g.image(image or ctx["normal"],
                                                             g.uv(uv_map)))
    return node.outputs["Surface Gradient"]


def _nm_sg(g, ctx):
    return g.resolve(_nm_sg_layer(g, ctx))


def _bump_builtin(g, ctx):
    bump = g.node("ShaderNodeBump")
    bump.inputs["Distance"].default_value = BUMP_DISTANCE
    if "Filter Width" in bump.inputs:
        bump.inputs["Filter Width"].default_value = G.FORWARD_FILTER_WIDTH
    g.link(noise_texture(g), bump.inputs["Height"])
    return bump.outputs["Normal"]


def _bump_sg(g, ctx):
    node = g.group(G.height_map_forward_group(), Height=noise_texture(g),
                   Bump_Scale=BUMP_DISTANCE)
    return g.resolve(node.outputs["Surface Gradient"])


def _tri_builtin(g, ctx):
    tc = g.node("ShaderNodeTexCoord")
    color = g.image(ctx["normal"], tc.outputs["Object"], projection="BOX")
    color.node.projection_blend = 0.25
    nm = g.node("ShaderNodeNormalMap", space="TANGENT", uv_map="UVMap")
    g.link(color, nm.inputs["Color"])
    return nm.outputs["Normal"]


def _tri_sg(g, ctx):
    coords = g.group(G.triplanar_coordinates_group())
    tri = g.group(G.triplanar_group())
    for axis in "XYZ":
        g.link(g.image(ctx["normal"], coords.outputs[f"UV {axis}"]), tri.inputs[f"Color {axis}"])
    return g.resolve(tri.outputs["Surface Gradient"])


def _uv2_builtin(g, ctx):
    return _nm_builtin(g, ctx, "Detail")


def _uv2_sg(g, ctx):
    # The per-map basis, its UV unlinked: the map's choice folds away (folded_cost's
    # "uv2-sg:linked" is the generic group with the UV Map node linked in).
    uv = g.uv("Detail")
    basis = g.group(G.procedural_basis_group("Detail"))
    tn = g.group(G.tangent_normal_group(), Color=g.image(ctx["normal"], uv),
                 Tangent=basis.outputs["Tangent"], Bitangent=basis.outputs["Bitangent"])
    return g.resolve(tn.outputs["Surface Gradient"])


# A stack's layers each read their own image (ctx["layers"]): layers that read the same image
# through the same nodes are one to Cycles, which merges identical nodes, and a stack of them
# would cost about one layer.
def layers_builtin(count):
    def build(g, ctx):
        total = None
        for k in range(count):
            n = _nm_builtin(g, ctx, ("UVMap", "Detail")[k % 2], ctx["layers"][k])
            total = n if total is None else g.add(total, n)
        return g.normalize(total) if count > 1 else total
    return build


def layers_sg(count):
    def build(g, ctx):
        total = None
        for k in range(count):
            sg = _nm_sg_layer(g, ctx, ("UVMap", "Detail")[k % 2], ctx["layers"][k])
            if total is None:
                total = sg
            else:
                comb = g.group(G.combine_group(), A=total, B=sg)
                total = comb.outputs["Surface Gradient"]
        return g.resolve(total)
    return build


# Sampler groups (5.0+) against the per-image groups they stand for: same taps, the image a
# closure evaluated per tap instead of an Image Texture node bound inside the group.
HEIGHT_BUMP = 0.05


def _sampler(g, image):
    from ..method_graphs.samplers import sampler_socket
    return sampler_socket(g.nodes, g.links, image)


def _hq_image(g, ctx):
    node = g.group(G.height_map_group(ctx["height"], "hq"), UV=g.uv("UVMap"),
                   Bump_Scale=HEIGHT_BUMP)
    return g.resolve(node.outputs[0])


def _hq_sampler(g, ctx):
    w, h = ctx["height"].size[:2]
    node = g.group(G.height_map_sampler_group("hq"), UV=g.uv("UVMap"), Bump_Scale=HEIGHT_BUMP,
                   Sampler=_sampler(g, ctx["height"]), Image_Width=w, Image_Height=h)
    return g.resolve(node.outputs[0])


def _tri_sampler(g, ctx):
    node = g.group(G.triplanar_sampler_group(), Sampler=_sampler(g, ctx["normal"]))
    return g.resolve(node.outputs["Surface Gradient"])


def _tri_height_image(g, ctx):
    node = g.group(G.triplanar_height_group(ctx["height"]), Bump_Scale=HEIGHT_BUMP)
    return g.resolve(node.outputs[0])


def _tri_height_sampler(g, ctx):
    w, h = ctx["height"].size[:2]
    node = g.group(G.triplanar_height_sampler_group(), Bump_Scale=HEIGHT_BUMP,
                   Sampler=_sampler(g, ctx["height"]), Image_Width=w, Image_Height=h)
    return g.resolve(node.outputs[0])


def _parallax(sampler):
    def build(g, ctx):
        if sampler:
            par = g.group(G.parallax_sampler_group(), UV=g.uv("UVMap"), Depth=0.1,
                          Sampler=_sampler(g, ctx["height"]))
        else:
            par = g.group(G.parallax_group(ctx["height"]), UV=g.uv("UVMap"), Depth=0.1)
        nm = g.group(G.normal_map_group("UVMap"), Color=g.image(ctx["normal"],
                                                                 par.outputs["UV"]))
        return g.resolve(nm.outputs[0])
    return build


# (key, label, build, twin key, target key, look: "twin" | method name for the reference)
CASES = [
    ("none", "no perturbation", lambda g, ctx: None, None, None, None),
    ("nm-builtin", "Image Texture -> Normal Map node", _nm_builtin, None, None, None),
    ("nm-sg", "Image Texture -> SG Normal Map -> SG Resolve", _nm_sg, "nm-builtin",
     "normal-map", "twin"),
    ("bump-builtin", "Noise -> Bump node", _bump_builtin, None, None, None),
    ("bump-sg", "Noise -> SG Height Map Forward -> SG Resolve", _bump_sg, "bump-builtin",
     "height-forward", "twin"),
    ("tri-builtin", "Box-projected Image Texture -> Normal Map node", _tri_builtin, None, None,
     None),
    ("tri-sg", "3 Image Textures -> SG Triplanar -> SG Resolve", _tri_sg, "tri-builtin",
     "triplanar", "triplanar"),
    ("uv2-builtin", "Normal Map node on a second UV map", _uv2_builtin, None, None, None),
    ("uv2-sg", "SG Procedural Basis [Detail] + SG Tangent Normal on a second UV map", _uv2_sg,
     "uv2-builtin", "second-uv", "procedural-basis"),
    ("layers2-builtin", "2 Normal Map nodes, added", layers_builtin(2), None, None, None),
    ("layers3-builtin", "3 Normal Map nodes, added", layers_builtin(3), None, None, None),
    ("layers2-sg", "2 SG Normal Map -> SG Combine -> SG Resolve", layers_sg(2),
     "layers2-builtin", None, None),
    ("layers3-sg", "3 SG Normal Map -> 2 SG Combine -> SG Resolve", layers_sg(3),
     "layers3-builtin", None, None),
]
# Blender 5.0+: each Sampler group against its per-image group (the twin).
SAMPLER_CASES = [
    ("hq-image", "SG Height Map HQ [image] (per-image)", _hq_image, None, None, None),
    ("hq-sampler", "SG Height Map HQ (Sampler)", _hq_sampler, "hq-image", None, "twin"),
    ("tri-sampler", "SG Triplanar (Sampler), one zone", _tri_sampler, "tri-sg", None, "twin"),
    ("triheight-image", "SG Triplanar Height [image] (per-image)", _tri_height_image, None,
     None, None),
    ("triheight-sampler", "SG Triplanar Height (Sampler)", _tri_height_sampler,
     "triheight-image", None, "twin"),
    ("parallax-image", "SG Parallax [image] (per-image) + SG Normal Map", _parallax(False),
     None, None, None),
    ("parallax-sampler", "SG Parallax (Sampler) + SG Normal Map", _parallax(True),
     "parallax-image", None, "twin"),
]


def cases():
    """The cases this Blender can render: the Sampler ones from 5.0."""
    from ...addon.sampler_zone import has_closures
    return CASES + (SAMPLER_CASES if has_closures() else [])


# Scene ------------------------------------------------------------------------------------------


MAX_LAYERS = 4


def images(normal_size=256, height_size=64):
    """ctx for the builders: the normal-map and height-map images as Blender float images, and
    one normal map per stack layer ("layers": the first is "normal", the others the same
    pattern with a different number of tiles, so each is an image of its own)."""
    from ..compare import bpy_float_image
    normal = bpy_float_image("rc_normal", R.images.hemisphere_tile_image(normal_size))
    layers = [normal] + [bpy_float_image(f"rc_normal_layer{k}", R.images.hemisphere_tile_image(
        normal_size, tiles=4 + k)) for k in range(1, MAX_LAYERS)]
    return {"normal": normal, "layers": layers,
            "height": bpy_float_image("rc_height",
                                      R.images.wave_height_image(height_size, (4.0, 2.0)))}


def material(name, build, ctx):
    """A grey Principled BSDF whose Normal is build(g, ctx) (unlinked where that is None)."""
    mat = new_material(name)
    g = Graph(mat.node_tree.nodes, mat.node_tree.links)
    g.nodes.clear()
    bsdf = g.set(g.node("ShaderNodeBsdfPrincipled"), Base_Color=(0.6, 0.6, 0.6, 1.0),
                 Roughness=0.4)
    g.link(bsdf.outputs[0], g.node("ShaderNodeOutputMaterial").inputs["Surface"])
    normal = build(g, ctx)
    if normal is not None:
        g.link(normal, bsdf.inputs["Normal"])
    return mat

