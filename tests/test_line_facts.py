"""reference.blender_lines against the running Blender: each fact the groups or the reference
read from the line's table agrees with what this Blender has or does (the detailed bakes are in
test_blender_facts.py, test_blender_pins.py and test_render_facts.py; this file ties the table
to them and holds the facts they do not cover)."""

import pytest

bpy = pytest.importorskip("bpy")

from support import facts_probe as fp  # noqa: E402
from surfgrad_addon.addon import compat  # noqa: E402
from surfgrad_addon.reference.blender_lines import LINES, facts_for  # noqa: E402

pytestmark = pytest.mark.tier("blender")


LINE = facts_for(bpy.app.version)


def test_the_running_blender_is_a_supported_line():
    assert LINE.line == f"{bpy.app.version[0]}.{bpy.app.version[1]}"
    assert LINE.line in LINES


@pytest.mark.tier("bake")
def test_api_facts_match_what_this_blender_has():
    tree = bpy.data.node_groups.new(".facts", "ShaderNodeTree")
    try:
        bump = tree.nodes.new("ShaderNodeBump")
        normal_map = tree.nodes.new("ShaderNodeNormalMap")
        assert LINE.bump_filter_width == ("Filter Width" in bump.inputs)
        assert LINE.normal_map_convention == hasattr(normal_map, "convention")
    finally:
        bpy.data.node_groups.remove(tree)
    assert LINE.modifier_properties == \
        ("properties" in bpy.types.NodesModifier.bl_rna.properties)
    engines = [e.identifier for e in
               bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items]
    assert LINE.eevee_engine in engines


def test_menu_sockets_where_the_line_has_them():
    """A shader group takes a Menu socket and a Menu Switch node exactly where the table says
    (5.0 and later); 4.2 and 4.5 refuse the socket type."""
    tree = bpy.data.node_groups.new(".facts menu", "ShaderNodeTree")
    try:
        try:
            tree.interface.new_socket("Choice", in_out="INPUT", socket_type="NodeSocketMenu")
            tree.nodes.new("GeometryNodeMenuSwitch")
            made = True
        except (TypeError, RuntimeError):
            made = False
        assert LINE.menu_sockets == made
    finally:
        bpy.data.node_groups.remove(tree)


def test_new_material_has_a_node_tree_on_every_line():
    raw = bpy.data.materials.new(".raw")
    mat = compat.new_material(".facts")
    try:
        assert (raw.node_tree is not None) == (bpy.app.version >= (5, 0, 0))
        assert mat.node_tree is not None and mat.node_tree.nodes
    finally:
        bpy.data.materials.remove(raw)
        bpy.data.materials.remove(mat)


def test_modifier_inputs_through_compat_on_every_line():
    """Geometry Nodes modifier inputs: ID properties up to 5.0, properties.inputs from 5.1
    (where item assignment raises TypeError); compat reads and writes both."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tree = bpy.data.node_groups.new("Facts GN", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    item = tree.interface.new_socket("Amount", in_out="INPUT", socket_type="NodeSocketFloat")
    gi, go = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    tree.links.new(gi.outputs[0], go.inputs[0])
    mesh = bpy.data.meshes.new("facts")
    obj = bpy.data.objects.new("facts", mesh)
    bpy.context.scene.collection.objects.link(obj)
    mod = obj.modifiers.new("GN", "NODES")
    mod.node_group = tree
    compat.set_input(mod, "Amount", 0.375)
    assert compat.get_input(mod, "Amount") == pytest.approx(0.375)
    if LINE.modifier_properties:
        with pytest.raises(TypeError):
            mod[item.identifier] = 0.5
    else:
        assert mod[item.identifier] == pytest.approx(0.375)
    with pytest.raises(KeyError, match="no input 'Nope'"):
        compat.set_input(mod, "Nope", 1.0)


@pytest.mark.tier("bake")
def test_packed_normals_are_this_lines_storage():
    """The shading normal under a rotated, non-uniformly scaled transform: this line's storage
    model (5.2: object normals packed into 2 x 16-bit octahedral, transformed, packed again;
    earlier: float32) fits to 2e-4 deg; the other storage is 1e-3 deg or more off."""
    base = fp.base
    base.new_scene()
    obj = fp.add_sphere(matrix_world=fp.trs_matrix((0.3, -0.2, 0.5), (30.0, -20.0, 50.0),
                                                   (1.7, 0.6, 1.1)))
    g = fp.Graph(obj)
    td = fp.rasterize(fp.mesh_arrays(obj, ()), "UVMap", 64, 64)
    got = fp.texels(td, g.bake(g.geometry().outputs["Normal"], 64, 64))[:, :3]
    other = LINES["5.0"] if LINE.packed_normals else LINES["5.2"]
    mine = fp.angle_deg(got, fp.shading_normal(td, line=LINE)).max()
    theirs = fp.angle_deg(got, fp.shading_normal(td, line=other)).max()
    assert mine < 2e-4, mine                    # measured 5e-5 (5.2), 8e-5 (earlier)
    assert theirs > 1e-3, theirs                # measured 4.4e-3 / 6.4e-3
    assert td.facts == LINE
