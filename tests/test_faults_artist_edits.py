"""The artist's edits refuse what would be silently lost or wrong (red team 28b), with the file
left as it was:

- A material linked from a library: Python can add nodes to its tree, but the file never saves
  them, so the layer stack, the decal projector (drivers and an empty too), Convert (from a
  Shader Editor showing the linked tree, whose poll lets it run) and Thaw used to edit it and
  report success. The API's add_layer_stack likewise.
- Convert to Surface Gradient on a Bump node whose Filter Width is linked dropped the link
  (the group takes a constant width), and on a muted node made live groups of it: either
  changed the look without a word.
- Freeze of a material another mesh also uses baked one object's UVs into a map the other
  then rendered with; a linked duplicate (the same mesh) is still frozen.
- Freeze packing the map of a material named with a "/" ("Rock/Wet") was refused with a
  missing temporary folder.
- Thaw removed the freeze's nodes by name, also a node of the user's that took the name of
  one the user had deleted.
- A second Sampler group added with the texture of a Sampler zone active linked its UV from
  inside that zone, which invalidated the material's links up to its output.
- The API's node_group raised AttributeError or RuntimeError (not the ValueError it promises)
  for an image given by name, an unknown extension, a uv_map that is not a string or too long,
  and built a group for a NaN or negative filter width; an image by name now works.
- A light's nodes (what the Shader Editor shows in Object mode with a light active) were
  edited like a material's (the decal projector added its empty and chain), unlike the World's.
- A decal projector scaled to zero on an axis divided by zero in its drivers, which Blender
  then stopped evaluating: the decal no longer followed the projector.
"""

import json
import types

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.harness import scenes as test_scenes  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("blender")

LINKED = "linked from a library"


def _tree_state(tree):
    return (sorted(f"{n.name}:{n.bl_idname}" for n in tree.nodes),
            sorted(f"{lk.from_node.name}.{lk.from_socket.identifier}->"
                   f"{lk.to_node.name}.{lk.to_socket.identifier}" for lk in tree.links),
            len(tree.animation_data.drivers) if tree.animation_data else 0)


def _file_state():
    return (sorted(o.name for o in bpy.data.objects),
            sorted(g.name for g in bpy.data.node_groups))


def _linked_back(mat, tmp_path):
    """`mat` written to a library file, removed here and linked back from it."""
    name, path = mat.name, tmp_path / f"{mat.name}.blend"
    bpy.data.libraries.write(str(path), {mat}, fake_user=True)
    bpy.data.materials.remove(mat)
    with bpy.data.libraries.load(str(path), link=True) as (_, into):
        into.materials = [name]
    linked = bpy.data.materials[name]
    assert linked.library is not None
    return linked


@pytest.fixture()
def linked(fresh, tmp_path):
    """A plane whose material (a Normal Map into a Diffuse BSDF, frozen-looking record on
    it) is linked from a library file; returns (plane, material)."""
    mat, tree, bsdf = diffuse_material("Library Material")
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(nmap.outputs[0], bsdf.inputs["Normal"])
    tree.nodes.active = nmap
    mat[F.RECORD] = json.dumps({"image": "x", "image_created": True, "file": "",
                                "links": [], "added": [], "moved": {}, "frame": ""})
    mat = _linked_back(mat, tmp_path)
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(mat)
    plane = bpy.data.objects.new("Plane", mesh)
    bpy.context.scene.collection.objects.link(plane)
    bpy.context.view_layer.objects.active = plane
    return plane, mat


def _refused_unchanged(tree, call, match):
    before, files = _tree_state(tree), _file_state()
    with pytest.raises(ValueError, match=match):
        call()
    assert _tree_state(tree) == before
    assert _file_state() == files


