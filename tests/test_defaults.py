"""Defaults an artist can use: every group, wired the usual way and otherwise left at its
defaults, gives a moderate, visible tilt on a unit sphere (2 to 30 degrees on average), and an
unlinked UV input is the active render UV map, as in Blender's own texture nodes. Measured by
bakes: the baked normal against the baked shading normal."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.harness import bake, compare, scenes as test_scenes  # noqa: E402
from surfgrad_addon.reference import images as T  # noqa: E402
from surfgrad_addon.reference.image_sampling import texel_centres  # noqa: E402

pytestmark = pytest.mark.tier("bake")


RES = 48


@pytest.fixture(scope="module")
def sphere():
    obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    # The sphere's UV map is its active render map, and the only one the image nodes see.
    obj.data.uv_layers.active_index = 0
    normal = compare.bpy_float_image("defaults normal", _moderate_normal_map(256))
    height = compare.bpy_float_image("defaults height",
                                     T.hemisphere_tile_height_image(256)[..., None]
                                     .repeat(3, -1))
    return obj, normal, height


def _moderate_normal_map(size):
    """A typical artist's tangent-space map: the wave height's normals at a relief of 4 cm per
    unit of height, about 10 degrees of tilt on average (the hemisphere tiles reach 90)."""
    _, deriv = T.wave_height(texel_centres(size, size))
    m = np.concatenate([-0.04 * deriv, np.ones(deriv.shape[:-1] + (1,))], axis=-1)
    return 0.5 + 0.5 * m / np.linalg.norm(m, axis=-1, keepdims=True)


def _tex(nodes, links, image, vector=None):
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = image
    if vector is not None:
        links.new(vector, tex.inputs["Vector"])
    return tex.outputs["Color"]


def _group(nodes, tree):
    node = nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    return node


def _resolve(nodes, links, sg):
    res = _group(nodes, G.resolve_group())
    links.new(sg, res.inputs["Surface Gradient"])
    return res.outputs[0]


# Each: group name -> graph(nodes, links, normal image, height image) -> resolved normal, the
# group at its defaults, its inputs wired the way the Add menu and README show.
def _normal_map(nodes, links, nm, h):
    node = _group(nodes, G.normal_map_group())
    links.new(_tex(nodes, links, nm), node.inputs["Color"])
    return _resolve(nodes, links, node.outputs[0])


def _tangent_normal(nodes, links, nm, h):
    basis = _group(nodes, G.procedural_basis_group())           # UV unlinked: active map
    node = _group(nodes, G.tangent_normal_group())
    links.new(_tex(nodes, links, nm), node.inputs["Color"])
    links.new(basis.outputs["Tangent"], node.inputs["Tangent"])
    links.new(basis.outputs["Bitangent"], node.inputs["Bitangent"])
    return _resolve(nodes, links, node.outputs[0])


def _blend_normals(nodes, links, nm, h):
    blend = _group(nodes, G.blend_normals_group())
    links.new(_tex(nodes, links, nm), blend.inputs["Color A"])
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (2.0, 2.0, 1.0)
    uv = nodes.new("ShaderNodeUVMap")
    links.new(uv.outputs[0], mapping.inputs[0])
    links.new(_tex(nodes, links, nm, mapping.outputs[0]), blend.inputs["Color B"])
    node = _group(nodes, G.normal_map_group())
    links.new(blend.outputs[0], node.inputs["Color"])
    return _resolve(nodes, links, node.outputs[0])


def _object_normal(nodes, links, nm, h):
    # An object-space map: Blender's Normal Map node in Object space, the usual source.
    onm = nodes.new("ShaderNodeNormalMap")
    onm.space = "OBJECT"
    geo = nodes.new("ShaderNodeNewGeometry")
    tangent_space = _tex(nodes, links, nm)
    # object-space colour = 0.5 + 0.5 (n + (2c - 1) * 0.5): the tile's bend around the normal
    mix = nodes.new("ShaderNodeVectorMath")
    mix.operation = "MULTIPLY_ADD"
    links.new(tangent_space, mix.inputs[0])
    mix.inputs[1].default_value = (0.5, 0.5, 0.0)
    links.new(geo.outputs["Normal"], mix.inputs[2])
    half = nodes.new("ShaderNodeVectorMath")
    half.operation = "MULTIPLY_ADD"
    links.new(mix.outputs[0], half.inputs[0])
    half.inputs[1].default_value = (0.5, 0.5, 0.5)
    half.inputs[2].default_value = (0.25, 0.25, 0.5)
    links.new(half.outputs[0], onm.inputs["Color"])
    node = _group(nodes, G.object_normal_group())
    links.new(onm.outputs[0], node.inputs["Perturbed Normal"])
    return _resolve(nodes, links, node.outputs[0])


def _noise(nodes, links, nm, h):
    noise = _group(nodes, G.noise_group())
    node = _group(nodes, G.volume_gradient_group())
    links.new(noise.outputs["Gradient"], node.inputs["Gradient"])
    return _resolve(nodes, links, node.outputs[0])


def _triplanar(nodes, links, nm, h):
    coords = _group(nodes, G.triplanar_coordinates_group())
    node = _group(nodes, G.triplanar_group())
    for axis in "XYZ":
        links.new(_tex(nodes, links, nm, coords.outputs[f"UV {axis}"]),
                  node.inputs[f"Color {axis}"])
    return _resolve(nodes, links, node.outputs[0])


def _height_hq(nodes, links, nm, h):
    node = _group(nodes, G.height_map_group(h))                # UV unlinked: active map
    return _resolve(nodes, links, node.outputs[0])


def _height_forward(nodes, links, nm, h):
    node = _group(nodes, G.height_map_forward_group())
    sep = nodes.new("ShaderNodeSeparateXYZ")
    links.new(_tex(nodes, links, h), sep.inputs[0])
    links.new(sep.outputs[0], node.inputs["Height"])
    return _resolve(nodes, links, node.outputs[0])


def _triplanar_height(nodes, links, nm, h):
    node = _group(nodes, G.triplanar_height_group(h))
    return _resolve(nodes, links, node.outputs[0])


def _parallax_then_normal_map(nodes, links, nm, h):
    par = _group(nodes, G.parallax_group(h))                   # UV unlinked: active map
    node = _group(nodes, G.normal_map_group())
    links.new(_tex(nodes, links, nm, par.outputs["UV"]), node.inputs["Color"])
    return _resolve(nodes, links, node.outputs[0])


def _decal(nodes, links, nm, h):
    empty, decal = O.add_decal_projector(bpy.context, nodes.id_data, nm)
    _decal.empties.append(empty)
    return _resolve(nodes, links, decal.outputs[0])


_decal.empties = []


def _sampler(builder):
    """A Sampler group (5.0+) with only its Sampler zone and the image size set, as the Add menu
    leaves it."""
    def chain(nodes, links, nm, h):
        from surfgrad_addon.harness.method_graphs.samplers import sampler_socket
        image = nm if builder is G.triplanar_sampler_group else h
        node = _group(nodes, builder())
        links.new(sampler_socket(nodes, links, image), node.inputs["Sampler"])
        if "Image Width" in node.inputs:
            node.inputs["Image Width"].default_value, node.inputs["Image Height"].default_value \
                = image.size
        if builder is G.parallax_sampler_group:
            nmap = _group(nodes, G.normal_map_group())
            links.new(_tex(nodes, links, nm, node.outputs["UV"]), nmap.inputs["Color"])
            return _resolve(nodes, links, nmap.outputs[0])
        return _resolve(nodes, links, node.outputs[0])
    return chain

CHAINS = {
    "SG Normal Map": _normal_map,
    "SG Tangent Normal + SG Procedural Basis": _tangent_normal,
    "SG Blend Normals": _blend_normals,
    "SG Object Normal": _object_normal,
    "SG Noise + SG Volume Gradient": _noise,
    "SG Triplanar + Coordinates": _triplanar,
    "SG Height Map HQ": _height_hq,
    "SG Height Map Forward": _height_forward,
    "SG Triplanar Height": _triplanar_height,
    "SG Parallax": _parallax_then_normal_map,
    "SG Decal + Coordinates": _decal,
}
if G.unavailable_reason("SG Parallax (Sampler)") is None:          # Blender 5.0+
    CHAINS.update({"SG Height Map HQ (Sampler)": _sampler(G.height_map_sampler_group),
                   "SG Triplanar (Sampler)": _sampler(G.triplanar_sampler_group),
                   "SG Triplanar Height (Sampler)": _sampler(G.triplanar_height_sampler_group),
                   "SG Parallax (Sampler)": _sampler(G.parallax_sampler_group)})


def _tilt(obj, chain, nm, h):
    def base(nodes, links):
        return nodes.new("ShaderNodeNewGeometry").outputs["Normal"]

    def build(nodes, links):
        return chain(nodes, links, nm, h)
    try:
        px, cov, _ = bake.bake_vector(obj, build, RES, RES, "UVMap")
        ref, cov0, _ = bake.bake_vector(obj, base, RES, RES, "UVMap")
    finally:
        for empty in _decal.empties:
            bpy.data.objects.remove(empty)
        _decal.empties.clear()
    both = cov & cov0
    return compare.angle_deg(px[both], ref[both]), np.isfinite(px[both]).all()


@pytest.mark.parametrize("name", list(CHAINS))
def test_defaults_give_a_moderate_visible_tilt(sphere, name):
    obj, nm, h = sphere
    tilt, finite = _tilt(obj, CHAINS[name], nm, h)
    print(f"{name}: mean tilt {tilt.mean():.2f} deg, p99 {np.percentile(tilt, 99):.2f}")
    assert finite
    assert 2.0 <= tilt.mean() <= 30.0, (name, tilt.mean())


@pytest.mark.parametrize("builder,uv_socket", [
    (lambda h: G.height_map_group(h), "UV"),
    (lambda h: G.parallax_group(h), "UV"),
    (lambda h: G.procedural_basis_group(), "UV")])
def test_an_unlinked_uv_is_the_active_render_uv_map(sphere, builder, uv_socket):
    """Linked to a UV Map node naming the active map, or left unlinked: the same bake."""
    obj, nm, h = sphere
    results = []
    for linked in (True, False):
        def build(nodes, links, linked=linked):
            node = _group(nodes, builder(h))
            if linked:
                uv = nodes.new("ShaderNodeUVMap")
                uv.uv_map = "UVMap"
                links.new(uv.outputs[0], node.inputs[uv_socket])
            out = node.outputs[0]
            if out.name in ("Tangent", "UV"):
                return out
            return _resolve(nodes, links, out)
        px, cov, _ = bake.bake_vector(obj, build, RES, RES, "UVMap")
        results.append(px[cov])
    linked_px, unlinked_px = results
    assert np.abs(linked_px - unlinked_px).max() <= 1e-6
    # ... and not because both are flat or zero: the output varies over the sphere.
    assert np.ptp(linked_px, axis=0).max() > 0.1
