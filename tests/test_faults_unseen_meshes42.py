"""Red team 42c: `compare` and `bake-normal-map` on meshes as other tools and artists make them.

1. More than eight UV maps (an importer's extra 2D channels on face corners: glTF custom
   attributes, USD primvars; Blender lists every one as a UV map, and bakes any of them):
   the reference built its tangents on a temporary mesh through `uv_layers.new`, which makes
   at most eight and returned None for the ninth. Before, on 5.2: compare of any UV map of
   such a mesh (the first one too) ended in "surfgrad: error: 'bpy_prop_collection[key]: key
   "Ninth" not found'", exit 2. Now the temporary mesh takes them as attributes
   (harness/mesh_data.triangle_mikktspace), and compare is within the bar.
2. A material that only a Geometry Nodes Set Material gives the object (no material slot of
   the object holds it): Cycles renders and bakes it on its faces, but the checks before a bake
   read the object's own slots only. Before: an image it reads that is missing baked Cycles'
   magenta 'missing' colour into those faces, exit 0 (object-space texels (0.37, 0.48, 0.98)
   on 5.2, 98 of the 196 covered at 16^2). Now the checks read every material the object
   renders with (addon/bake_uvs.rendered_materials): refused, naming the image and the material.
   And a batch's list of the files a .blend reads (its manifest's inputs, which tell a
   repainted texture) left out such a material's UDIM tiles: a repainted tile was not seen.
3. Freeze of a material on an object a Set Material gives another material none of its slots
   holds: Freeze bakes the frozen material's faces alone, the other materials into a
   throwaway image, but Blender's bake finds that material no image of its own and wrote its
   faces into the frozen map. Before: two quads on one UV square, the second given a tilted
   normal by the Set Material: 196 of the 256 texels of the frozen material's map up to 103
   degrees off, and Freeze wired it in. Now refused, naming the material and the fix (add it
   to a slot, which bakes the map of the frozen material alone: normal_bake.unslotted_problem).
4. compare on an object whose Set Material gives some faces a material (in a slot of the
   object or not): compare puts its own material in every slot, but the node gives those
   faces theirs whatever the slots hold, so they baked with it, not with the method's groups.
   Before: a correct SG Normal Map called p99 180 / max 180 deg wrong, exit 0. Now refused,
   exit 2, naming the material and the fix (harness/bake._other_materials_problem).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from surfgrad_addon.reference import images  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_unseen_meshes31 import P99, MAX, empty_file  # noqa: E402,F401
from test_faults_unseen_meshes32 import _grid, _object  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 32


def _ninth_uv_map(obj):
    """obj with UV maps UV1..UV7 beside 'UVMap' (eight, the most uv_layers.new makes) and a
    ninth, 'Ninth', as an importer writes it (a 2D vector attribute on face corners): 'UVMap'
    turned a quarter."""
    mesh = obj.data
    for i in range(1, 8):
        mesh.uv_layers.new(name=f"UV{i}")
    uv = np.empty(len(mesh.loops) * 2)
    mesh.uv_layers["UVMap"].uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    mesh.attributes.new("Ninth", "FLOAT2", "CORNER").data.foreach_set(
        "vector", np.column_stack([uv[:, 1], 1.0 - uv[:, 0]]).ravel())
    mesh.update()
    return obj


def test_a_mesh_with_more_than_eight_uv_maps_is_compared(empty_file):
    """1. Before: KeyError 'key "Ninth" not found' for either UV map."""
    obj = _ninth_uv_map(_object("Many", [_grid(uv_size=0.9)]))
    assert len(obj.data.uv_layers) == 9 and obj.data.uv_layers.new(name="Tenth") is None
    for uv_map in ("UVMap", "Ninth"):
        report = compare.compare(obj, "normal-map", RES, uv_map=uv_map)
        assert report["uv_map"] == uv_map
        assert report["texels_compared"] > 700, report
        assert report["p99_deg"] <= P99 and report["max_deg"] <= MAX, report
    assert [m.name for m in bpy.data.meshes] == ["Many"]        # the temporary mesh is gone


def _normal_map_material(name, image):
    """A Diffuse BSDF whose normal is a tangent-space Normal Map node of `image`."""
    mat, tree, bsdf = diffuse_material(name)
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    tree.links.new(texture.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def _bumps():
    """A packed float image of bumps (a tangent-space normal map)."""
    return compare.bpy_float_image("bumps", images.hemisphere_tile_image(32))


def _set_material_modifier(obj, material):
    """A Geometry Nodes modifier giving `material` to obj's faces at x > 0."""
    tree = bpy.data.node_groups.new("Set Material", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    new, link = tree.nodes.new, tree.links.new
    group_in, group_out = new("NodeGroupInput"), new("NodeGroupOutput")
    set_material = new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = material
    xyz, greater = new("ShaderNodeSeparateXYZ"), new("FunctionNodeCompare")
    greater.data_type, greater.operation = "FLOAT", "GREATER_THAN"
    link(new("GeometryNodeInputPosition").outputs[0], xyz.inputs[0])
    link(xyz.outputs["X"], greater.inputs[0])
    link(greater.outputs[0], set_material.inputs["Selection"])
    link(group_in.outputs[0], set_material.inputs["Geometry"])
    link(set_material.outputs[0], group_out.inputs[0])
    obj.modifiers.new("GeometryNodes", "NODES").node_group = tree


def _object_space_map(tmp_path, obj, name):
    out = tmp_path / f"{name}.exr"
    api.bake_normal_map(obj, str(out), resolution=16, space="object", depth="float", margin=0,
                        log=None)
    img = bpy.data.images.load(str(out))
    px = np.empty(len(img.pixels), np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4)[:, :3]


def _two_materials(by_nodes):
    """The grid with 'Base' (a plain Diffuse) in its one slot and 'Other' (bumps) on its faces
    at x > 0: given by a Set Material node (`by_nodes`), or by a second slot and the faces'
    material index."""
    verts, faces, uvs = _grid(uv_size=0.9)
    obj = _object("Parts", [(verts, faces, uvs)])
    obj.data.materials.append(diffuse_material("Base")[0])
    other = _normal_map_material("Other", _bumps())
    if by_nodes:
        _set_material_modifier(obj, other)
    else:
        obj.data.materials.append(other)
        right = np.array([verts[f, 0].mean() > 0 for f in map(list, faces)], np.int32)
        obj.data.polygons.foreach_set("material_index", right)
        obj.data.update()
    return obj, other


def test_a_material_only_geometry_nodes_give_is_checked(empty_file, tmp_path):
    """2. What the refusal rests on: the bake renders the Set Material's material on its faces
    (the map is the one of the same material in a slot of its own, texel for texel, and those
    faces are bumped). Before: its missing image baked, exit 0; now refused, nothing written."""
    obj, other = _two_materials(by_nodes=False)
    in_slot = _object_space_map(tmp_path, obj, "in_slot")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, other = _two_materials(by_nodes=True)
    assert [s.material.name for s in obj.material_slots] == ["Base"]
    by_nodes = _object_space_map(tmp_path, obj, "by_nodes")
    assert np.array_equal(by_nodes, in_slot)
    covered = np.abs(by_nodes).sum(1) > 0
    assert covered.sum() > 150 and np.ptp(by_nodes[covered], axis=0).max() > 0.2  # bumped

    gone = bpy.data.images.new("gone", 8, 8)
    gone.source, gone.filepath = "FILE", str(tmp_path / "gone.png")
    next(n for n in other.node_tree.nodes if n.type == "TEX_IMAGE").image = gone
    out = tmp_path / "n.png"
    with pytest.raises(ValueError) as err:
        api.bake_normal_map(obj, str(out), resolution=16, log=None)
    assert (f"image 'gone' reads '{tmp_path / 'gone.png'}', which does not exist: Cycles would "
            f"bake its magenta 'missing' colour") in str(err.value)
    assert "(read by 'Image Texture' in material 'Other')" in str(err.value)
    assert not out.exists()


@pytest.mark.tier("blender")
def test_a_batch_lists_the_tiles_of_a_material_only_geometry_nodes_give(empty_file, tmp_path,
                                                                       monkeypatch):
    """2. The UDIM tile a Set Material's material reads is among the files a batch stamps
    (before: left out), read from the viewport's evaluated object: no render-mode pass."""
    from surfgrad_addon.addon import render_mesh
    from surfgrad_addon.addon.batch import session
    passes, real = [], render_mesh.read_in_render_mode
    monkeypatch.setattr(render_mesh, "read_in_render_mode",
                        lambda *a, **k: passes.append(1) or real(*a, **k))
    obj, other = _two_materials(by_nodes=True)
    tiled = bpy.data.images.new("painted", 8, 8, tiled=True)
    tiled.filepath = str(tmp_path / "painted.<UDIM>.png")
    (tmp_path / "painted.1001.png").write_bytes(b"")
    next(n for n in other.node_tree.nodes if n.type == "TEX_IMAGE").image = tiled
    assert session.dependencies_of_open_file() == [str(tmp_path / "painted.1001.png")]
    assert passes == []


def _quads(n, stack=False):
    """n unit quads side by side, each over the UV square; the first's material 'Base' (a
    bumped Diffuse, or with the layer stack), the others 'Other' (a tilted normal) through a
    Set Material node (by_nodes) or a slot of its own."""
    verts = [(1.1 * k + x, y, 0.0) for k in range(n) for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
    faces = [[4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3] for k in range(n)]
    uvs = np.array([(0.05 + 0.9 * x, 0.05 + 0.9 * y) for x, y, _ in verts[:4]] * n)
    obj = _object("Quads", [(np.array(verts), faces, uvs)])
    base = diffuse_material("Base")[0] if stack else _normal_map_material("Base", _bumps())
    if stack:
        api.add_layer_stack(base)
    obj.data.materials.append(base)
    other, tree, bsdf = diffuse_material("Other")
    tilted = tree.nodes.new("ShaderNodeNormalMap")
    tilted.inputs["Color"].default_value = (1.0, 0.5, 0.6, 1.0)
    tree.links.new(tilted.outputs[0], bsdf.inputs["Normal"])
    return obj, base, other


def _frozen_map(tmp_path, obj, base, name):
    from surfgrad_addon.addon import normal_bake
    out = tmp_path / f"{name}.exr"
    normal_bake.bake_normal_tiles(obj, out, resolution=16, depth="float", margin=0,
                                  overwrite=True, log=lambda *_: None, only=base)
    img = bpy.data.images.load(str(out))
    px = np.empty(len(img.pixels), np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4)[:, :3]


def test_freeze_refuses_a_material_only_geometry_nodes_give(empty_file, tmp_path):
    """3. Before: the frozen map held the other material's faces (196 texels up to 103 deg
    off); now refused. The fix it names, a slot for that material, freezes the map of the
    frozen material's faces alone."""
    from surfgrad_addon.addon import freeze, normal_bake
    obj, base, other = _quads(1)
    alone = _frozen_map(tmp_path, obj, base, "alone")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, base, other = _quads(2)
    _set_material_modifier(obj, other)             # the second quad's faces: x > 1
    obj.modifiers[0].node_group.nodes["Compare"].inputs[1].default_value = 1.05
    with pytest.raises(normal_bake.NormalBakeError) as err:
        _frozen_map(tmp_path, obj, base, "frozen")
    assert str(err.value) == (
        "object 'Quads' renders material(s) ['Other'] that none of its material slots holds "
        "(a Geometry Nodes Set Material gives them): Blender's bake writes their faces into "
        "the map of material 'Base', over its faces where their UVs overlap; add them to the "
        "object's material slots (Material Properties > +)")
    assert not (tmp_path / "frozen.exr").exists()
    obj.data.materials.append(other)                # the fix
    assert np.abs(_frozen_map(tmp_path, obj, base, "slotted") - alone).max() < 1e-5

    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, base, other = _quads(2, stack=True)
    _set_material_modifier(obj, other)
    obj.modifiers[0].node_group.nodes["Compare"].inputs[1].default_value = 1.05
    with pytest.raises(freeze.FreezeError, match="renders material\\(s\\) \\['Other'\\]"):
        freeze.freeze(obj, resolution=16)


@pytest.mark.parametrize("slotted", [False, True])
def test_compare_refuses_faces_a_set_material_gives_another_material(empty_file, tmp_path,
                                                                      slotted):
    """4. Before: p99 180 / max 180 deg, exit 0; now refused, the slots as they were."""
    from support.compare_cli import compare_cli_refuses
    obj, other = _two_materials(by_nodes=True)
    if slotted:
        obj.data.materials.append(other)
    slots = [s.material.name for s in obj.material_slots]
    with pytest.raises(RuntimeError) as err:
        compare.compare(obj, "normal-map", RES)
    assert str(err.value).startswith(
        "object 'Parts' renders material(s) ['Other'] on faces whatever its material slots "
        "hold (a Geometry Nodes Set Material")
    assert [s.material.name for s in obj.material_slots] == slots
    assert sorted(m.name for m in bpy.data.materials) == ["Base", "Other"]
    if slotted:                                   # the command: a refusal, nothing written
        assert compare_cli_refuses(tmp_path, "parts.blend", "Parts", "normal-map")
