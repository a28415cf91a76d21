"""Round 51 (helper rt51a): what an artist's layer stack and an object-space bake take from
the mesh and the node they replace.

1. Add Layer Stack (addon/operators.py add_layer_stack, api.add_layer_stack) replaced the link
   into the shader's Normal with a new stack whose SG Normal Map read the active render UV
   map, also where the replaced link came from a tangent-space Normal Map node on another UV
   map (a glTF import with its normal map on TEXCOORD_1: uv_map 'UVMap.001'). The artist's
   map plugged into the stack then turned with the wrong UV map's tangents: here a plane
   whose second UV map is the first turned 90 degrees, a constant map tilted 30 degrees: the
   object-space bake of the stack lay 41.4 degrees (every texel) from the replaced node's, the
   tilt turned 90 degrees about the normal. Now the new SG Normal Map is the per-map group of
   the replaced node's UV map ("SG Normal Map [UVMap.001]"), the bake matches (0.0 degrees),
   and the operator's report says which UV map it reads; a UV map the artist gives wins.

2. An object-space bake of a mesh whose shape keys are mixed in (a key's value not 0 and not
   muted, or a pinned shape key (Shape Key Lock)) holds the mixed shape's normals, as a posed
   armature's does (red team 50d, addon/deformed_mesh.py), and reads back right on that mix
   alone, not on the basis an engine's morph targets start from. Here a two-quad strip with a
   key folding the second quad 60 degrees, value 1: its texels 60.0 degrees (median) from the
   basis map, exit 0 and no word. Now bake-normal-map (the API, bake_request) warns, naming
   the object, the keys, and the fixes (set the values to 0 / unpin, or bake in tangent
   space); a muted key, a key at 0 or a key that moves nothing gives no warning.

3. Freeze (addon/freeze.py) bakes in tangent space only (bake_normal_tiles, tangent), which
   follows a pose or a mix: a stack of tangent-space layers frozen posed is the one frozen at
   rest. But a stack that reads object-space positions or normals (SG Noise with its Vector
   unlinked, triplanar, projector and decal coordinates, SG Object Normal, a Texture
   Coordinate Object / Geometry Position) looks them up where the pose or mix puts the
   surface: the freeze tests' layered stack (SG Normal Map + SG Noise) on the 50d skinned
   strip, its second bone turned 60 degrees, froze a map whose second quad lay 30.4 degrees
   (median; p90 59.2) from the map frozen at rest, exit 0 and no word; in the rest pose the
   frozen map no longer matched the live stack by that much. Now Freeze warns (check's warn,
   the operator's report), naming the object, the armature or the keys, the nodes that read
   object space and the fix (Rest Position / keys to 0 before freezing); a stack of
   tangent-space layers alone, or one at rest, gets no warning.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_assets50d import _pose, _skinned_strip, strip  # noqa: E402

from support.baked_normals import baked_normals, degrees_between  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16
TURN_DEG = 60.0
TILT_DEG = 30.0
FOLD_DEG = 60.0


def _bake(obj, path, space="object"):
    return baked_normals(obj, path, space, RES)


def _deg(a, b):
    return degrees_between(a, b)


# 1 --------------------------------------------------------------------------------------------

def _two_uv_plane():
    """A 2 x 2 plane (normal +Z); 'UVMap' the unit square along x, y (active, render);
    'UVMap.001' the same square turned 90 degrees (its u runs along +y)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("Plane")
    verts = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 0.0)]
    mesh.from_pydata(verts, [], [(0, 1, 2, 3)])
    first, second = mesh.uv_layers.new(name="UVMap"), mesh.uv_layers.new(name="UVMap.001")
    for loop in mesh.loops:
        x, y, _z = verts[loop.vertex_index]
        u, v = (x + 1) / 2 * 0.98 + 0.01, (y + 1) / 2 * 0.98 + 0.01
        first.data[loop.index].uv = (u, v)
        second.data[loop.index].uv = (v, 1.0 - u)
    mesh.uv_layers.active = first
    first.active_render = True
    obj = bpy.data.objects.new("Plane", mesh)
    bpy.context.scene.collection.objects.link(obj)
    mat, tree, bsdf = diffuse_material("Imported")
    obj.data.materials.append(mat)
    color = tree.nodes.new("ShaderNodeRGB")            # the artist's map: tilted along +u
    t = np.radians(TILT_DEG)
    color.outputs[0].default_value = (np.sin(t) / 2 + 0.5, 0.5, np.cos(t) / 2 + 0.5, 1.0)
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    nmap.uv_map = "UVMap.001"
    tree.links.new(color.outputs[0], nmap.inputs["Color"])
    tree.links.new(nmap.outputs[0], bsdf.inputs["Normal"])
    return obj, mat, color


