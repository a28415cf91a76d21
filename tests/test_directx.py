"""The DirectX/OpenGL switch of every group that decodes a tangent-space colour (SG Normal Map,
SG Tangent Normal, SG Triplanar, SG Decal): a DirectX map (green flipped) with DirectX on bakes
exactly like the same map in OpenGL convention with it off, on every line. From 5.2, Blender's
own Normal Map node set to DirectX agrees with SG Normal Map set to DirectX."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import reference as R  # noqa: E402
from surfgrad_addon.addon import groups as G
from surfgrad_addon.harness import bake, compare as C, scenes as test_scenes  # noqa: E402
from surfgrad_addon.harness.graph import Graph, surface_gradient  # noqa: E402
from surfgrad_addon.harness.method_graphs.images import normal_map_graph  # noqa: E402
from surfgrad_addon.harness.method_graphs.projection import decal_graph, triplanar_graph  # noqa: E402,E501
from surfgrad_addon.harness.method_scene import decal_projector  # noqa: E402
from surfgrad_addon.reference import methods as M  # noqa: E402

pytestmark = pytest.mark.tier("bake")


RES = 48


@pytest.fixture(scope="module")
def inputs():
    test_scenes.new_scene(["Torus"])
    obj = bpy.data.objects["Torus"]
    inp = C.prepare_inputs(obj)
    px = inp.pixels("normal").copy()
    px[..., 1] = 1.0 - px[..., 1]                      # the same map, DirectX convention
    inp.images["normal_dx"] = (px, C.bpy_float_image("sg_normal_dx", px))
    yield obj, inp
    for _, img in inp.images.values():
        bpy.data.images.remove(img)


def _switched(g, sg, directx):
    """The group node of `sg` with its DirectX switch set, resolved."""
    g.set(sg.node, DirectX=directx)
    return g.resolve(sg)


def _image_graph(graph, inp, image, directx):
    """A builder of `graph` (a harness method graph) on `image`, DirectX set."""
    def build(nodes, links):
        g = Graph(nodes, links)
        return _switched(g, graph(inp, g, image=image), directx)
    return build


def _normal_map(inp, image, directx):
    return _image_graph(normal_map_graph, inp, image, directx)


def _triplanar(inp, image, directx):
    return _image_graph(triplanar_graph, inp, image, directx)


def _tangent_normal(inp, image, directx):
    def build(nodes, links):
        g = Graph(nodes, links)
        uv = g.uv(inp.uv_map)
        basis = g.group(G.procedural_basis_group(), UV=uv)
        node = g.group(G.tangent_normal_group(), Color=g.image(inp.bpy_image(image), uv),
                       Tangent=basis.outputs["Tangent"], Bitangent=basis.outputs["Bitangent"])
        return _switched(g, surface_gradient(node), directx)
    return build


def _decal(inp, image, directx):
    def build(nodes, links):
        g = Graph(nodes, links)
        saved = inp.images["normal"]
        inp.images["normal"] = inp.images[image]
        try:
            sg = decal_graph(inp, g)
        finally:
            inp.images["normal"] = saved
        return _switched(g, sg, directx)
    return build


def _bake(obj, inp, build):
    px, cov, _ = bake.bake_vector(obj, build, RES, RES, inp.uv_map)
    return px[cov].astype(np.float64)


@pytest.mark.parametrize("graph", [_normal_map, _tangent_normal, _triplanar, _decal])
def test_directx_map_with_switch_equals_opengl_map(inputs, graph):
    obj, inp = inputs
    if graph is _decal:
        inp.projector = decal_projector(obj)
    try:
        opengl = _bake(obj, inp, graph(inp, "normal", False))
        directx = _bake(obj, inp, graph(inp, "normal_dx", True))
        wrong = _bake(obj, inp, graph(inp, "normal_dx", False))
    finally:
        if inp.projector is not None:
            bpy.data.objects.remove(inp.projector)
            inp.projector = None
    err = C.angle_deg(directx, opengl)
    print(f"{graph.__name__}: {len(err)} texels, DirectX vs OpenGL max {err.max():.2e} deg, "
          f"convention ignored max {C.angle_deg(wrong, opengl).max():.1f} deg")
    assert len(err) > 0.5 * RES * RES
    assert err.max() < 1e-3, err.max()                  # same map: float rounding only
    # ... the map really bends the normals, and ignoring the convention is visibly wrong.
    geo = _bake(obj, inp, lambda nodes, links: Graph(nodes, links).geometry("Normal"))
    assert C.angle_deg(opengl, geo).mean() > 3.0
    assert C.angle_deg(wrong, opengl).max() > 10.0


def test_reference_directx_flip(inputs):
    obj, inp = inputs
    from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object
    td = R.rasterize(mesh_arrays_from_object(obj), inp.uv_map, RES, RES,
                     facts=bake.running_line())
    _, a = M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map)
    _, b = M.normal_map_surfgrad(td, inp.pixels("normal_dx"), inp.uv_map, directx=True)
    np.testing.assert_allclose(a, b, atol=1e-6)


@pytest.mark.skipif(not hasattr(bpy.types.ShaderNodeNormalMap, "bl_rna") or
                    "convention" not in bpy.types.ShaderNodeNormalMap.bl_rna.properties,
                    reason="the Normal Map node has a convention from Blender 5.2")
def test_sg_directx_matches_blenders_directx_normal_map_node(inputs):
    obj, inp = inputs

    def blender(nodes, links):
        g = Graph(nodes, links)
        color = g.image(inp.bpy_image("normal_dx"), g.uv(inp.uv_map))
        nm = g.node("ShaderNodeNormalMap", uv_map=inp.uv_map, convention="DIRECTX")
        return g.set(nm, Color=color).outputs["Normal"]
    sg = _bake(obj, inp, _normal_map(inp, "normal_dx", True))
    node = _bake(obj, inp, blender)
    assert C.angle_deg(sg, node).max() < 0.05
    assert C.angle_deg(node, _bake(obj, inp, _normal_map(inp, "normal", False))).max() < 0.05
