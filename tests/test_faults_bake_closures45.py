"""Red team 45a: the Diffuse stand-ins of round 44 (addon/bake_closures.py) that every
normal-map bake (bake-normal-map, bake-batch, api.bake_normal_map) makes of a material's BSDFs.

1. A Diffuse BSDF of black Color: Cycles drops a closure of no weight, and its NORMAL bake then
   takes the surface's own normal, so a map fed through a black Diffuse BSDF (or the black
   texels of a texture in its Color) baked flat: 60.0 degrees off for a normal map leaning 60
   degrees, on 5.2 and 4.2 alike, exit 0 (round 44 stood in every BSDF but the Diffuse one).
   A grey one mixed with another BSDF weighed by its Color, not the Mix Shader's factor as
   docs/pipelines.md says: a 0.2 grey Diffuse BSDF fed that map, mixed at 0.5 with a flat
   Principled BSDF, baked 21.1 degrees from the factor's mix. Now a Diffuse BSDF stands in too,
   as a white one.
2. A BSDF inside a node group (an asset library's shader group, a group of the artist's) was
   baked as it was: a normal map leaning 60 degrees through a Principled BSDF in a group came
   out 8.26 degrees flatter, through a Glass BSDF in a group 15.29 (5.2), the test's mix of
   both (one group inside the other) 10.9 on 5.2 and 4.2 alike, exit 0. Now a group holding
   a BSDF at any depth is baked through a copy stood in the same way, which its group node
   uses for the bake only; the group, its users, the other materials sharing it and the
   material are as they were after.
3. A hair BSDF (Hair, Principled Hair: no Normal input; on a mesh, hair cards) makes a closure
   whose bake normal is neither the surface's nor any map's: mixed at 0.5 with a Principled
   BSDF fed a map leaning 60 degrees, a Principled Hair BSDF baked 45.0 degrees from the map
   and 52.2 from the factor's mix (the map and the surface's normal halfway; a Hair BSDF 3.7),
   on 5.2 and 4.2 alike. Now it stands in as a white Diffuse BSDF fed the surface's normal.
4. (Coordinator, on merging.) A BSDF in a material that only a Geometry Nodes Set Material
   gives the object (the checks read such materials since round 42c) had no stand-in: a
   Principled BSDF fed the map leaning 60 degrees baked 8.3 degrees flatter there, exit 0,
   where the same material in a slot bakes the map. Now its BSDFs stand in as a slot's do.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.geometry_nodes import set_material_group  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from test_faults_assets44 import _baked_normals, _tilted_plane, group_only  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _degrees_off(got, normal):
    return np.degrees(np.arccos(np.clip(got @ normal, -1.0, 1.0))).max()


def test_a_black_diffuse_bsdf_bakes_the_normal_it_is_given(tmp_path):
    """Finding 1: every texel is the normal fed in (before: 60.0 degrees off, the surface's
    own normal), and the material is left exactly as it was."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfDiffuse")
    mat.node_tree.nodes["Diffuse BSDF"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    before = material_dump(mat)
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    assert material_dump(mat) == before


def test_bsdfs_with_different_normals_mix_by_the_factor(tmp_path):
    """Finding 1: a grey Diffuse BSDF fed the map and a Principled BSDF fed none, mixed at
    0.5, bake the normal halfway between the map's and the surface's (before: 21.1 degrees
    from it, the Diffuse BSDF weighed by its grey)."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    diffuse = tree.nodes["Diffuse BSDF"]
    diffuse.inputs["Color"].default_value = (0.2, 0.2, 0.2, 1.0)
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.5
    tree.links.new(diffuse.outputs[0], mix.inputs[1])
    tree.links.new(tree.nodes.new("ShaderNodeBsdfPrincipled").outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    halfway = normal + np.array([0.0, 0.0, 1.0])
    got = _baked_normals(obj, tmp_path / "n.exr")
    assert _degrees_off(got, halfway / np.linalg.norm(halfway)) < 0.05


@pytest.mark.parametrize("hair", ["ShaderNodeBsdfHair", "ShaderNodeBsdfHairPrincipled"])
def test_a_hair_bsdf_mixes_in_the_surface_normal(tmp_path, hair):
    """Finding 3: a hair BSDF mixed at 0.5 with a BSDF fed the map bakes the normal halfway
    between the map's and the surface's (before: 3.7 degrees from it through
    a Hair BSDF, 52.2 through a Principled Hair BSDF)."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    tree = mat.node_tree
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.5
    tree.links.new(tree.nodes.new(hair).outputs[0], mix.inputs[1])
    tree.links.new(tree.nodes["Principled BSDF"].outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    before = material_dump(mat)
    halfway = normal + np.array([0.0, 0.0, 1.0])
    got = _baked_normals(obj, tmp_path / "n.exr")
    assert _degrees_off(got, halfway / np.linalg.norm(halfway)) < 0.05
    assert material_dump(mat) == before


def _group(name, shader, normal_from):
    """A group with a Vector input and a Shader output: `shader` fed the input's normal, or
    (normal_from given) the group's own Normal Map node's."""
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    group.interface.new_socket("Normal", in_out="INPUT", socket_type="NodeSocketVector")
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    bsdf = group.nodes.new(shader)
    source = group.nodes.new("NodeGroupInput").outputs[0]
    if normal_from is not None:
        rgb = group.nodes.new("ShaderNodeRGB")
        rgb.outputs[0].default_value = (*(normal_from * 0.5 + 0.5), 1.0)
        normal_map = group.nodes.new("ShaderNodeNormalMap")
        group.links.new(rgb.outputs[0], normal_map.inputs["Color"])
        source = normal_map.outputs[0]
    group.links.new(source, bsdf.inputs["Normal"])
    group.links.new(bsdf.outputs[0], group.nodes.new("NodeGroupOutput").inputs[0])
    return group, bsdf, source


def test_a_bsdf_inside_a_node_group_bakes_the_normal_it_is_given(tmp_path):
    """Finding 2: a Principled BSDF in a group, mixed with a Glass BSDF in a group inside it,
    both fed the group's normal map; the group is shared with a second material. Every texel
    is the normal (before: 10.9 degrees off); the material, the groups, their users and the
    other material are as they were, and no group is left behind."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    inner, _, _ = _group("Inner Glass", "ShaderNodeBsdfGlass", None)
    outer, principled, source = _group("Asset Shader", "ShaderNodeBsdfPrincipled", normal)
    nested = outer.nodes.new("ShaderNodeGroup")
    nested.node_tree = inner
    outer.links.new(source, nested.inputs[0])
    mix = outer.nodes.new("ShaderNodeMixShader")
    outer.links.new(principled.outputs[0], mix.inputs[1])
    outer.links.new(nested.outputs[0], mix.inputs[2])
    outer.links.new(mix.outputs[0], outer.nodes["Group Output"].inputs[0])
    node = group_only(mat, outer)
    other = mat.copy()
    before = (material_dump(mat), material_dump(other), sorted(bpy.data.node_groups.keys()),
              outer.users, inner.users, len(outer.nodes), len(inner.nodes))
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    after = (material_dump(mat), material_dump(other), sorted(bpy.data.node_groups.keys()),
             outer.users, inner.users, len(outer.nodes), len(inner.nodes))
    assert after == before
    assert node.node_tree == outer and nested.node_tree == inner


def test_a_bsdf_a_set_material_gives_bakes_the_normal_it_is_given(tmp_path):
    """Finding 4: the plane's slot holds a plain material, a Set Material node gives every face
    the Principled BSDF fed the map: every texel is the map's normal (before: 8.3 degrees
    flatter), and the material is as it was after."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    obj.data.materials.clear()
    slot = bpy.data.materials.new("Slot")
    slot.use_nodes = True                   # (4.2 and 4.5 make a material without a tree)
    obj.data.materials.append(slot)
    obj.modifiers.new("GeometryNodes", "NODES").node_group = set_material_group(mat)
    before = material_dump(mat)
    assert _degrees_off(_baked_normals(obj, tmp_path / "n.exr"), normal) < 0.05
    assert material_dump(mat) == before
