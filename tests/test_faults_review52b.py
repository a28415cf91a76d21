"""Review rt52b, round 52: the shape-key warning (deformed_mesh.shape_key_warning) under Shape
Key Lock (the pin that shows the active key alone), against what Blender evaluates.

1. A pinned key that is muted: Blender shows the basis (the evaluated plane stays flat, 0.0
   degrees), yet bake-normal-map --space object warned "shape keys mixed in (pinned: Shape Key
   Lock) ('Fold' at 1) that turn its faces up to 19.5 degrees": a false warning on every line.
   Now: no warning (mixed_shape_keys skips a muted pin).
2. A pinned key whose Relative To is not the basis (here itself): Blender shows the key as it
   is stored, so the evaluated quad turned 19.5 degrees, but the check took the key's delta
   from its Relative To (0) and warned of nothing: an object-space map of the pinned shape
   with no word. Now the pin is measured from the basis: 19.5 degrees, as evaluated.
3. Keys mixed through one vertex group: the Python walk of every vertex's groups ran once per
   key (0.7 s a key at 500k vertices, before every object-space bake; six keys took 3.3x one
   key's time at 250k); now once per group (1.5x).
4. posed_armature_warning on a pose that only shifts the whole rig (root motion, no bone
   turned): every face keeps its normal (0.0 degrees evaluated), yet it warned "a bone turned
   up to 0.0 degrees ... reads back right in this pose alone". Now no warning; a bone moved
   against another (faces turned > 10 degrees) is still warned of.
5. Freeze's object-space readers (freeze.object_space_readers) took a Texture Coordinate node
   whose UV feeds the stack as one because its Object output was linked at all, here to the
   Base Color's noise: Freeze on a shape-keyed plane warned "the stack reads object-space
   positions or normals ('Texture Coordinate')", which it does not. Now only an output that
   leads into the stack counts; linking Object into the stack's image still warns.
6. The raw-image-in-normal-input warning on the Normal node (ShaderNodeNormal), whose input is
   a vector it dots with: an image there (Dot into Roughness) was warned "every normal leans
   toward (1, 1, 1) and the bake takes them so", where the bake came out flat (< 0.05 deg).
   Now the Normal node is not taken for a normal input.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon.deformed_mesh import shape_key_warning  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _plane_with_key():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("Quad")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    obj = bpy.data.objects.new("Quad", mesh)
    bpy.context.scene.collection.objects.link(obj)
    basis = obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Fold", from_mix=False)
    key.data[0].co.z += 1.0
    key.value = 0.0
    return obj, basis, key


def _evaluated_turn(obj):
    """Degrees between the quad's Newell normal as Blender evaluates it and the basis's (z)."""
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    co = np.array([v.co[:] for v in obj.evaluated_get(dg).data.vertices])
    n = np.cross(co, np.roll(co, -1, axis=0)).sum(0)
    return float(np.degrees(np.arccos(n[2] / np.linalg.norm(n))))


def test_a_muted_pinned_key_shows_the_basis_and_is_not_warned_about():
    obj, _, key = _plane_with_key()
    key.mute = True
    obj.show_only_shape_key = True
    obj.active_shape_key_index = 1
    assert _evaluated_turn(obj) == pytest.approx(0.0, abs=1e-6)
    assert shape_key_warning(obj) is None
    key.mute = False                   # the same pin unmuted: shown, and warned of
    assert _evaluated_turn(obj) == pytest.approx(19.47, abs=0.01)
    assert "up to 19.5 degrees" in shape_key_warning(obj)


def test_a_pinned_key_is_measured_as_shown_not_from_its_relative_to():
    obj, _, key = _plane_with_key()
    key.relative_key = key
    obj.show_only_shape_key = True
    obj.active_shape_key_index = 1
    turn = _evaluated_turn(obj)
    assert turn == pytest.approx(19.47, abs=0.01)
    warning = shape_key_warning(obj)
    assert warning is not None and f"up to {turn:.1f} degrees" in warning, warning
    obj.show_only_shape_key = False   # unpinned at value 0: nothing mixed, nothing said
    assert _evaluated_turn(obj) == pytest.approx(0.0, abs=1e-6)
    assert shape_key_warning(obj) is None


def test_keys_sharing_a_vertex_group_walk_the_mesh_once():
    """3. Six keys mixed through one vertex group (a face rig's L/R split) on a 250k-vertex
    grid: the check walked every vertex's groups in Python once per key (0.7 s a key at 500k
    vertices, before every object-space bake); now once per group. Measured as the time of
    six keys against one (each key's numpy work is small beside the walk)."""
    import time
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=500, y_subdivisions=500)
    obj = bpy.context.object
    n = len(obj.data.vertices)
    group = obj.vertex_groups.new(name="Left")
    group.add(list(range(0, n, 2)), 0.5, "REPLACE")
    obj.shape_key_add(name="Basis")
    co = np.empty(n * 3)
    obj.data.shape_keys.key_blocks[0].data.foreach_get("co", co)
    keys = []
    for k in range(6):
        key = obj.shape_key_add(name=f"Corrective {k}", from_mix=False)
        moved = co.copy()
        moved[2::3] += 0.1 * np.sin(np.arange(n) * 0.01 * (k + 1))
        key.data.foreach_set("co", moved)
        key.vertex_group = "Left"
        key.value = 0.0
        keys.append(key)

    def seconds():
        start = time.perf_counter()
        assert shape_key_warning(obj) is not None
        return time.perf_counter() - start

    keys[0].value = 1.0
    one = min(seconds() for _ in range(2))
    for key in keys:
        key.value = 1.0
    six = min(seconds() for _ in range(2))
    assert six < 2.0 * one, (six, one)