def test_the_stack_keeps_the_replaced_normal_maps_uv_map(tmp_path):
    obj, mat, color = _two_uv_plane()
    before = _bake(obj, tmp_path / "node.exr")
    # Independent expectation: the tilt lies along UVMap.001's u, object +y.
    t = np.radians(TILT_DEG)
    assert _deg(before, np.array([0.0, np.sin(t), np.cos(t)])).max() < 0.5
    made = api.add_layer_stack(mat)
    group = made["normal_map"].node_tree
    assert made["replaced"] and made["uv_map"] == "UVMap.001"
    assert group.name == "SG Normal Map [UVMap.001]"
    assert [n.uv_map for n in group.nodes if n.bl_idname == "ShaderNodeNormalMap"] == ["UVMap.001"]
    mat.node_tree.links.new(color.outputs[0], made["normal_map"].inputs[0])
    after = _bake(obj, tmp_path / "stack.exr")
    assert _deg(after, before).max() < 0.5, _deg(after, before).max()


def test_a_uv_map_the_artist_gives_wins_and_the_report_names_the_kept_one(tmp_path):
    obj, mat, color = _two_uv_plane()
    made = api.add_layer_stack(mat, uv_map="UVMap")
    assert made["uv_map"] == "" and made["normal_map"].node_tree.name == "SG Normal Map [UVMap]"
    obj, mat, color = _two_uv_plane()
    reports = []
    op = type("Op", (), {"uv_map": "", "report": lambda self, kind, text: reports.append(text)})()
    assert O.SURFGRAD_OT_add_layer_stack.execute(op, _Context(obj)) == {"FINISHED"}
    assert any("reads UV map 'UVMap.001', as the replaced Normal Map node did" in r
               for r in reports), reports


class _Context:
    """What the operator reads of a context with no Shader Editor: the active object."""
    def __init__(self, obj):
        self.space_data = None
        self.object = obj


# 2 --------------------------------------------------------------------------------------------

def _keyed_strip():
    """Two flat quads along x (UVs: left half, right half) with a basis and a key 'Fold' that
    turns the second quad 60 degrees about the joint (x = 1), out of the plane."""
    obj = strip("Face")
    obj.shape_key_add(name="Basis")
    fold = obj.shape_key_add(name="Fold", from_mix=False)
    t = np.radians(FOLD_DEG)
    for i in (4, 5):
        y = obj.data.vertices[i].co.y
        fold.data[i].co = (1.0 + np.cos(t), y, np.sin(t))
    fold.value = 0.0
    return obj, fold


