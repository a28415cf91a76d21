"""Round 53 (helper rt53a): the deform warnings and Freeze's object-space check on shapes an
artist's file can hold, and compare's refusal of an --image its method drops.

1. Absolute shape keys (Relative unticked: the mesh is the keys interpolated at the Evaluation
   Time along their frames). deformed_mesh.mixed_shape_keys looked at relative keys alone: a
   two-quad strip with an absolute key folding the second quad 60 degrees, Evaluation Time on
   its frame (10), baked object space that quad 60.0 degrees from the basis map, exit 0 and no
   word (Evaluation Time 5: 40.9 degrees, no word). Now the absolute keys are interpolated as
   Blender does (linear, cardinal, Catmull-Rom, B-spline, mixed; here within 1e-5 m of the
   evaluated mesh, 4 keys, 10 times, 6 mixes) and the bake warns, naming the Evaluation Time,
   the keys and the fix (Evaluation Time to the basis's frame); at the basis, no word.

2. The posed-armature warning (deformed_mesh.posed_armature_warning) looked at every bone.
   a. A bone no vertex is weighted to (a control or IK bone), turned 57.3 degrees: every face
      stays (0.0 degrees evaluated), yet it warned "a bone turned up to 57.3 degrees". Now only
      the deforming bones some vertex follows count: no warning; weighted, warned.
   b. Its root-motion check (_one_shift, round 52b) took every bone shifted alike for a rigid
      move; a vertex weighted to no bone stays at rest, so the face holding it turned 19.5
      degrees (evaluated) with no word. Now the rigid shift holds only where every vertex
      follows a bone (and no vertex-group mask): warned, "bones moved from their rest, none
      turned"; with the vertex weighted, no warning (0.0 degrees evaluated).

3. Freeze's object-space readers (freeze.object_space_readers) took only SG groups by name: the
   layered stack's SG Noise wrapped in the artist's own group ('My Noise'), the strip posed
   60 degrees, froze a map whose second quad lay 30.4 degrees (median) from the map frozen at
   rest with no warning (unwrapped: warned, tests/test_faults_deform51a.py). Now a group is
   looked into (what reaches its Group Output, at any depth): warned, naming the wrapper; a
   wrapper whose noise reads its Vector from the group's input gets no warning.

4. `compare --image X --method height-map` (any method that reads no normal map) was refused
   only after the bake and the comparison (compare_object read which images the reference had
   read). Now it is refused before the file opens and before any bake (compare_graph is never
   called; no JSON written), from the registry's declared reads (MethodSpec.reads), which
   tests/test_faults_reads53a.py holds to what each reference reads and the test below to what
   each method's graph reads.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon.deformed_mesh import (posed_armature_warning,  # noqa: E402
                                                shape_key_warning)
from surfgrad_addon.harness import compare  # noqa: E402
from surfgrad_addon.harness.methods import METHODS  # noqa: E402
from support.baked_normals import baked_normals, degrees_between  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from test_faults_assets50d import _pose, _skinned_strip, strip  # noqa: E402

pytestmark = pytest.mark.tier("blender")

RES = 16
FOLD_DEG = 60.0
INTERPOLATIONS = ("KEY_LINEAR", "KEY_CARDINAL", "KEY_CATMULL_ROM", "KEY_BSPLINE")


def _evaluated(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    return np.array([v.co[:] for v in obj.evaluated_get(dg).data.vertices])


def _face_turns(obj, co):
    """Degrees each face of obj at positions co lies from its stored (basis) normal."""
    basis = np.array([v.co[:] for v in obj.data.vertices])
    out = []
    for poly in obj.data.polygons:
        ids = list(poly.vertices)
        a, b = (np.cross(c[ids], np.roll(c[ids], -1, axis=0)).sum(0) for c in (basis, co))
        cos = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
        out.append(float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))))
    return out


# 1 --------------------------------------------------------------------------------------------

def _absolute_strip():
    """The strip (quads at x 0..1, 1..2) with an absolute key 'Fold' (frame 10) lifting x = 2
    by sqrt(3): the second quad folded 60 degrees."""
    obj = strip("Body")
    obj.shape_key_add(name="Basis")
    fold = obj.shape_key_add(name="Fold", from_mix=False)
    for i in (4, 5):
        fold.data[i].co.z += np.sqrt(3.0)
    obj.data.shape_keys.use_relative = False
    return obj


def test_absolute_keys_are_measured_as_blender_evaluates_them():
    obj = strip("Body")
    obj.shape_key_add(name="Basis")
    rng = np.random.default_rng(53)
    for n in range(3):
        key = obj.shape_key_add(name=f"K{n}", from_mix=False)
        for v in key.data:
            v.co = np.array(v.co) + rng.normal(size=3) * 0.3
    keys = obj.data.shape_keys
    keys.use_relative = False
    said = 0
    for mix in [(k,) * 4 for k in INTERPOLATIONS] + [INTERPOLATIONS, INTERPOLATIONS[::-1]]:
        for block, kind in zip(keys.key_blocks, mix):
            block.interpolation = kind
        for time in (-3.0, 0.0, 2.5, 5.0, 10.0, 13.3, 20.0, 27.0, 30.0, 40.0):
            keys.eval_time = time
            worst = max(_face_turns(obj, _evaluated(obj)))
            text = shape_key_warning(obj)
            if worst < 0.01:
                assert text is None, (mix, time, text)
                continue
            said += 1
            assert f"up to {worst:.1f} degrees" in text, (mix, time, worst, text)
            assert f"Evaluation Time {keys.eval_time:g}" in text, text      # (0 at least)
            assert "set Evaluation Time to 'Basis''s frame (0)" in text, text
            assert ("Interpolation to Linear" in text) == ("KEY_BSPLINE" in mix), (mix, text)
    assert said > 40


def test_a_pinned_absolute_key_is_measured_as_shown():
    obj = _absolute_strip()
    obj.show_only_shape_key = True
    obj.active_shape_key_index = 1
    assert max(_face_turns(obj, _evaluated(obj))) == pytest.approx(FOLD_DEG, abs=1e-3)
    text = shape_key_warning(obj)
    assert "(pinned: Shape Key Lock)" in text and "60.0 degrees" in text, text
    assert "Shape Key Lock" in text.split(": ", 1)[1], text


@pytest.mark.tier("bake")
def test_an_object_space_bake_of_absolute_keys_off_the_basis_warns(tmp_path, capfd):
    obj = _absolute_strip()
    flat = np.array([0.0, 0.0, 1.0])
    basis = baked_normals(obj, tmp_path / "basis.exr", "object", RES)      # Evaluation Time 0
    assert "shape keys" not in capfd.readouterr().err
    assert degrees_between(basis, flat).max() < 0.5
    obj.data.shape_keys.eval_time = 10.0
    folded = baked_normals(obj, tmp_path / "fold.exr", "object", RES)
    err = capfd.readouterr().err
    off = degrees_between(folded, basis)
    assert off[:, : RES // 2 - 1].max() < 0.5                              # the first quad stays
    assert abs(np.median(off[:, RES // 2 + 1:]) - FOLD_DEG) < 1.0          # the second folded
    assert "object 'Body'" in err and "Evaluation Time 10" in err and "'Fold' at 1" in err, err
    assert "60.0 degrees" in err and "set Evaluation Time to 'Basis''s frame (0)" in err, err


# 2 --------------------------------------------------------------------------------------------

def _with_bone(obj, arm, name, head, tail):
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    bone = arm.data.edit_bones.new(name)
    bone.head, bone.tail = head, tail
    bpy.ops.object.mode_set(mode="OBJECT")


def _warning(obj):
    return posed_armature_warning(obj, bpy.context.evaluated_depsgraph_get())


def test_a_posed_bone_no_vertex_follows_is_not_warned_about():
    obj, arm = _skinned_strip()
    _with_bone(obj, arm, "Control", (0, 1, 0), (0, 2, 0))
    pb = arm.pose.bones["Control"]
    pb.rotation_mode = "XYZ"
    pb.rotation_euler = (1.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    assert max(_face_turns(obj, _evaluated(obj))) < 1e-6
    assert _warning(obj) is None
    # Weighted (vertex 5, the strip's far corner): the second quad bends, and it is warned of.
    obj.vertex_groups["B"].remove([5])
    obj.vertex_groups.new(name="Control").add([5], 1.0, "REPLACE")
    assert max(_face_turns(obj, _evaluated(obj))) > 10.0
    assert "a bone turned up to 57.3 degrees" in _warning(obj)


def test_a_root_shift_past_a_vertex_weighted_to_no_bone_is_warned_about():
    obj, arm = _skinned_strip()
    obj.vertex_groups["A"].remove([0])             # vertex 0 follows no bone: it stays
    arm.pose.bones["A"].location = (0.0, 0.0, 0.5)   # the root shifts; B, its child, with it
    bpy.context.view_layer.update()
    assert max(_face_turns(obj, _evaluated(obj))) == pytest.approx(19.47, abs=0.01)
    text = _warning(obj)
    assert text and "bones moved from their rest, none turned" in text, text
    obj.vertex_groups["A"].add([0], 1.0, "REPLACE")  # every vertex follows: a rigid move
    assert max(_face_turns(obj, _evaluated(obj))) < 1e-4
    assert _warning(obj) is None


# 3 --------------------------------------------------------------------------------------------

def _wrap_noise(tree, vector_from_input=False):
    """The stack's SG Noise moved into the artist's group 'My Noise' (its Gradient out; with
    `vector_from_input`, its Vector read from the group's own input, fed the UV)."""
    noise = next(n for n in tree.nodes if n.type == "GROUP" and
                 n.node_tree.name.startswith("SG Noise"))
    group = bpy.data.node_groups.new("My Noise", "ShaderNodeTree")
    group.interface.new_socket("Gradient", in_out="OUTPUT", socket_type="NodeSocketVector")
    inner = group.nodes.new("ShaderNodeGroup")
    inner.node_tree = noise.node_tree
    inner.inputs["Scale"].default_value = 3.0
    group.links.new(inner.outputs["Gradient"], group.nodes.new("NodeGroupOutput").inputs[0])
    wrapper = tree.nodes.new("ShaderNodeGroup")
    wrapper.name = "My Noise"
    if vector_from_input:
        group.interface.new_socket("Vector", in_out="INPUT", socket_type="NodeSocketVector")
        group.links.new(group.nodes.new("NodeGroupInput").outputs[0], inner.inputs["Vector"])
    wrapper.node_tree = group
    if vector_from_input:
        uv = tree.nodes.new("ShaderNodeUVMap")
        tree.links.new(uv.outputs[0], wrapper.inputs["Vector"])
    for link in list(noise.outputs["Gradient"].links):
        tree.links.new(wrapper.outputs[0], link.to_socket)
    tree.nodes.remove(noise)


def _frozen(obj, wrap):
    mat, _bsdf = layered_material(obj)
    wrap(mat.node_tree)
    said = []
    F.freeze(obj, 32, log=lambda *_: None, warn=said.append)
    image = next(i for i in bpy.data.images if "frozen" in i.name)
    px = np.array(image.pixels[:]).reshape(32, 32, 4)[..., :3] * 2.0 - 1.0
    return px / np.linalg.norm(px, axis=-1, keepdims=True), said


@pytest.mark.tier("bake")
def test_freezing_posed_through_a_wrapped_noise_warns():
    obj, _arm = _skinned_strip()
    rest, quiet = _frozen(obj, _wrap_noise)
    assert quiet == []
    obj, arm = _skinned_strip()
    _pose(arm, FOLD_DEG)
    posed, said = _frozen(obj, _wrap_noise)
    off = degrees_between(posed, rest)
    assert off[:, :15].max() < 0.01 and np.median(off[:, 17:]) > 10.0, np.median(off[:, 17:])
    (text,) = [w for w in said if "armature" in w]
    assert "'My Noise' (My Noise)" in text and "Rest Position" in text, text


def test_a_wrapper_fed_coordinates_from_outside_is_no_object_space_reader():
    for vector_from_input, expected in ((False, ["'My Noise' (My Noise)"]), (True, [])):
        obj, _arm = _skinned_strip()
        mat, _bsdf = layered_material(obj)
        _wrap_noise(mat.node_tree, vector_from_input)
        _end, fed = F.find_stack(mat.node_tree)
        assert F.object_space_readers(mat.node_tree, fed) == expected


# 4 --------------------------------------------------------------------------------------------

def test_compare_refuses_an_unread_image_before_the_file_opens_and_any_bake(tmp_path,
                                                                           monkeypatch):
    def no_bake(*_a, **_k):
        raise AssertionError("compare baked")
    monkeypatch.setattr(compare, "compare_graph", no_bake)
    json_out = tmp_path / "r.json"
    for method in ("height-map", "triplanar-height", "volume-noise", "height-blend"):
        with pytest.raises(compare.CompareError, match=rf"method '{method}' reads no normal "
                           r"map, so --image would change nothing: leave --image out"):
            # The .blend is not there: refused before it is looked for.
            compare.run(str(tmp_path / "none.blend"), "Sphere", method, 16, json_out,
                        image=str(tmp_path / "rock_nrm.png"))
        from surfgrad_addon.harness import scenes
        scenes.new_scene()
        with pytest.raises(compare.CompareError, match="reads no normal map"):
            compare.compare_object(bpy.data.objects["Sphere"], method, 16,
                                   image=str(tmp_path / "rock_nrm.png"), log=None)
    assert not json_out.exists()
    # A method that reads one is let through to its image (missing here: named).
    with pytest.raises(compare.CompareError) as err:
        compare.run(str(tmp_path / "none.blend"), "Sphere", "normal-map", 16, json_out,
                    image=str(tmp_path / "rock_nrm.png"))
    assert "reads no normal map" not in str(err.value)


def test_every_methods_graph_reads_the_images_it_declares():
    from surfgrad_addon.harness import scenes
    from support.materials import diffuse_material
    checked = 0
    for name, m in sorted(METHODS.items()):
        if m.unavailable_reason() is not None:
            continue
        for variant in m.variants:
            scenes.new_scene()
            obj = bpy.data.objects["Sphere"]
            inp = compare.prepare_inputs(obj, None, None, variant)
            read, given = set(), inp.bpy_image
            inp.bpy_image = lambda key, given=given, read=read: (read.add(key), given(key))[1]
            _mat, tree, _bsdf = diffuse_material(f"{name}-{variant}")
            with m.scene(obj, inp):
                m.graph(inp, tree.nodes, tree.links)
            assert read == set(m.reads), (name, variant, sorted(read), m.reads)
            checked += 1
    assert checked >= 20
