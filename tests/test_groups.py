"""Building the node groups: idempotent, versioned without breaking links, tidy; and SG Noise's
value equal to the reference noise."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import reference as R  # noqa: E402
from surfgrad_addon.addon import groups as G
from surfgrad_addon.harness import bake, scenes as test_scenes  # noqa: E402
from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def test_building_twice_gives_one_group_each(fresh):
    G.build_all()
    names = sorted(g.name for g in bpy.data.node_groups)
    G.build_all()
    assert sorted(g.name for g in bpy.data.node_groups) == names
    assert all(not name.endswith(".001") for name in names)
    menu = [n for n, _ in G.MENU_GROUPS if G.unavailable_reason(n) is None]
    assert set(menu) <= set(names)
    hidden = [n for n in names if n not in menu]
    assert hidden and all(n.startswith(".") for n in hidden)


def test_a_newer_version_rebuilds_in_place_and_keeps_links(fresh, monkeypatch):
    tree = G.resolve_group()
    mat = new_material("User")
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    group = nodes.new("ShaderNodeGroup")
    group.node_tree = tree
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    geo = nodes.new("ShaderNodeNewGeometry")
    links.new(group.outputs["Normal"], bsdf.inputs["Normal"])
    links.new(geo.outputs["Normal"], group.inputs["Surface Gradient"])
    ptr = tree.as_pointer()
    nodes_before = len(tree.nodes)
    monkeypatch.setattr(G.common, "VERSION", G.VERSION + 1)   # every builder reads it there
    tree.nodes.new("ShaderNodeMath")            # a stray edit the rebuild must clear
    rebuilt = G.resolve_group()
    assert rebuilt.as_pointer() == ptr and rebuilt["surfgrad_version"] == G.common.VERSION
    assert len(rebuilt.nodes) == nodes_before
    assert bsdf.inputs["Normal"].is_linked and group.inputs["Surface Gradient"].is_linked
    assert all(link.is_valid for link in links)


def test_every_group_is_documented_with_frames(fresh):
    for name, tree in G.build_all().items():
        assert tree.description, name
        for item in tree.interface.items_tree:
            if item.item_type == "SOCKET":
                assert item.description, (name, item.name)
        assert any(n.bl_idname == "NodeFrame" and n.label for n in tree.nodes), name


def test_a_builder_uses_exactly_its_declared_sockets(fresh):
    """A group's sockets come from its GroupInterface: a builder that asks for a socket the
    interface lacks, or of another type, or leaves one unused, is refused."""
    from surfgrad_addon.addon.node_builder import BuildError, ensure_group, interface_signature
    from surfgrad_addon.reference import socket_specs as S
    from surfgrad_addon.reference.group_interfaces import GroupInterface, signature_row
    iface = GroupInterface("A test group", (S.SURFACE_GRADIENT_OUT,), (S.NORMAL, S.BUMP_SCALE))

    def undeclared(b):
        b.input(S.STRENGTH)

    def wrong_type(b):
        b.input(S.NORMAL_COLOR.but(name="Normal"))

    def unused(b):
        b.output(S.SURFACE_GRADIENT_OUT, b.scale(b.input(S.NORMAL), 2.0))

    def complete(b):
        b.output(S.SURFACE_GRADIENT_OUT, b.scale(b.input(S.NORMAL), b.input(S.BUMP_SCALE)))
    for name, build, message in ((".SG Test 1", undeclared, "not in the group's declared"),
                                 (".SG Test 2", wrong_type, "declared as a VECTOR"),
                                 (".SG Test 3", unused, "never used")):
        with pytest.raises(BuildError, match=message):
            ensure_group(name, 1, build, interface=iface)
    tree = ensure_group(".SG Test 4", 1, complete, interface=iface)
    assert interface_signature(tree) == {
        "description": "A test group",
        "sockets": [signature_row(S.SURFACE_GRADIENT_OUT, "OUTPUT"),
                    signature_row(S.NORMAL, "INPUT"), signature_row(S.BUMP_SCALE, "INPUT")]}
    assert [s["max_value"] for s in interface_signature(tree)["sockets"]][-1] == 1000.0


@pytest.mark.tier("bake")
def test_sg_noise_value_and_gradient_equal_the_reference(fresh):
    """SG Noise's Value (baked through the emission's red channel) and Gradient, against
    reference.fractal_sum on the object coordinates: to float32 precision."""
    obj = test_scenes.build(["Transformed"])["Transformed"]
    res, scale = 48, 4.0

    def graph(output):
        def build(nodes, links):
            noise = nodes.new("ShaderNodeGroup")
            noise.node_tree = G.noise_group()
            noise.inputs["Scale"].default_value = scale
            if output == "Value":
                comb = nodes.new("ShaderNodeCombineXYZ")
                links.new(noise.outputs["Value"], comb.inputs[0])
                return comb.outputs[0]
            return noise.outputs["Gradient"]
        return build
    value_px, cov, _ = bake.bake_vector(obj, graph("Value"), res, res, "UVMap")
    grad_px, _, _ = bake.bake_vector(obj, graph("Gradient"), res, res, "UVMap")
    td = R.rasterize(mesh_arrays_from_object(obj), "UVMap", res, res)
    inside = cov[td.pixel[:, 1], td.pixel[:, 0]]
    h, g = R.fractal_sum(td.position_object * scale, octaves=4)
    g_world = (scale * g) @ td.mesh.normal_matrix.T
    got_v = value_px[td.pixel[:, 1], td.pixel[:, 0], 0][inside]
    got_g = grad_px[td.pixel[:, 1], td.pixel[:, 0]][inside]
    assert np.ptp(h[inside]) > 0.5                     # the noise really varies
    np.testing.assert_allclose(got_v, h[inside], atol=2e-5)
    np.testing.assert_allclose(got_g, g_world[inside], rtol=1e-4,
                               atol=2e-4 * np.abs(g_world).max())


def test_image_bound_groups_take_the_active_image_texture(fresh):
    from surfgrad_addon.addon import ui
    mat = new_material("M")
    tree = mat.node_tree
    img = bpy.data.images.new("rock_height", 8, 4, float_buffer=True)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    tree.nodes.active = tex
    node = ui.add_group_node(tree, "SG Height Map HQ")
    taps = [n for n in node.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage"]
    assert node.node_tree.name == "SG Height Map HQ [rock_height]"
    assert len(taps) == 16 and all(t.image == img for t in taps)
    assert ui.image_bound("SG Parallax") and not ui.image_bound("SG Resolve")


@pytest.mark.tier("bake")
def test_triplanar_height_with_three_images_matches_the_reference(fresh):
    """SG Triplanar Height with a different height image per plane, baked, against the
    reference (the single-image case is in the bake comparison suite)."""
    from surfgrad_addon.harness import compare
    from surfgrad_addon.reference import methods as M
    obj = test_scenes.build(["Sphere"])["Sphere"]
    heights = [R.images.wave_height_image(size, freq) for size, freq in
               ((32, (3.0, 2.0)), (16, (1.0, 2.0)), (24, (2.0, 1.0)))]
    imgs = [compare.bpy_float_image(f"h{i}", h) for i, h in enumerate(heights)]

    def build(nodes, links):
        node = nodes.new("ShaderNodeGroup")
        node.node_tree = G.triplanar_height_group(images=imgs)
        node.inputs["Bump Scale"].default_value = 0.05
        return compare.resolve_sg(nodes, links, node.outputs["Surface Gradient"])
    px, cov, _ = bake.bake_vector(obj, build, 48, 48, "UVMap")
    td = R.rasterize(mesh_arrays_from_object(obj), "UVMap", 48, 48)
    ref = M.resolve(M.triplanar_height_surfgrad(
        td, [h.astype(np.float32).astype(np.float64) for h in heights], bump_scale=0.05))
    inner = td.interior() & cov[td.pixel[:, 1], td.pixel[:, 0]]
    err = compare.angle_deg(px[td.pixel[:, 1], td.pixel[:, 0]][inner], ref[inner])
    tilt = compare.angle_deg(ref[inner], M.unit_base_normal(td)[inner])
    assert tilt.mean() > 1 and err.max() < 0.05, (tilt.mean(), err.max())
    assert G.triplanar_height_group(images=imgs).name == "SG Triplanar Height [h0 | h1 | h2]"


def test_a_users_group_with_our_name_is_never_rebuilt_over(fresh):
    """A node group the user made and happened to call "SG Combine" is refused, not cleared:
    ours are recognised by their version stamp."""
    mine = bpy.data.node_groups.new("SG Combine", "ShaderNodeTree")
    mine.nodes.new("ShaderNodeMath")
    with pytest.raises(ValueError, match="'SG Combine' already exists and is not a "
                                         "surface-gradient group; rename it"):
        G.combine_group()
    assert len(mine.nodes) == 1 and "surfgrad_version" not in mine
    mine.name = "My Combine"
    ours = G.combine_group()
    assert ours.name == "SG Combine" and ours != mine and len(mine.nodes) == 1