def test_a_linked_material_is_refused_not_edited(linked):
    plane, mat = linked
    tree = mat.node_tree
    nmap = tree.nodes.active
    no_editor = types.SimpleNamespace(object=plane, space_data=None,
                                      scene=bpy.context.scene)
    # The operators' route without a Shader Editor (F3 search): the active object's material.
    _refused_unchanged(tree, lambda: O.shown_tree(no_editor), f"'Library Material' is {LINKED}")
    _refused_unchanged(tree, lambda: api.add_layer_stack(mat), LINKED)
    _refused_unchanged(tree, lambda: O.add_layer_stack(tree), LINKED)
    _refused_unchanged(tree, lambda: O.convert_node(tree, nmap), LINKED)
    _refused_unchanged(tree, lambda: O.add_decal_projector(no_editor, tree), LINKED)
    _refused_unchanged(tree, lambda: F.thaw(mat), f"'Library Material' is {LINKED}")


def _bump_material():
    mat, tree, bsdf = diffuse_material("Bumpy")
    bump = tree.nodes.new("ShaderNodeBump")
    tree.links.new(bump.outputs[0], bsdf.inputs["Normal"])
    return mat, tree, bump


def test_convert_refuses_a_linked_filter_width(fresh):
    mat, tree, bump = _bump_material()
    if "Filter Width" not in bump.inputs:
        pytest.skip("this line's Bump node has no Filter Width")
    width = tree.nodes.new("ShaderNodeValue")
    tree.links.new(width.outputs[0], bump.inputs["Filter Width"])
    _refused_unchanged(tree, lambda: O.convert_node(tree, bump),
                       "link into Filter Width.*remove the link and type the width")


@pytest.mark.parametrize("kind", ["ShaderNodeBump", "ShaderNodeNormalMap"])
def test_convert_refuses_a_muted_node(fresh, kind):
    mat, tree, bsdf = diffuse_material("Muted")
    node = tree.nodes.new(kind)
    tree.links.new(node.outputs[0], bsdf.inputs["Normal"])
    node.mute = True
    _refused_unchanged(tree, lambda: O.convert_node(tree, node), "is muted: unmute it")
    node.mute = False                              # unmuted, the same node converts
    resolve = O.convert_node(tree, node)
    assert bsdf.inputs["Normal"].links[0].from_node == resolve


def test_freeze_refuses_a_material_another_mesh_uses():
    objs = test_scenes.new_scene(["Sphere", "Plane"])
    sphere, plane = objs["Sphere"], objs["Plane"]
    mat, _ = layered_material(sphere)
    plane.data.materials.clear()
    plane.data.materials.append(mat)
    before, images = material_dump(mat), set(bpy.data.images.keys())
    with pytest.raises(F.FreezeError, match="also used by 'Plane'.*own copy of the material"):
        F.freeze(sphere, 16, log=lambda *_: None)
    assert material_dump(mat) == before and set(bpy.data.images.keys()) == images
    # A linked duplicate shares the mesh, its UVs and so the map: that one is no obstacle.
    plane.data.materials.clear()
    twin = sphere.copy()
    bpy.context.scene.collection.objects.link(twin)
    assert twin.data == sphere.data
    assert F.check(sphere, 16)[0] == mat


@pytest.mark.tier("bake")
def test_freeze_packs_a_material_named_with_a_slash():
    obj = test_scenes.new_scene(["Plane"])["Plane"]
    mat, _ = layered_material(obj, name="Rock/Wet")
    record = F.freeze(obj, 16, log=lambda *_: None)
    image = bpy.data.images[record["image"]]
    assert image.packed_file is not None and image.size[:] == (16, 16)
    assert record["file"] == "" and F.RECORD in mat


