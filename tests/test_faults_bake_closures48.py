"""Red team 48a: round 47's changes to the normal-map bake (tests/test_faults_bake_closures47.py)
at the other entry points.

1. A linked material a linked node group gives by a Set Material (refused since round 47) was
   refused by the bake itself, after the request's checks had passed: a request with another
   problem too (its output there already) named that one alone, and the rerun the next. Now the
   request's checks (bake_request: bake-normal-map, bake-batch, the api) name it with the rest.
2. EEVEE's Specular BSDF makes no closure in Cycles: Cycles' own bake of it gave the surface's
   normal (60 degrees off the map fed it), and since round 47 it stands in, its Normal baked as
   EEVEE renders it, with no word that Cycles renders the material without it. It still stands
   in, and the bake warns, naming the material and the node.
3. Freeze of a local material on an object whose other slot holds a linked material that a
   Geometry Nodes Set Material (a local group) gives it too passed its checks, then was refused
   by the bake with a wrong reason (a material 'none of its material slots holds': one does).
   For the bake the slot held a local copy while the Set Material still gave the linked
   material, a material no slot held; let through, Blender's bake wrote its faces into the
   last slot's map (measured: the other material's 60-degree normal in the frozen map). Now
   every local user of a linked material (the slots and the Set Material alike) uses one copy
   (linked_materials.local_copies): the freeze is done, its map holds its own faces alone.
Freeze bakes its stack alone through a Diffuse BSDF (freeze._baking_the_stack_alone), so a
Transparent BSDF or Holdout added to its Principled BSDF leaves its map as it was (probed, 5.2).
"""

import contextlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import freeze, normal_bake  # noqa: E402
from surfgrad_addon.addon.bake_request import BakeRequestError  # noqa: E402
from test_faults_assets44 import _baked_normals, _tilted_plane  # noqa: E402
from support.geometry_nodes import geometry_group  # noqa: E402
from test_faults_bake_closures47 import _degrees_off, _linked_set_material  # noqa: E402
from test_faults_freeze44 import SIZE, _quads  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def test_a_linked_group_is_named_with_the_requests_other_problems(tmp_path):
    """Finding 1: one refusal names both problems; nothing is written or changed."""
    obj, _, _, _ = _linked_set_material(tmp_path, linked_group=True)
    (tmp_path / "n.exr").write_bytes(b"an earlier map")
    with pytest.raises(BakeRequestError) as refused:
        _baked_normals(obj, tmp_path / "n.exr")
    assert "n.exr exists" in str(refused.value)
    assert "node group 'Set Material', linked from" in str(refused.value)
    assert (tmp_path / "n.exr").read_bytes() == b"an earlier map"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["library.blend", "n.exr"]


def test_an_eevee_specular_bakes_its_normal_and_is_warned_of(tmp_path, capsys, monkeypatch):
    """Finding 2: the map is its Normal, and the warning names it; Cycles' own bake (no stand
    in) gives the surface's normal, the fact the warning states."""
    obj, _, normal = _tilted_plane("ShaderNodeEeveeSpecular")
    capsys.readouterr()
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    assert "material 'Imported': Specular BSDF 'Specular BSDF' is EEVEE's alone" in \
        capsys.readouterr().err
    monkeypatch.setattr(normal_bake, "_stand_ins", lambda *_: contextlib.nullcontext())
    surface = _degrees_off(_baked_normals(obj, tmp_path / "cycles.exr"), np.array([0, 0, 1.0]))
    assert surface < 0.05


def test_freeze_beside_a_linked_slot_a_set_material_also_gives(tmp_path):
    """Finding 3: two quads, Rock (a layer stack) and the library's material in its slots, the
    second quad given the library's material by a Set Material too. The freeze is done (before:
    refused, naming no fault of the file's): the map is Rock's flat stack, nowhere the other
    material's normal, and the slot and the Set Material hold the library's material again."""
    _, library_mat, _ = _tilted_plane("ShaderNodeBsdfPrincipled")
    library_mat.name = "Library Material"
    bpy.data.libraries.write(str(tmp_path / "library.blend"), {library_mat}, fake_user=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, rock = _quads(None, [[(0.05, 0.05), (0.45, 0.05), (0.45, 0.95), (0.05, 0.95)],
                              [(0.55, 0.05), (0.95, 0.05), (0.95, 0.95), (0.55, 0.95)]])
    with bpy.data.libraries.load(str(tmp_path / "library.blend"), link=True) as (_, into):
        into.materials = ["Library Material"]
    linked = bpy.data.materials["Library Material", str(tmp_path / "library.blend")]
    obj.data.materials.append(linked)
    obj.data.polygons[1].material_index = 1
    tree, group_in, group_out = geometry_group("Set Material")
    setter = tree.nodes.new("GeometryNodeSetMaterial")
    setter.inputs["Material"].default_value = linked
    tree.links.new(tree.nodes.new("GeometryNodeInputIndex").outputs[0],
                   setter.inputs["Selection"])            # the second quad (index 1)
    tree.links.new(group_in.outputs[0], setter.inputs["Geometry"])
    tree.links.new(setter.outputs[0], group_out.inputs[0])
    obj.modifiers.new("GeometryNodes", "NODES").node_group = tree
    record = freeze.freeze(obj, resolution=SIZE)
    pixels = np.array(bpy.data.images[record["image"]].pixels[:]).reshape(SIZE, SIZE, 4)
    # Rock's flat stack on its quad, the bake's flat background elsewhere: nowhere the other's
    # 60 degrees (0.93, 0.5, 0.75)
    assert np.allclose(pixels[..., :3], [0.5, 0.5, 1.0], atol=0.01)
    assert [s.material for s in obj.material_slots] == [rock, linked]
    assert setter.inputs["Material"].default_value == linked
    assert len(bpy.data.materials) == 2