def test_an_object_space_bake_with_a_shape_key_mixed_in_warns(tmp_path, capfd):
    obj, fold = _keyed_strip()
    up = np.array([0.0, 0.0, 1.0])
    basis = _bake(obj, tmp_path / "basis.exr")
    assert _deg(basis, up).max() < 0.5
    assert "shape key" not in capfd.readouterr().err
    fold.value = 1.0
    mixed = _bake(obj, tmp_path / "mixed.exr")
    err = capfd.readouterr().err
    off = _deg(mixed, basis)
    assert off[:, : RES // 2 - 1].max() < 0.5                       # the first quad stays
    assert abs(np.median(off[:, RES // 2 + 1:]) - FOLD_DEG) < 1.0    # the second folded
    assert "object 'Face'" in err and "'Fold' at 1" in err and "60.0 degrees" in err, err
    assert "values to 0" in err and "tangent space" in err, err
    fold.value = 0.5                                                 # half: 30 degrees
    _bake(obj, tmp_path / "half.exr")
    assert "30.0 degrees" in capfd.readouterr().err


def test_a_pinned_shape_key_warns_even_at_value_0(tmp_path, capfd):
    obj, fold = _keyed_strip()
    obj.show_only_shape_key = True
    obj.active_shape_key_index = 1
    bpy.context.view_layer.update()
    pinned = _bake(obj, tmp_path / "pinned.exr")
    err = capfd.readouterr().err
    assert abs(np.median(_deg(pinned, np.array([0.0, 0.0, 1.0]))[:, RES // 2 + 1:])
               - FOLD_DEG) < 1.0                                     # the bake holds the key
    assert "Shape Key Lock" in err and "60.0 degrees" in err, err


def test_no_warning_muted_at_0_unmoved_or_in_tangent_space(tmp_path, capfd):
    obj, fold = _keyed_strip()
    fold.value = 1.0
    tangent = _bake(obj, tmp_path / "t.exr", "tangent")
    assert _deg(tangent, np.array([0.0, 0.0, 1.0])).max() < 0.5
    assert "shape key" not in capfd.readouterr().err
    fold.mute = True
    _bake(obj, tmp_path / "m.exr")
    assert "shape key" not in capfd.readouterr().err
    fold.mute = False
    still = obj.shape_key_add(name="Still", from_mix=False)          # moves nothing
    still.value = 1.0
    fold.value = 0.0
    _bake(obj, tmp_path / "s.exr")
    assert "shape key" not in capfd.readouterr().err


# 3 --------------------------------------------------------------------------------------------

def _frozen(obj, tree_edit=None):
    """Freeze obj's layered stack at 32^2: (the frozen map's unit normals, the warnings)."""
    mat, _bsdf = layered_material(obj)
    if tree_edit:
        tree_edit(mat.node_tree)
    warnings = []
    F.freeze(obj, 32, log=lambda *_: None, warn=warnings.append)
    image = next(i for i in bpy.data.images if "frozen" in i.name)
    px = np.array(image.pixels[:]).reshape(32, 32, 4)[..., :3] * 2.0 - 1.0
    return px / np.linalg.norm(px, axis=-1, keepdims=True), warnings


def _without_noise(tree):
    """The stack's SG Noise layer taken out: tangent-space layers alone."""
    combine = next(n for n in tree.nodes if n.type == "GROUP" and
                   n.node_tree.name.startswith("SG Combine"))
    for link in list(combine.inputs["B"].links):
        tree.links.remove(link)


def test_freezing_an_object_space_stack_posed_warns():
    obj, _arm = _skinned_strip()
    rest, quiet = _frozen(obj)
    assert quiet == []
    obj, arm = _skinned_strip()
    _pose(arm, TURN_DEG)
    bpy.context.scene.frame_set(4)
    posed, said = _frozen(obj)
    off = _deg(posed, rest)
    assert off[:, :15].max() < 0.01                                  # the first quad stays
    assert np.median(off[:, 17:]) > 10.0, np.median(off[:, 17:])      # the noise moved
    (text,) = [w for w in said if "armature" in w]
    assert "armature 'Rig'" in text and "frame 4" in text and "60.0 degrees" in text, text
    assert "(SG Noise)" in text and "Rest Position" in text and "freezing" in text, text


def test_freezing_tangent_layers_posed_or_at_rest_says_nothing():
    obj, _arm = _skinned_strip()
    rest, quiet = _frozen(obj, _without_noise)
    obj, arm = _skinned_strip()
    _pose(arm, TURN_DEG)
    posed, said = _frozen(obj, _without_noise)
    assert _deg(posed, rest).max() < 0.5                              # tangent space holds
    assert quiet == [] and not [w for w in said if "armature" in w], said


def test_freezing_an_object_space_stack_with_a_shape_key_mixed_in_warns():
    obj, fold = _keyed_strip()
    fold.value = 1.0
    _map, said = _frozen(obj)
    (text,) = [w for w in said if "shape keys" in w]
    assert "'Fold' at 1" in text and "(SG Noise)" in text and "values to 0" in text, text