def test_a_decal_projector_scaled_through_zero_keeps_following(fresh):
    """Scaling the projector to zero on an axis (S Z 0, or a decal animated growing from
    nothing) divided by zero in its drivers, which Blender then stopped evaluating for good:
    the decal stayed put after the scale came back."""
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [], [(0, 1, 2)])
    plane = bpy.data.objects.new("Plane", mesh)
    bpy.context.scene.collection.objects.link(plane)
    mat, tree, _ = diffuse_material("Decal")
    mesh.materials.append(mat)
    empty, decal = O.add_decal_projector(bpy.context, tree)
    coords = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"
                  and n.node_tree.name == "SG Projector Coordinates")
    rows = [coords.inputs[f"To Projector {axis}"] for axis in "XYZ"]
    drivers = tree.animation_data.drivers
    assert len(drivers) == 18 and all(d.driver.is_simple_expression for d in drivers)
    for scale in ((1, 1, 0), (0, 1, 1), (0, 0, 0), (2, 3, 0.5)):
        empty.scale = scale
        empty.rotation_euler = (0.5, -0.2, 0.3)
        bpy.context.view_layer.update()
        assert all(d.driver.is_valid for d in drivers), scale
        values = [list(r.default_value) for r in rows] + [list(decal.inputs["Axis X"]
                                                            .default_value)]
        assert all(abs(v) < 1e7 for row in values for v in row), (scale, values)
    # Back to a real size: the drivers follow it again (the inverse of its 3 x 3 matrix).
    inverse = empty.matrix_world.to_3x3().inverted()
    for r, expected in zip(rows, inverse):
        assert list(r.default_value) == pytest.approx(list(expected), abs=1e-5)
    axis_x = empty.matrix_world.to_3x3().col[0].normalized()
    assert list(decal.inputs["Axis X"].default_value) == pytest.approx(list(axis_x), abs=1e-6)


@pytest.mark.tier("bake")
def test_thaw_keeps_a_node_of_the_users_that_took_a_frozen_nodes_name():
    """The user deletes the freeze's Normal Map node and adds one of their own, which takes
    the free name "Normal Map": Thaw used to remove it by that name."""
    obj = test_scenes.new_scene(["Plane"])["Plane"]
    mat, _ = layered_material(obj)
    record = F.freeze(obj, 16, log=lambda *_: None)
    tree = mat.node_tree
    frozen_nmap = next(tree.nodes[n] for n in record["added"]
                       if tree.nodes[n].bl_idname == "ShaderNodeNormalMap")
    name = frozen_nmap.name
    tree.nodes.remove(frozen_nmap)
    mine = tree.nodes.new("ShaderNodeNormalMap")
    assert mine.name == name                 # the name the record holds
    F.thaw(mat)
    assert tree.nodes.get(name) == mine and F.RECORD not in mat
    # What the freeze added (and still labels as its own) is gone.
    assert not any(n.label.startswith("surfgrad: ") for n in tree.nodes)


def test_a_second_sampler_group_on_a_zones_texture_keeps_the_material_valid(fresh):
    """The texture a Sampler zone holds made active and a second Sampler group added (the
    one-texel twin of the same image): the new group's UV was linked from inside the first
    zone, a link out of a zone, which made everything downstream invalid up to the Material
    Output (the material rendered nothing)."""
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.addon import ui
    from surfgrad_addon.addon.sampler_zone import has_closures
    if not has_closures():
        pytest.skip("Sampler groups need Blender 5.0's closures")
    mat, tree, bsdf = diffuse_material("Sampled")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.new("Height", 8, 8)
    mapping = tree.nodes.new("ShaderNodeMapping")
    tree.links.new(tree.nodes.new("ShaderNodeUVMap").outputs[0], mapping.inputs[0])
    tree.links.new(mapping.outputs[0], tex.inputs["Vector"])
    tree.nodes.active = tex
    first = ui.add_group_node(tree, "SG Height Map HQ (Sampler)")
    zone_out = first.inputs["Sampler"].links[0].from_node
    tree.nodes.active = zone_out.inputs["Color"].links[0].from_node    # the zone's texture
    second = ui.add_group_node(tree, "SG Height Map One-Texel (Sampler)", (400.0, 0.0))
    assert second.inputs["UV"].links[0].from_node == mapping        # as the first group's
    assert first.inputs["UV"].links[0].from_node == mapping
    resolve = tree.nodes.new("ShaderNodeGroup")
    resolve.node_tree = G.resolve_group()
    tree.links.new(second.outputs[0], resolve.inputs["Surface Gradient"])
    tree.links.new(resolve.outputs[0], bsdf.inputs["Normal"])
    invalid = [f"{lk.from_node.name}.{lk.from_socket.name} -> {lk.to_node.name}."
               f"{lk.to_socket.name}" for lk in tree.links if not lk.is_valid]
    assert invalid == []


