"""Red team 47a: what the normal-map bake (bake-normal-map, bake-batch, api.bake_normal_map)
makes of a material's shaders, after the Diffuse stand-ins of rounds 44 and 45
(addon/bake_closures.py).

1. A closure with no normal of its own added to a BSDF: Add Shader (Transparent BSDF, BSDF fed
   a normal map leaning 60 degrees) baked a zero vector (grey 0.5, not a unit normal) in every
   texel, so did Holdout, and Ray Portal on 5.2 (on 4.2 the Ray Portal pulled the map halfway
   to the surface's normal: 30 degrees off; mixed at 0.5 with the BSDF, 30 degrees off on 5.2
   and 4.2 alike), exit 0, where the BSDF renders the map. Now they are unlinked for the bake:
   every texel is the map.
2. A material linked from a library that a Geometry Nodes Set Material gives the object (no
   slot holds it) was baked as it was: its Principled BSDF fed the map 8.26 degrees flat, on
   5.2 and 4.2 alike, exit 0. Now its local users (the Set Material node) use a local copy of
   it for the bake, whose BSDFs stand in: every texel is the map, and after the bake (a failed
   one too) the node, the material, its users and the file's materials are as they were.
   Where a linked node group gives it, which cannot be pointed at a copy, the bake is refused
   naming the group and the fix (make it local), and nothing is written.
3. A Principled BSDF with a coat (Coat Weight 1) whose Coat Normal is not its Normal (unlinked:
   the surface's) renders the coat with that normal; the map holds its Normal (Cycles' own
   bake had averaged them: 27.9 degrees off the map), with no word of it. Now the bake warns,
   naming the material and the node (on stderr, in the API's and the batch's warnings).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import normal_bake  # noqa: E402
from surfgrad_addon.addon.exit_codes import BakeFailed  # noqa: E402
from support.geometry_nodes import set_material_group  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from test_faults_assets44 import _baked_normals, _tilted_plane  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _degrees_off(got, normal):
    return np.degrees(np.arccos(np.clip(got @ normal, -1.0, 1.0))).max()


@pytest.mark.parametrize("closure", ["ShaderNodeBsdfTransparent", "ShaderNodeHoldout",
                                     "ShaderNodeBsdfRayPortal"])
def test_a_closure_without_a_normal_added_to_a_bsdf_bakes_the_bsdfs(tmp_path, closure):
    """Finding 1: every texel is the map's normal (before: a zero vector, or on 4.2 a Ray
    Portal 30 degrees off), and the material is as it was."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    tree = mat.node_tree
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(tree.nodes.new(closure).outputs[0], add.inputs[0])
    tree.links.new(tree.nodes["Principled BSDF"].outputs[0], add.inputs[1])
    tree.links.new(add.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    before = material_dump(mat)
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    assert material_dump(mat) == before


def _linked_set_material(tmp_path, linked_group):
    """The plane, its slot a plain material, and a Set Material giving it the material of
    _tilted_plane linked from a library: the Set Material in a local group, or (linked_group)
    in a group linked from the library too. Returns (obj, the linked material, normal, the
    Geometry Nodes group)."""
    _, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    mat.name = name = "Library Material"
    tree = set_material_group(mat)
    group_name = tree.name
    library = str(tmp_path / "library.blend")
    bpy.data.libraries.write(library, {mat, tree}, fake_user=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2)
    obj = bpy.context.active_object
    with bpy.data.libraries.load(library, link=True) as (_, into):
        into.materials = [name]
        into.node_groups = [group_name] if linked_group else []
    linked = bpy.data.materials[name]
    slot = bpy.data.materials.new("Slot")
    slot.use_nodes = True                   # (4.2 and 4.5 make a material without a tree)
    obj.data.materials.append(slot)
    tree = bpy.data.node_groups[group_name] if linked_group else set_material_group(linked)
    obj.modifiers.new("GeometryNodes", "NODES").node_group = tree
    return obj, linked, normal, tree


def _state(linked, tree):
    return (material_dump(linked), linked.users, tree.users,
            [n.inputs["Material"].default_value for n in tree.nodes
             if n.bl_idname == "GeometryNodeSetMaterial"],
            sorted(m.name_full for m in bpy.data.materials), len(bpy.data.node_groups))


def test_a_linked_material_a_set_material_gives_bakes_through_a_local_copy(tmp_path,
                                                                          monkeypatch):
    """Finding 2: every texel is the map's normal (before: 8.26 degrees flat); after the bake,
    and after a bake that fails inside, everything is as it was."""
    obj, linked, normal, tree = _linked_set_material(tmp_path, linked_group=False)
    before = _state(linked, tree)
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    assert _state(linked, tree) == before

    def fails(*_):
        raise RuntimeError("the bake failed here")

    monkeypatch.setattr(normal_bake, "tangents_of", fails)
    with pytest.raises(BakeFailed, match="the bake failed here"):
        _baked_normals(obj, tmp_path / "failed.exr")
    assert _state(linked, tree) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["library.blend", "n.exr"]


def test_a_linked_material_a_linked_group_gives_is_refused(tmp_path):
    """Finding 2: the linked group cannot be pointed at a copy: refused naming the group and
    the fix (before: 8.26 degrees flat, exit 0); nothing is written or changed."""
    obj, linked, _, tree = _linked_set_material(tmp_path, linked_group=True)
    before = _state(linked, tree)
    with pytest.raises(ValueError, match="node group 'Set Material', linked from .*make the "
                                         "node group local"):
        _baked_normals(obj, tmp_path / "n.exr")
    assert _state(linked, tree) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["library.blend"]


def test_a_coat_fed_another_normal_is_warned_of(tmp_path, capsys):
    """Finding 3: the map is the Normal, and a warning names the node; fed the same normal
    the coat is not warned of."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    tree = mat.node_tree
    principled = tree.nodes["Principled BSDF"]
    principled.inputs["Coat Weight"].default_value = 1.0
    capsys.readouterr()
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    warned = "material 'Imported': Principled BSDF 'Principled BSDF' has a coat"
    assert warned in capsys.readouterr().err
    tree.links.new(tree.nodes["Normal Map"].outputs[0], principled.inputs["Coat Normal"])
    assert _degrees_off(_baked_normals(obj, tmp_path / "same.exr"), normal) < 0.05
    assert "has a coat" not in capsys.readouterr().err
