"""Red team 44a: the product on real assets made outside the project (glTF, OBJ, PLY and STL
files from public repositories, imported with Blender's own importers); each finding is built
here by code, a few faces, so no test reads a fetched file.

1. A map baked through the BSDF the importers make: every glTF, OBJ and FBX import feeds its
   normal map through a Normal Map node into a Principled BSDF. Cycles' NORMAL bake averages
   the closures' normals, and every closure but a diffuse one changes its normal first (the
   bump correction of Principled, Glossy and Metallic; Glass, Refraction, Translucent and
   Subsurface too), so where the map leans far from the surface bake-normal-map, bake-batch
   and the API wrote a flatter map with exit 0. Before, on 4.2 and 5.2 alike, a constant
   normal map 60 degrees from the surface baked 8.3 degrees off through a Principled BSDF
   (45: 0.16, 50: 2.9, 70: 13.7) and 15.3 through a Glass or Metallic BSDF; on the real
   assets (64^2, against the same material through a Diffuse BSDF) up to 39.6 degrees on the
   lizardman of castle-engine/demo-models (39 texels over 1 degree), 29.1 on Khronos'
   DamagedHelmet, 29.7 on revelryengine's Barrel. Freeze already baked its stack through a
   Diffuse stand-in; now every normal-map bake does (addon/bake_closures.py): each BSDF of the
   material's own tree stands in as a Diffuse BSDF fed the same Normal, for the bake only.
2. A UV layout lying whole one tile off the UDIM grid: Khronos' DamagedHelmet (the glTF
   sample most viewers open first) has its UVs at v 1..2 in the file, which Blender's glTF
   importer turns into v -1..0; its textures repeat, so it renders right. bake-normal-map
   refused it with "has no faces in any UDIM tile: unwrap it into the 0-1 square", and a batch
   with "15442 face(s) ... lie outside the UDIM range ... move them into tiles, or bake the
   rest on purpose with --allow-partial"; --allow-partial then failed the asset (exit 1) with
   the first message. Unwrapping again would undo the asset's layout (mirrored halves stacked
   on one island), and --allow-partial bakes nothing. Now both say where its UVs lie and the
   whole tiles that move it into tile 1001 (+0 in u, +1 in v), which keeps every island
   (normal_bake.no_tile_problem); a batch no longer offers --allow-partial for a layout with
   nothing in any tile.
"""

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon.batch import plan, session  # noqa: E402
from support.blender import new_material  # noqa: E402
from support.material_dump import material_dump  # noqa: E402

from support.baked_normals import baked_normals  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16
TILT_DEG = 60.0


def _tilted_plane(shader):
    """A plane whose material feeds a constant tangent-space normal TILT_DEG from the surface
    through a Normal Map node into `shader`, as an importer wires a normal map."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2)
    obj = bpy.context.active_object
    mat = new_material("Imported")
    obj.data.materials.append(mat)
    tree = mat.node_tree
    for node in [n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        tree.nodes.remove(node)
    output = tree.nodes["Material Output"]
    bsdf = tree.nodes.new(shader)
    tree.links.new(bsdf.outputs[0], output.inputs["Surface"])
    tilt = math.radians(TILT_DEG)
    normal = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (*(normal * 0.5 + 0.5), 1.0)
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(rgb.outputs[0], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs[0], bsdf.inputs["Normal"])
    return obj, mat, normal


def _baked_normals(obj, path):
    return baked_normals(obj, path, "tangent", RES)


def group_only(mat, group):
    """Make `mat`'s tree render `group` alone (its first output into the Surface); return
    its group node."""
    tree = mat.node_tree
    for node in [n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        tree.nodes.remove(node)
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return node


@pytest.mark.parametrize("shader", ["ShaderNodeBsdfPrincipled", "ShaderNodeBsdfGlass"])
def test_a_normal_map_bakes_as_given_through_any_bsdf(tmp_path, shader):
    """Finding 1: the plane's every texel is the tangent-space normal fed in (measured before:
    8.3 degrees off through the Principled BSDF, 15.3 through Glass), and the material is
    left exactly as it was."""
    obj, mat, normal = _tilted_plane(shader)
    before = material_dump(mat)
    got = _baked_normals(obj, tmp_path / "n.exr")
    degrees = np.degrees(np.arccos(np.clip(got @ normal, -1.0, 1.0)))
    assert degrees.max() < 0.05, degrees.max()
    assert material_dump(mat) == before


def test_a_muted_link_stays_muted_through_the_stand_in(tmp_path):
    """Finding 1: a second BSDF (flat) behind a muted link into a Mix Shader renders nothing,
    and its Diffuse stand-in must not either: the map is the first BSDF's normal alone (with
    the second mixed in at 0.5 it would lie 30 degrees off)."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    tree = mat.node_tree
    output = tree.nodes["Material Output"]
    tilted = output.inputs["Surface"].links[0].from_node
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.5
    flat = tree.nodes.new("ShaderNodeBsdfPrincipled")
    tree.links.new(tilted.outputs[0], mix.inputs[1])
    tree.links.new(flat.outputs[0], mix.inputs[2]).is_muted = True
    tree.links.new(mix.outputs[0], output.inputs["Surface"])
    before = material_dump(mat)
    got = _baked_normals(obj, tmp_path / "n.exr")
    degrees = np.degrees(np.arccos(np.clip(got @ normal, -1.0, 1.0)))
    assert degrees.max() < 0.05, degrees.max()
    assert material_dump(mat) == before
    assert [link.is_muted for link in mix.inputs[2].links] == [True]