@pytest.mark.parametrize("name, options, match", [
    ("SG Height Map HQ", {"image": "No Such Image"}, "there is no image of that name"),
    ("SG Parallax", {"image": 3}, "give an image of this file"),
    ("SG Height Map HQ", {"extension": "WRAP"}, "extension 'WRAP': use one of REPEAT"),
    ("SG Height Map Forward", {"filter_width": "abc"}, "give a positive number"),
    ("SG Height Map Forward", {"filter_width": float("nan")}, "give a positive number"),
    ("SG Height Map Forward", {"filter_width": -1.0}, "give a positive number"),
    ("SG Normal Map", {"uv_map": 3}, "give the UV map's name"),
    ("SG Normal Map", {"uv_map": "x" * 80}, "longer than a UV map's name can be"),
])
def test_the_api_raises_value_errors_for_bad_options(fresh, name, options, match):
    """The API promises ValueError with the fix; these raised AttributeError or the node
    builder's RuntimeError (or built a group with a NaN filter width), and left no group."""
    groups = set(bpy.data.node_groups.keys())
    with pytest.raises(ValueError, match=match):
        api.node_group(name, **options)
    assert set(bpy.data.node_groups.keys()) == groups


def test_the_api_takes_an_image_by_name(fresh):
    image = bpy.data.images.new("Height", 8, 4)
    by_name = api.node_group("SG Height Map HQ", image="Height")
    assert by_name == api.node_group("SG Height Map HQ", image=image)
    assert any(getattr(n, "image", None) == image for n in by_name.nodes)
    mat, _, _ = diffuse_material("Stack")
    with pytest.raises(ValueError, match="give the UV map's name"):
        api.add_layer_stack(mat, uv_map=5)


def test_a_lights_nodes_shown_are_refused(fresh):
    """In Object mode the Shader Editor shows the active light's nodes: the decal projector
    went in there (an empty in the scene and a decal chain in the light), as the World's
    nodes are refused."""
    light = bpy.data.lights.new("Lamp", "POINT")
    if light.node_tree is None:
        light.use_nodes = True
    obj = bpy.data.objects.new("Lamp", light)
    bpy.context.scene.collection.objects.link(obj)
    space = types.SimpleNamespace(type='NODE_EDITOR', tree_type="ShaderNodeTree",
                                  shader_type='OBJECT', edit_tree=light.node_tree)
    shown = types.SimpleNamespace(object=obj, space_data=space, scene=bpy.context.scene)
    _refused_unchanged(light.node_tree, lambda: O.shown_tree(shown),
                       "shows the World's \\(or a light's")


def test_precise_far_is_not_set_in_a_linked_material(fresh, tmp_path):
    """api.update_precise_far set the input in a linked material too, where the file never
    saves it; it now refuses before setting any. A local material is set as before."""
    mat, tree, _bsdf = diffuse_material("Far Library")
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = G.triplanar_coordinates_group()      # one of the groups with the input
    linked_mat = _linked_back(mat, tmp_path)
    local, local_tree, _ = diffuse_material("Far Local")
    local_node = local_tree.nodes.new("ShaderNodeGroup")
    local_node.node_tree = G.triplanar_coordinates_group()
    mesh = bpy.data.meshes.new("Far")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [], [(0, 1, 2)])
    mesh.materials.append(local)
    mesh.materials.append(linked_mat)
    far = bpy.data.objects.new("Far", mesh)
    far.location = (10000.0, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(far)
    bpy.context.view_layer.update()
    name = "Precise Far From Origin"
    with pytest.raises(ValueError, match=f"'Far Library' is {LINKED}"):
        api.update_precise_far(far)
    assert local_node.inputs[name].default_value is False      # nothing set: all or nothing
    far.data.materials.pop(index=1)
    assert api.update_precise_far(far) == 1 and local_node.inputs[name].default_value is True