def _rigged_strip():
    """A strip of two quads along x, its left half weighted to bone 'root', its right half to
    'tip' (root's child); returns (mesh object, armature object)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("Strip")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)], [],
                     [(0, 1, 4, 3), (1, 2, 5, 4)])
    obj = bpy.data.objects.new("Strip", mesh)
    rig = bpy.data.armatures.new("Rig")
    arm = bpy.data.objects.new("Rig", rig)
    for o in (obj, arm):
        bpy.context.scene.collection.objects.link(o)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    root = rig.edit_bones.new("root")
    root.head, root.tail = (0, 0.5, 0), (1, 0.5, 0)
    tip = rig.edit_bones.new("tip")
    # the tip far out (its matrix's entries ~40): one shift of every bone is one all the same
    tip.head, tip.tail, tip.parent = (40, 0.5, 0), (41, 0.5, 0), root
    bpy.ops.object.mode_set(mode="OBJECT")
    obj.modifiers.new("Armature", "ARMATURE").object = arm
    obj.vertex_groups.new(name="root").add([0, 3], 1.0, "REPLACE")
    obj.vertex_groups.new(name="tip").add([1, 2, 4, 5], 1.0, "REPLACE")
    return obj, arm


def _largest_face_turn(obj, dg):
    dg.update()
    normals = [p.normal.z for p in obj.evaluated_get(dg).data.polygons]
    return max(float(np.degrees(np.arccos(np.clip(z, -1, 1)))) for z in normals)


def test_a_pose_that_only_shifts_the_whole_rig_is_not_warned_about():
    """4. The root bone moved 0.3 m (root motion), nothing turned: the skin moves rigidly and
    every face keeps its normal (0.0 degrees, as Blender evaluates it), so the object-space
    map is the rest pose's; the bake warned "a pose other than its rest pose (a bone turned
    up to 0.0 degrees) ... reads back right in this pose alone". Now: no warning; a pose
    that moves one bone against another (faces turn) is still warned of."""
    from surfgrad_addon.addon.deformed_mesh import posed_armature_warning
    obj, arm = _rigged_strip()
    dg = bpy.context.evaluated_depsgraph_get()
    arm.pose.bones["root"].location = (0.0, 0.3, 0.0)
    assert _largest_face_turn(obj, dg) == pytest.approx(0.0, abs=1e-4)
    assert posed_armature_warning(obj, dg) is None
    arm.pose.bones["tip"].location = (0.0, 0.0, 0.5)       # the tip lifted: faces turn
    assert _largest_face_turn(obj, dg) > 10.0
    assert "in a pose other than its rest pose" in (posed_armature_warning(obj, dg) or "")


def test_a_texture_coordinate_node_shared_with_the_base_colour_is_no_stack_reader():
    from surfgrad_addon import api
    from surfgrad_addon.addon import freeze as F
    obj, _, key = _plane_with_key()
    key.value = 1.0
    mat = bpy.data.materials.new("Shared Coordinates")
    mat.use_nodes = True
    obj.data.materials.append(mat)
    tree = mat.node_tree
    made = api.add_layer_stack(mat)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.new("Detail Normals", 4, 4)
    tex.image.colorspace_settings.is_data = True
    tree.links.new(coords.outputs["UV"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Color"], made["normal_map"].inputs["Color"])
    noise = tree.nodes.new("ShaderNodeTexNoise")
    tree.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    tree.links.new(noise.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    _, fed = F._fed(tree, tree.nodes["Material Output"], rendered=True)
    assert F.object_space_readers(tree, fed) == []
    tree.links.new(coords.outputs["Object"], tex.inputs["Vector"])    # now the stack reads it
    assert F.object_space_readers(tree, fed) == [repr(coords.name)]


@pytest.mark.tier("bake")
def test_an_image_dotted_by_a_normal_node_is_not_a_raw_normal(tmp_path, capfd):
    """6. An image's colour into the Normal node's input (a vector it dots with: Dot feeds the
    Roughness here) was warned "wired straight into the Normal input of node 'Normal' ... every
    normal leans toward (1, 1, 1) and the bake takes them so"; the bake is flat (under 0.05
    degrees from (0, 0, 1)), the BSDF's Normal unlinked. Now no warning there."""
    from surfgrad_addon import api
    from test_faults_raw_normal50 import _plane_reading
    obj, mat, tree, bsdf, tex = _plane_reading()
    dot = tree.nodes.new("ShaderNodeNormal")
    tree.links.new(tex.outputs["Color"], dot.inputs["Normal"])
    tree.links.new(dot.outputs["Dot"], bsdf.inputs["Roughness"])
    res, out = 8, tmp_path / "n.exr"
    api.bake_normal_map(obj, str(out), resolution=res, margin=0, log=None)
    assert "wired straight into" not in capfd.readouterr().err
    img = bpy.data.images.load(str(out))
    px = np.array(img.pixels[:]).reshape(res, res, 4)[..., :3] * 2.0 - 1.0
    px /= np.linalg.norm(px, axis=-1, keepdims=True)
    assert np.degrees(np.arccos(np.clip(px[..., 2], -1, 1))).max() < 0.05