def test_a_node_group_with_a_normal_input_is_not_stood_in(tmp_path):
    """Finding 1: a group of the artist's (a Normal input, a Shader output) whose own nodes
    make the normal is baked as it is: a Diffuse stand-in fed its unlinked Normal input would
    bake the surface flat (30 degrees off here; 30 degrees bends no closure)."""
    obj, mat, _ = _tilted_plane("ShaderNodeBsdfPrincipled")
    tilt = math.radians(30.0)
    normal = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    group = bpy.data.node_groups.new("Rock Shader", "ShaderNodeTree")
    group.interface.new_socket("Normal", in_out="INPUT", socket_type="NodeSocketVector")
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    group.nodes.new("NodeGroupInput")
    rgb = group.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (*(normal * 0.5 + 0.5), 1.0)
    normal_map = group.nodes.new("ShaderNodeNormalMap")
    bsdf = group.nodes.new("ShaderNodeBsdfPrincipled")
    group.links.new(rgb.outputs[0], normal_map.inputs["Color"])
    group.links.new(normal_map.outputs[0], bsdf.inputs["Normal"])
    group.links.new(bsdf.outputs[0], group.nodes.new("NodeGroupOutput").inputs[0])
    group_only(mat, group)
    got = _baked_normals(obj, tmp_path / "n.exr")
    degrees = np.degrees(np.arccos(np.clip(got @ normal, -1.0, 1.0)))
    assert degrees.max() < 0.05, degrees.max()

def _plane_a_tile_below():
    """A plane whose UVs fill the square one tile below tile 1001 (v -1..0), as the glTF
    importer turns a file's v 1..2."""
    obj, _, _ = _tilted_plane("ShaderNodeBsdfPrincipled")
    for loop in obj.data.uv_layers["UVMap"].data:
        loop.uv = (loop.uv[0], loop.uv[1] - 1.0)
    return obj


WHOLE_TILES = ("UV map 'UVMap' of object 'Plane' has no faces in any UDIM tile (its UVs span "
               "u 0..1, v -1..0; the tiles are u 0..10, v 0..100), so nothing would be baked: "
               "move its UVs by whole tiles, +0 in u and +1 in v, into tile 1001")


def test_a_layout_one_tile_off_the_grid_is_told_the_whole_tiles_to_move(tmp_path):
    """Finding 2, bake-normal-map and the API: the refusal names the span and the move."""
    obj = _plane_a_tile_below()
    with pytest.raises(ValueError) as err:
        api.bake_normal_map(obj, str(tmp_path / "n.png"), resolution=RES, log=None)
    assert str(err.value).startswith(WHOLE_TILES), str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_a_batch_does_not_offer_allow_partial_for_a_layout_with_no_tile():
    """Finding 2, bake-batch: its scan's refusal is the same, without --allow-partial (which
    baked nothing and failed the asset)."""
    _plane_a_tile_below()
    scan = session.scan_open_file()["assets"][0]
    settings = {"uv_map": None, "allow_partial": False}
    problem = plan.asset_problem(scan, settings, "helmet.blend")
    assert problem.startswith(WHOLE_TILES) and "allow-partial" not in problem, problem
