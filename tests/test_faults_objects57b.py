"""Red team 57b: objects a scene holds that are not a plain mesh, through bake-normal-map (the
API), compare and Freeze. Built here by code, a few faces.

1. A Geometry Nodes modifier that makes the mesh anew (a Mesh Grid: a procedural generator)
   and gives its faces no material: the object's slot holds the material, but Blender renders
   and bakes those faces with no material (the evaluated slot is empty; Cycles' default
   surface). bake-normal-map refused it, rightly, but told the artist to "give the slot a
   material" (it holds one) and named no modifier; Freeze passed its checks and then Blender
   cancelled its bake ("the bake of 'GNObj' did not finish ({'CANCELLED'})", BakeFailed after
   the "checked" stage, on 5.2 and 4.2). Now both refuse before baking, naming the faces, the
   material the slot holds, the modifier and the fix (a Set Material node)
   (addon/empty_slots.py; freeze.check runs the same check as bake-normal-map); with that
   Set Material the bake is done and every texel is the material's map.
2. A mesh whose modifiers leave it no UV map at all (a Remesh, which makes new faces without
   UVs; a Geometry Nodes Store Named Attribute of the UVs as a 3D vector): bake-normal-map,
   compare and Freeze refused it with "the rendered mesh has []): pick one of those, or fix
   the modifiers", naming no modifier and offering nothing to pick. Now the refusal names
   the modifiers shown in renders and the fix for each (apply the Remesh and unwrap; store
   the UVs as a 2D Vector on Face Corner) (addon/bake_uvs.not_rendered_problem).
3. A mesh whose Geometry Nodes output has no faces (Mesh to Points, Mesh to Curve, a Delete
   Geometry): bake-normal-map and Freeze blamed its UV map (finding 2's words), compare said
   "has no faces to bake; add geometry" (its mesh has 30). Now all three say it has no faces
   as it renders, naming the mesh's face count, the modifiers and the fix
   (bake_uvs.no_faces_problem).
4. Geometry Nodes joining faces of no material to the mesh (a Curve to Mesh tube along its
   edges, UV'd over the grid): the rendered object has a second slot, empty, that the object
   lacks. bake-normal-map refused it, telling the artist to "give the slot a material" (the
   object has one slot); Freeze froze it and reported success, its map 400 of 1024 texels
   30.0 degrees off the stack's (the tube's faces baked flat over the grid's; 32^2, 5.2).
   Now both refuse, naming the slot the object lacks, the modifier and the fix (a Set
   Material node), the material unchanged. compare (which puts its material in every slot
   the object has) called a correct SG Normal Map p99 180 / max 180 degrees wrong over 900
   texels at 32^2 (the tube's faces baked flat with Cycles' default surface); a mesh made
   anew (finding 1) ran the reference and was then cancelled by Blender's bake (exit 1).
   Now compare refuses both before baking (exit 2), naming the faces' count and the
   modifier (harness/bake._other_materials_problem).
5. Freeze of an object whose Array modifier's UV offset moves the copy out of the 0-1 square
   (its mesh's UVs inside it): refused, rightly, as "UV map 'the active render UV map' of
   'Grid' has faces outside the 0-1 UV square", a placeholder quoted as a name, no modifier
   named. Now the UV map's name and the modifiers that move the UVs (freeze._outside_square_text).

Probed and right on 5.2 (compare normal-map within p99 0.0005 / max 0.001 degrees at 32^2,
bake-normal-map's tangent map of a constant normal map equal to it, the scene unchanged):
Solidify with rim faces and rim only (overlap warned), Weld, Decimate, Boolean union and
difference with the exact solver, Array with a UV offset into tile 1002 (refused without
<UDIM>), Mirror with Mirror U, a Subdivision shown in the viewport only, a Wave in renders
only, Subdivision viewport 0 / render 3, a parented object under a rotated, non-uniformly
scaled empty with a Track To constraint, a Geometry Nodes mesh with its UVs on half its faces
(Set Material given) or through Realize Instances. Curves (bevel, extrude), text, NURBS
surfaces, metaballs, Grease Pencil, point clouds and collection-instancing empties are
refused by all three naming what they are and the fix (round 34c, 37c).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.addon.bake_request import BakeRequestError  # noqa: E402
from surfgrad_addon.harness import asset_scenes as A, bake as B, compare  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 32
COLOUR = (0.75, 0.5, 0.933)            # a constant tangent-space map, tilted about v


@pytest.fixture
def empty_file():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy


def _normal_map_material(obj, name="M"):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0):        # always on from 5.0 (deprecated)
        mat.use_nodes = True
    nt = mat.node_tree
    nm, rgb = nt.nodes.new("ShaderNodeNormalMap"), nt.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = COLOUR + (1.0,)
    nt.links.new(rgb.outputs[0], nm.inputs["Color"])
    nt.links.new(nm.outputs[0], nt.nodes["Principled BSDF"].inputs["Normal"])
    obj.data.materials.append(mat)
    return mat


def _stack_material(obj):
    mat = bpy.data.materials.new("SG")
    if bpy.app.version < (5, 0):        # always on from 5.0 (deprecated)
        mat.use_nodes = True
    O.add_layer_stack(mat.node_tree)
    obj.data.materials.append(mat)
    return mat


def _generated(name="GNObj", data_type="FLOAT2", material=None):
    """An object whose Geometry Nodes modifier makes a 4 x 4 grid anew, its UVs stored as
    'UVMap' (data_type on Face Corner), smooth; a Set Material of `material` at the end."""
    ng = bpy.data.node_groups.new("Make", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    out = ng.nodes.new("NodeGroupOutput")
    grid = ng.nodes.new("GeometryNodeMeshGrid")
    for key, value in (("Vertices X", 5), ("Vertices Y", 5), ("Size X", 2.0), ("Size Y", 2.0)):
        grid.inputs[key].default_value = value
    store = ng.nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = data_type, "CORNER"
    store.inputs["Name"].default_value = "UVMap"
    ng.links.new(grid.outputs["Mesh"], store.inputs["Geometry"])
    ng.links.new(grid.outputs["UV Map"], store.inputs["Value"])
    smooth = ng.nodes.new("GeometryNodeSetShadeSmooth")
    ng.links.new(store.outputs[0], smooth.inputs[0])
    last = smooth.outputs[0]
    if material is not None:
        setter = ng.nodes.new("GeometryNodeSetMaterial")
        setter.inputs["Material"].default_value = material
        ng.links.new(last, setter.inputs["Geometry"])
        last = setter.outputs[0]
    ng.links.new(last, out.inputs[0])
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    mesh.uv_layers.new(name="UVMap")
    obj = A._link(name, mesh)
    obj.modifiers.new("GN", "NODES").node_group = ng
    return obj


def _pixels(path):
    img = bpy.data.images.load(str(path))
    try:
        px = np.array(img.pixels[:], dtype=np.float64).reshape(RES, RES, -1)
    finally:
        bpy.data.images.remove(img)
    return px[..., :3]


# 1. A Geometry Nodes mesh made anew, without a material -------------------------------------

def test_generated_faces_without_material_bake_refusal_names_the_modifier(empty_file,
                                                                          tmp_path):
    obj = _generated()
    _normal_map_material(obj)
    out = tmp_path / "gn.png"
    with pytest.raises(BakeRequestError) as err:
        api.bake_normal_map(obj, out, resolution=RES, samples=1, log=None)
    text = str(err.value)
    # Before: "use empty material slot 1, ...: give the slot a material" (it holds 'M').
    assert "give the slot a material" not in text, text
    assert "'GN'" in text and "Set Material" in text and "'M'" in text, text
    assert "16 face(s)" in text, text
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_generated_faces_with_set_material_bake_the_map(empty_file, tmp_path):
    """The fix the refusal names works: every covered texel is the constant map."""
    mesh = bpy.data.meshes.new("Holder")
    mat = _normal_map_material(bpy.data.objects.new("Holder", mesh))
    obj = _generated(material=mat)
    obj.data.materials.append(mat)
    out = api.bake_normal_map(obj, tmp_path / "gn.png", resolution=RES, samples=1, log=None,
                              margin=0)
    px = _pixels(out)
    # The grid's UVs cover the whole square: every texel the map.
    assert np.abs(px - np.array(COLOUR)).max() < 0.01, np.abs(px - COLOUR).max()


def test_generated_faces_without_material_freeze_refused_before_baking(empty_file):
    obj = _generated()
    mat = _stack_material(obj)
    nodes = sorted(n.name for n in mat.node_tree.nodes)
    images = len(bpy.data.images)
    # Before: BakeFailed "did not finish ({'CANCELLED'})" from Blender's bake, after check.
    with pytest.raises(F.FreezeError, match=r"'GN'.*Set Material"):
        F.check(obj, RES)
    with pytest.raises(F.FreezeError, match=r"'GN'.*Set Material"):
        F.freeze(obj, RES)
    assert sorted(n.name for n in mat.node_tree.nodes) == nodes
    assert len(bpy.data.images) == images and F.RECORD not in mat


# 2. Modifiers that leave the mesh no UV map -------------------------------------------------

def _remeshed():
    obj = A._link("Remeshed", A._grid("Remeshed", nx=6, ny=5))
    mod = obj.modifiers.new("Remesh", "REMESH")
    mod.mode, mod.octree_depth = "SMOOTH", 3
    return obj


@pytest.mark.parametrize("kind", ["remesh", "vector3"])
def test_no_uv_map_left_names_the_modifier_and_fix(empty_file, tmp_path, kind):
    if kind == "remesh":
        obj, word, fix = _remeshed(), "'Remesh'", "unwrap"
    else:
        obj, word, fix = _generated(data_type="FLOAT_VECTOR"), "'GN'", "2D Vector"
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    assert len(evaluated.polygons) > 0 and len(evaluated.uv_layers) == 0
    _normal_map_material(obj)
    out = tmp_path / "m.png"
    with pytest.raises(BakeRequestError) as err:
        api.bake_normal_map(obj, out, resolution=RES, samples=1, log=None)
    # Before: "...the rendered mesh has []): pick one of those, or fix the modifiers".
    for text in (str(err.value),):
        assert "pick one of those" not in text and word in text and fix in text, text
    with pytest.raises(compare.CompareError) as err:
        compare.compare_object(obj, "normal-map", RES, log=lambda *_: None)
    assert "pick one of those" not in str(err.value) and word in str(err.value)
    assert list(tmp_path.iterdir()) == []
    obj.data.materials.clear()
    _stack_material(obj)
    with pytest.raises(F.FreezeError) as err:
        F.check(obj, RES)
    assert "pick one of those" not in str(err.value) and word in str(err.value)


# 3. A mesh whose modifiers leave it no faces, or join faces of no slot ------------------------

def _nodes_on(obj, kind):
    """A Geometry Nodes modifier 'GN' on obj: 'points' (Mesh to Points), 'nothing' (Delete
    Geometry of everything), 'tube' (the mesh joined with a tube along its edges, Curve to
    Mesh: faces of a second material slot, which the object lacks)."""
    ng = bpy.data.node_groups.new(kind, "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    gi, go = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
    link = ng.links.new
    if kind == "tube":
        curve = ng.nodes.new("GeometryNodeMeshToCurve")
        tube = ng.nodes.new("GeometryNodeCurveToMesh")
        circle = ng.nodes.new("GeometryNodeCurvePrimitiveCircle")
        circle.inputs["Radius"].default_value = 0.02
        join = ng.nodes.new("GeometryNodeJoinGeometry")
        link(gi.outputs[0], curve.inputs[0])
        link(curve.outputs[0], tube.inputs[0])
        link(circle.outputs[0], tube.inputs["Profile Curve"])
        # The tube's UVs: its position mapped over the grid's (a tube UV'd in place).
        store = ng.nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type, store.domain = "FLOAT2", "CORNER"
        store.inputs["Name"].default_value = "UVMap"
        uv = ng.nodes.new("ShaderNodeVectorMath")
        uv.operation = "MULTIPLY_ADD"
        uv.inputs[1].default_value, uv.inputs[2].default_value = (0.45, 0.6, 0), (0.5, 0.5, 0)
        link(ng.nodes.new("GeometryNodeInputPosition").outputs[0], uv.inputs[0])
        link(uv.outputs[0], store.inputs["Value"])
        link(tube.outputs[0], store.inputs["Geometry"])
        link(store.outputs[0], join.inputs[0])
        link(gi.outputs[0], join.inputs[0])
        link(join.outputs[0], go.inputs[0])
    else:
        node = ng.nodes.new("GeometryNodeMeshToPoints" if kind == "points"
                            else "GeometryNodeDeleteGeometry")
        link(gi.outputs[0], node.inputs[0])
        link(node.outputs[0], go.inputs[0])
    obj.modifiers.new("GN", "NODES").node_group = ng
    return obj


@pytest.mark.parametrize("kind", ["points", "nothing"])
def test_no_faces_as_it_renders_names_the_modifier(empty_file, tmp_path, kind):
    obj = _nodes_on(A._link("Grid", A._grid("Grid", nx=6, ny=5)), kind)
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    assert len(evaluated.polygons) == 0 and len(obj.data.polygons) == 30
    _normal_map_material(obj)
    # Before: bake "the rendered mesh has []): pick one of those, or fix the modifiers" (a UV
    # map problem); compare "has no faces to bake; add geometry" (the mesh has 30).
    with pytest.raises(BakeRequestError) as err:
        api.bake_normal_map(obj, tmp_path / "p.png", resolution=RES, samples=1, log=None)
    text = str(err.value)
    assert "no faces as it renders" in text and "'GN'" in text and "has 30" in text, text
    with pytest.raises(compare.CompareError) as err:
        compare.compare_object(obj, "normal-map", RES, log=lambda *_: None)
    assert "no faces as it renders" in str(err.value) and "'GN'" in str(err.value)
    assert list(tmp_path.iterdir()) == []
    obj.data.materials.clear()
    _stack_material(obj)
    with pytest.raises(F.FreezeError, match="no faces as it renders"):
        F.check(obj, RES)


def test_joined_faces_of_a_slot_the_object_lacks(empty_file, tmp_path):
    obj = _nodes_on(A._link("Grid", A._grid("Grid", nx=6, ny=5)), "tube")
    _normal_map_material(obj)
    out = tmp_path / "t.png"
    with pytest.raises(BakeRequestError) as err:
        api.bake_normal_map(obj, out, resolution=RES, samples=1, log=None)
    text = str(err.value)
    # Before: "... use empty material slot 2 ...: give the slot a material" (it has one slot).
    assert "give the slot a material" not in text, text
    assert "slot 2, a slot the object itself lacks (it has 1)" in text and "'GN'" in text, text
    assert list(tmp_path.iterdir()) == []


def test_joined_faces_of_a_slot_the_object_lacks_freeze_refused(empty_file):
    obj = _nodes_on(A._link("Grid", A._grid("Grid", nx=6, ny=5)), "tube")
    mat = _stack_material(obj)
    nt = mat.node_tree                  # the stack's map: the constant, tilted 30 degrees
    layer = next(n for n in nt.nodes if n.type == "GROUP" and "Normal Map" in n.node_tree.name)
    rgb = nt.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = COLOUR + (1.0,)
    nt.links.new(rgb.outputs[0], next(s for s in layer.inputs if s.type == "RGBA"))
    nodes = sorted(n.name for n in nt.nodes)
    # Before: frozen, 400 of the 1024 texels 30.0 degrees off the stack's map (the tube's
    # faces, of no material, baked flat over the grid's), reported as done.
    with pytest.raises(F.FreezeError, match=r"slot 2, a slot the object itself lacks"):
        F.freeze(obj, RES)
    assert sorted(n.name for n in mat.node_tree.nodes) == nodes and F.RECORD not in mat


@pytest.mark.parametrize("kind", ["tube", "anew"])
def test_compare_refuses_faces_rendered_without_a_material(empty_file, kind):
    """Before: the tube (UV'd over the grid) made compare call a correct SG Normal Map p99
    180 / max 180 degrees wrong over 900 texels; the mesh made anew was cancelled by
    Blender's bake after the reference's work (exit 1)."""
    if kind == "tube":
        obj = _nodes_on(A._link("Grid", A._grid("Grid", nx=6, ny=5)), "tube")
        faces = None
    else:
        obj, faces = _generated(), 16
    _normal_map_material(obj)
    slots = [s.material for s in obj.material_slots]
    with pytest.raises(B.BakeError) as err:
        compare.compare_object(obj, "normal-map", RES, log=lambda *_: None)
    text = str(err.value)
    assert "with no material whatever its material slots hold" in text and "'GN'" in text, text
    if faces:
        assert f"renders {faces} face(s)" in text, text
    assert [s.material for s in obj.material_slots] == slots


def test_freeze_outside_the_square_names_the_uv_map_and_the_modifier(empty_file):
    """Before: "UV map 'the active render UV map' of 'Grid' has faces outside the 0-1 UV
    square: ... pick (or unwrap) a UV map inside it" (a placeholder quoted as a name; the
    mesh's UVs lie inside the square, the Array's UV offset moves the copy out)."""
    obj = A._link("Grid", A._grid("Grid", nx=6, ny=5, x0=0.0, x1=0.5))
    array = obj.modifiers.new("Array", "ARRAY")
    array.count, array.offset_u = 2, 0.45
    _stack_material(obj)
    with pytest.raises(F.FreezeError) as err:
        F.check(obj, RES)
    text = str(err.value)
    assert "UV map 'UVMap' of 'Grid'" in text and "'Array'" in text, text
    assert "the active render UV map" not in text, text
