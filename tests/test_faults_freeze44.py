"""Red team 44d: Freeze against bake-normal-map, warning for warning and refusal for refusal.

A frozen map is a bake: the artist must hear what a TD hears from bake-normal-map for the same
object and material. Measured on 5.2 and 4.2, before the fix (main at 444fa62):

1. bake_request.mesh_problems' warnings were thrown away by freeze.check: overlapping UV
   islands (the map keeps one face's texels), faces collapsed in UV (holes the margin fills),
   an object far from the origin. Freeze reported none of them (operator: FINISHED, no
   WARNING), where bake-normal-map prints each. Now freeze.check passes them to `warn` and
   the operator reports them (also before a refusal, with the other warnings).
2. Faces beyond the UDIM tiles (u < 0 here) were frozen with no word: bake-normal-map refuses
   them (exit 1, "lie outside the UDIM range"); the frozen material samples the image at
   those faces' wrapped UVs, texels of other faces. Now refused like faces outside the 0-1
   square, before anything changes.
3. Save As naming the file of an image the object's materials read (here its base colour
   texture), with Overwrite: Freeze replaced that file with the normal map (its bytes
   changed, the material then read a normal map as colour). bake-normal-map refuses that
   output even with --overwrite (image_checks.output_input_problems); now Freeze does too,
   and the file is as it was.
4. A stack whose SG Blend Normals was saved on 5.2 (its Method a Menu Switch, which 4.5's
   shader trees cannot evaluate): 4.5 froze it as if the blend were zero, with no word, where
   bake-normal-map refuses it (foreign_nodes.py, red team 34). Now freeze.check refuses it with
   the same words, for the frozen material (foreign_node_problems(obj, only=mat)); 5.0 and 5.2
   freeze it (pinned); 4.2 cannot read a 5.x file at all (test_faults_artist34.py).
5. A Geometry Nodes modifier that makes the second quad (UVs in the right half) an unrealized
   instance with the frozen material: Freeze baked the realized quad alone and wired the map
   in, the instance reading flat background texels, with no word (bake-normal-map refuses it,
   unrealized_instances.py). Now refused naming the fix (Realize Instances), without the
   command line's --allow-partial, for the frozen material's instances alone. A mesh made all
   of instances was refused blaming its UV map ("is not on the mesh as it renders ... pick one
   of those, or fix the modifiers"); now with bake-normal-map's words, naming the instances
   and Realize Instances.
6. Resolution 16384 (the operator's maximum) on a machine of 24 GB and no swap (this one;
   the memory read stubbed as in test_faults_pipeline32.py): bake-normal-map refuses it (at
   least 45 GB), Freeze started the bake, which the OOM killer ends with SIGKILL, the
   artist's Blender session and unsaved work with it (not run: it would take the shared
   machine's memory). Now refused first with the same words, the fix naming Resolution.
7. The noise reference (reference/noise.py, the filtered volume noise's and the plain one's)
   counted the box of lattice cells it hashes with np.prod, which wraps past 2^63: cells some
   2e6 apart on every axis (`compare --method volume-noise-filtered` on a mesh 2e5 m across,
   object coordinates x Scale 4 x the octaves' lacunarity) gave a negative count and a raw
   "ValueError: negative dimensions are not allowed", exit 1 with a traceback. Scale itself
   is set by no user route (CLI, api, operator and bench use the default); the object's size
   reaches it. Now counted in Python integers: that compare runs (p99 2e-5 deg; its octaves
   are finer than the footprint there and fade out).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import freeze_operators as FO  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from support.geometry_nodes import geometry_group  # noqa: E402
from support.machine_memory import machine_without_swap  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from surfgrad_addon.addon.node_builder import running_line  # noqa: E402
from test_faults_artist34 import _open_saved_on_52  # noqa: E402
from test_faults_operators35 import registered  # noqa: E402,F401 (a fixture)

pytestmark = pytest.mark.tier("bake")

SIZE = 16
SQUARE = [(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)]


def _quads(fresh, uvs, at=(0.0, 0.0, 0.0)):
    """Unit quads side by side at `at`, quad k with the UV corners uvs[k]; its material 'Rock'
    a layer stack into a Diffuse BSDF. Returns (object, material)."""
    verts = [(1.5 * k + x, y, 0.0) for k in range(len(uvs))
             for x, y in ((0, 0), (1, 0), (1, 1), (0, 1))]
    faces = [[4 * k + i for i in range(4)] for k in range(len(uvs))]
    mesh = bpy.data.meshes.new("Quads")
    mesh.from_pydata(verts, [], faces)
    mesh.uv_layers.new(name="UVMap").uv.foreach_set("vector", np.ravel(uvs))
    mesh.update()
    obj = bpy.data.objects.new("Quads", mesh)
    obj.location = at
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    mat, tree, _ = diffuse_material("Rock")
    O.add_layer_stack(tree)
    mesh.materials.append(mat)
    bpy.context.view_layer.update()
    return obj, mat


def _tree_state(mat):
    tree = mat.node_tree
    return (sorted(n.name for n in tree.nodes),
            sorted((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name,
                    lk.to_socket.identifier) for lk in tree.links),
            sorted(i.name for i in bpy.data.images), F.RECORD in mat)


def test_the_operator_reports_the_mesh_warnings_bake_normal_map_prints(fresh, registered,
                                                                         capfd):
    """Quads 1 and 2 on the same UV square, quad 3 collapsed to a UV line, 2 km out. Before:
    FINISHED and no warning. Now the three warnings, and the freeze done."""
    line = [(0.1, 0.1), (0.9, 0.1), (0.9, 0.1), (0.1, 0.1)]
    obj, mat = _quads(fresh, [SQUARE, SQUARE, line], at=(2000.0, 0.0, 0.0))
    registered(*FO.CLASSES)
    capfd.readouterr()
    assert bpy.ops.surfgrad.freeze_stack(resolution=SIZE) == {'FINISHED'}
    said = capfd.readouterr()
    warnings = [w for w in (said.out + said.err).splitlines() if "Warning" in w]
    assert F.RECORD in mat
    overlap = [w for w in warnings if "UV map 'UVMap' of object 'Quads': " in w and
               "of tile 1001's texels lie under more than one face" in w]
    far = [w for w in warnings if "object 'Quads' reaches 2004 m from the origin" in w]
    hole = [w for w in warnings if "UV map 'UVMap' of object 'Quads': 1 face(s) with area on "
            "the mesh have none in UV space (their UVs collapsed to a point or a line: faces "
            "2), so the bake writes no texel for them" in w]
    assert len(overlap) == 1 and len(far) == 1 and len(hole) == 1, warnings
    # Texel centres inside both quads at 16^2: 12 x 12 in the 0.1-0.9 square, the 12 on the
    # diagonal both split along too (one face of each quad takes them; red team 50a): 144 / 256.
    assert "56% of tile 1001's texels" in overlap[0]


def test_freeze_refuses_faces_beyond_the_udim_tiles(fresh):
    """Quad 2 at u in [-0.9, -0.1]. Before: frozen, no word (bake-normal-map: exit 1). Now
    refused with the fix, nothing changed."""
    obj, mat = _quads(fresh, [SQUARE, [(u - 1.0, v) for u, v in SQUARE]])
    before = _tree_state(mat)
    with pytest.raises(F.FreezeError) as err:
        F.freeze(obj, SIZE)
    assert str(err.value) == (
        "UV map 'UVMap' of 'Quads' has faces outside the 0-1 UV square: a frozen stack is one "
        "image of that square; pick (or unwrap) a UV map inside it")
    assert _tree_state(mat) == before


def test_freeze_refuses_to_save_over_an_image_the_material_reads(fresh, tmp_path):
    """Before: with Overwrite the base colour texture's file became the normal map. Now
    refused as bake-normal-map refuses it; the file and the material as they were."""
    obj, mat = _quads(fresh, [SQUARE])
    colour = bpy.data.images.new("colour", 4, 4)
    colour.pixels.foreach_set(np.tile([0.8, 0.2, 0.1, 1.0], 16).astype(np.float32))
    path = tmp_path / "rock.png"
    colour.filepath_raw, colour.file_format = str(path), "PNG"
    colour.save()
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = colour
    bsdf = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    mat.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Color"])
    data, before = path.read_bytes(), _tree_state(mat)
    with pytest.raises(F.FreezeError) as err:
        F.freeze(obj, SIZE, filepath=str(path), overwrite=True)
    assert str(err.value) == (
        f"output {str(path)!r} is the file of image 'colour', which material 'Rock' reads: "
        f"the bake would replace its own input; write the map to another file")
    assert path.read_bytes() == data and _tree_state(mat) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rock.png"]


BLEND_IN_STACK = """
import sys, bpy
from surfgrad_addon import api
from surfgrad_addon.addon import groups as G
from surfgrad_addon.addon.compat import new_material
from surfgrad_addon.addon.enum_input import set_choice
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_plane_add(size=2)
mat = new_material("Rock")
bpy.context.object.data.materials.append(mat)
stack = api.add_layer_stack(mat)
blend = mat.node_tree.nodes.new("ShaderNodeGroup")
blend.node_tree, blend.name = G.blend_normals_group(), "RNM blend"
set_choice(blend.inputs["Method"], 3)
mat.node_tree.links.new(blend.outputs[0], stack["normal_map"].inputs["Color"])
"""
SAVE = "bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])\n"


@pytest.mark.tier("child")
def test_freeze_refuses_a_node_this_line_cannot_evaluate(fresh, tmp_path):
    """On 4.5, a 5.2 file's SG Blend Normals in the stack. Before: frozen (as zero). Now
    refused naming the node, nothing changed. 5.0 and 5.2 (built here: no child) freeze it."""
    if running_line().menu_sockets:
        exec(BLEND_IN_STACK, {})
        obj = bpy.data.objects["Plane"]
        assert F.check(obj, SIZE)[0] == bpy.data.materials["Rock"]
        return
    if running_line().line == "4.2":      # reads no 5.x file (test_faults_artist34.py)
        return
    if not _open_saved_on_52(tmp_path, BLEND_IN_STACK + SAVE):
        return
    obj, mat = bpy.data.objects["Plane"], bpy.data.materials["Rock"]
    before = _tree_state(mat)
    with pytest.raises(F.FreezeError) as err:
        F.freeze(obj, SIZE)
    assert (f"material 'Rock' uses node(s) 'Menu Switch' in node group 'SG Blend Normals' "
            f"that Blender {bpy.app.version_string} cannot evaluate") in str(err.value)
    assert _tree_state(mat) == before


def _instance_second_quad(obj):
    """Geometry Nodes: face 1 becomes an unrealized instance, face 0 stays mesh."""
    ng, gi, go = geometry_group("Instance one")
    n = ng.nodes
    index, equal = n.new("GeometryNodeInputIndex"), n.new("FunctionNodeCompare")
    equal.data_type, equal.operation = "INT", "EQUAL"
    a, b = [s for s in equal.inputs if s.type == "INT"][:2]      # (4.2: every type's; 5.x: two)
    b.default_value = 1
    split = n.new("GeometryNodeSeparateGeometry")
    split.domain = "FACE"
    inst, join = n.new("GeometryNodeGeometryToInstance"), n.new("GeometryNodeJoinGeometry")
    ng.links.new(index.outputs[0], a)
    ng.links.new(gi.outputs[0], split.inputs["Geometry"])
    ng.links.new(equal.outputs[0], split.inputs["Selection"])
    ng.links.new(split.outputs["Selection"], inst.inputs[0])
    ng.links.new(split.outputs["Inverted"], join.inputs[0])
    ng.links.new(inst.outputs[0], join.inputs[0])
    ng.links.new(join.outputs[0], go.inputs[0])
    obj.modifiers.new("Instance one", "NODES").node_group = ng
    bpy.context.view_layer.update()


def test_freeze_refuses_instances_of_its_material_the_bake_leaves_out(fresh):
    """Before: frozen, the instanced quad's half of the map flat. Now refused, nothing
    changed; the fix it names (Realize Instances) freezes."""
    left = [(0.05 + 0.4 * u, v) for u, v in SQUARE]
    obj, mat = _quads(fresh, [left, [(u + 0.5, v) for u, v in left]])
    _instance_second_quad(obj)
    before = _tree_state(mat)
    with pytest.raises(F.FreezeError) as err:
        F.freeze(obj, SIZE)
    text = str(err.value)
    assert text.startswith("object 'Quads' renders 1 unrealized instance(s) of ") and (
        "(1 faces), which Blender's bake leaves out (it bakes only the realized mesh); they "
        "use its material(s) on ") in text and text.endswith(
        "that the realized mesh leaves empty, so the map would lack them: add a Realize "
        "Instances node before the Group Output of its Geometry Nodes (or apply the modifier, "
        "or Object > Apply > Make Instances Real)")
    assert "allow-partial" not in text and _tree_state(mat) == before
    ng = obj.modifiers[0].node_group
    realize = ng.nodes.new("GeometryNodeRealizeInstances")
    ng.links.new(ng.nodes["Join Geometry"].outputs[0], realize.inputs[0])
    ng.links.new(realize.outputs[0], ng.nodes["Group Output"].inputs[0])
    bpy.context.view_layer.update()
    assert F.check(obj, SIZE)[0] == mat


def test_freeze_names_a_mesh_made_all_of_instances(fresh):
    """Before: "UV map 'UVMap' ... is not on the mesh as it renders". Now the instances."""
    obj, mat = _quads(fresh, [SQUARE])
    ng, gi, go = geometry_group("All instances")
    inst = ng.nodes.new("GeometryNodeGeometryToInstance")
    ng.links.new(gi.outputs[0], inst.inputs[0])
    ng.links.new(inst.outputs[0], go.inputs[0])
    obj.modifiers.new("All instances", "NODES").node_group = ng
    bpy.context.view_layer.update()
    with pytest.raises(F.FreezeError) as err:
        F.check(obj, SIZE)
    assert str(err.value) == (
        "object 'Quads' renders all its faces as 1 unrealized instance(s) and Blender's bake "
        "renders only the realized mesh, which has none: add a Realize Instances node before "
        "the Group Output of its Geometry Nodes (or apply the modifier, or Object > Apply > "
        "Make Instances Real)")


def test_freeze_refuses_a_bake_larger_than_the_machine(fresh, monkeypatch):
    """Before: check passed at 16384 (the bake would be killed). Now refused, nothing
    changed; 8192 (11.3 GB) passes."""
    gb = 1024 ** 3
    machine_without_swap(monkeypatch, 24 * gb, gb // 2)
    obj, mat = _quads(fresh, [SQUARE])
    before = _tree_state(mat)
    with pytest.raises(F.FreezeError) as err:
        F.check(obj, 16384)
    assert str(err.value) == (
        "a 16384x16384 bake of 1 tile(s) needs at least 45.0 GB of memory beyond the 0.5 GB "
        "this process holds, more than this machine's 24.0 GB of memory and 0.0 GB of swap, "
        "where the system would kill the bake: bake at a lower Resolution, or on a machine "
        "with more memory")
    assert _tree_state(mat) == before
    assert F.check(obj, 8192)[0] == mat


def test_the_noise_reference_hashes_cells_millions_apart():
    """Two points 2.4e6 cells apart on every axis (a box of 1.4e19 cells, between 2^63 and
    2^64): before, ValueError (np.prod wrapped to a negative count). Now each point's value
    and gradient as when evaluated alone."""
    from surfgrad_addon.reference.noise import gradient_noise
    p = np.array([[0.3, 0.6, 0.2], [2.4e6 + 0.7, -2.4e6 + 0.1, 2.4e6 + 0.45]])
    value, gradient = gradient_noise(p)
    for i in range(2):
        alone = gradient_noise(p[i:i + 1])
        assert value[i] == alone[0][0] and np.array_equal(gradient[i], alone[1][0])
    assert np.all(np.isfinite(gradient)) and np.abs(value).max() > 0


def test_compare_of_filtered_noise_on_a_mesh_2e5_m_across(fresh):
    """The user route (compare's own function; the CLI calls it). Before: a raw ValueError."""
    import mathutils
    from support.small_objects import scaled_test_object
    from surfgrad_addon.harness import compare
    obj = scaled_test_object("Sphere", 1.0)
    obj.data.transform(mathutils.Matrix.Scale(1e5, 4))
    report = compare.compare_object(obj, "volume-noise-filtered", SIZE, log=None)[0]
    assert report["texels_compared"] > 150 and report["p99_deg"] < 0.1, report
