"""Fault injection, red team 36a: Blender's other tile token, and checks that read one part of
what the bake reads.

- `--output m.<UVTILE>.png` (Blender's u<U>_v<V> tile token) wrote a file named with the
  token, exit 0; <UVTILE> is now refused before baking.
- A local node group and a library's of the same name (each reading its own image "Tex"): the
  image checks kept groups and images by name, so the second one met was never checked (a
  missing image baked as magenta, exit 0); the normal map warnings kept images by name too (a
  library's map in -1..1 named as a local one: no warning), and so did the memory count before
  a bake (one image of the two counted).
- A packed UDIM normal map's -1..1 warning read its first tile only."""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402

pytestmark = pytest.mark.tier("bake")


@pytest.mark.tier("blender")
def test_the_uvtile_token_is_refused_before_baking(tmp_path, capsys):
    """Before: bake-normal-map and bake-batch with <UVTILE> in the output name, one tile,
    wrote `m.<UVTILE>.png` itself, exit 0. Now exit 2 naming the token and the fix, and the
    folder stays empty."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    out = tmp_path / "out"
    out.mkdir()
    said = "has <UVTILE>, which this bake does not fill in"
    for args in (["bake-normal-map", "--blend", str(blend), "--object", "Rock", "--output",
                  str(out / "m.<UVTILE>.png")],
                 ["bake-batch", str(blend), "--output", str(out / "{object}.<UVTILE>.png"),
                  "--workers", "0"]):
        capsys.readouterr()
        rc = commands.execute(args + ["--resolution", "16", "--samples", "1"])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAD_REQUEST and said in err.strip().splitlines()[-1], err
    assert list(out.iterdir()) == []


def _bake_plane(capsys, blend, output):
    """bake-normal-map of object Plane in `blend` to `output`, 16 x 16, 1 sample: (exit
    code, stderr)."""
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(output), "--resolution", "16", "--samples", "1"])
    return rc, capsys.readouterr().err


def _group_reading(name, image):
    """Node group `name` whose output is Image Texture `image`'s colour."""
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    group.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    tex = group.nodes.new("ShaderNodeTexImage")
    tex.image = image
    out = group.nodes.new("NodeGroupOutput")
    group.links.new(tex.outputs["Color"], out.inputs["Color"])
    return group


@pytest.mark.tier("bake")
@pytest.mark.parametrize("local_first", [True, False])
def test_a_library_group_named_as_a_local_one_has_its_images_checked(local_first, tmp_path,
                                                                     capsys):
    """A material reads a local node group "G" (a good image "Tex") and a library's "G" (its
    own "Tex", a file that is missing). Before: the image walk kept groups (and images) by
    name alone, so whichever "G" it met second was taken as walked and its "Tex" as checked:
    with the local one met first the bake ran, exit 0, the library's missing image baked as
    magenta. Now refused, naming the file, in either order."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    missing = bpy.data.images.new("Tex", 4, 4)
    missing.source, missing.filepath = "FILE", str(tmp_path / "gone.png")
    lib = tmp_path / "lib.blend"
    bpy.data.libraries.write(str(lib), {_group_reading("G", missing)})
    bpy.ops.wm.read_factory_settings(use_empty=True)
    local = _group_reading("G", bpy.data.images.new("Tex", 4, 4))
    with bpy.data.libraries.load(str(lib), link=True) as (_src, dst):
        dst.node_groups = ["G"]
    linked = dst.node_groups[0]
    assert linked.library is not None and linked.name == local.name == "G"
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.object
    mat = bpy.data.materials.new("Mat")
    if mat.node_tree is None:                 # before 5.0 a new material needs use_nodes
        mat.use_nodes = True
    obj.data.materials.append(mat)
    nodes = mat.node_tree.nodes
    bsdf = nodes["Principled BSDF"]
    # which "G" the walk meets first follows the links' order: both orders
    groups = (linked, local) if local_first else (local, linked)
    # (each into the normal: a Base Color alone is not baked, round 54)
    normal_map, bump = nodes.new("ShaderNodeNormalMap"), nodes.new("ShaderNodeBump")
    mat.node_tree.links.new(normal_map.outputs[0], bump.inputs["Normal"])
    mat.node_tree.links.new(bump.outputs[0], bsdf.inputs["Normal"])
    for group, socket in zip(groups, (normal_map.inputs["Color"], bump.inputs["Height"])):
        node = nodes.new("ShaderNodeGroup")
        node.node_tree = group
        mat.node_tree.links.new(node.outputs["Color"], socket)
    blend = tmp_path / "s.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    out = tmp_path / "out"
    out.mkdir()
    rc, err = _bake_plane(capsys, blend, out / "m.png")
    assert rc == exit_codes.BAD_REQUEST and list(out.iterdir()) == [], err
    assert "gone.png', which does not exist" in err, err


@pytest.mark.tier("bake")
def test_a_packed_udim_tile_in_minus_one_to_one_is_warned_about_by_name(tmp_path, capsys):
    """A packed UDIM normal map: tile 1001 stored 0..1, tile 1002 in -1..1. Before: the range
    warning read the image's own pixels, its first tile only: exit 0, no warning, tile 1002's
    normals pulled toward (-1, -1). Now each packed tile the bake writes is judged, named."""
    from test_faults_images35 import RANGE, _below_zero, _exr
    from test_faults_pipeline_more import _scene as _source_scene
    for tile in (1001, 1002):
        _exr(tmp_path / f"n.{tile}.exr", signed=tile == 1002)
    blend = _source_scene(tmp_path / "s.blend", tmp_path / "n.1001.exr", "TILED",
                          second_tile=True)
    bpy.data.images["n.1001.exr"].pack()
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    for tile in (1001, 1002):
        (tmp_path / f"n.{tile}.exr").unlink()
    out = tmp_path / "out"
    out.mkdir()
    rc, err = _bake_plane(capsys, blend, out / "m.<UDIM>.png")
    assert rc == exit_codes.OK, err
    r, g = _below_zero()
    assert err.count(RANGE) == 1, err
    assert (f"image 'n.1001.exr', read by Normal Map node 'Normal Map' (material 'Mat'), has "
            f"{r}% of its texels below 0 in R and {g}% in G (tile 1002: its packed data): "
            f"{RANGE}") in err, err


def _local_and_library_maps(tmp_path, local_first):
    """Object Plane in s.blend whose material adds two Normal Map nodes' normals, each reading
    an image named "n.exr" (16 x 16 half EXR): a local one stored 0..1 (good/) and one linked
    from lib.blend stored in -1..1 (bad/), linked first or second. (blend, the library's
    Normal Map node's name)."""
    from test_faults_images35 import _exr
    from test_faults_pipeline_more import _scene as _source_scene
    lib = tmp_path / "lib.blend"
    if not lib.exists():
        for folder, signed in (("good", False), ("bad", True)):
            (tmp_path / folder).mkdir()
            _exr(tmp_path / folder / "n.exr", signed=signed)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        image = bpy.data.images.load(str(tmp_path / "bad" / "n.exr"))
        image.colorspace_settings.name = "Non-Color"
        bpy.data.libraries.write(str(lib), {image})
    blend = _source_scene(tmp_path / "s.blend", tmp_path / "good" / "n.exr")
    with bpy.data.libraries.load(str(lib), link=True) as (_src, dst):
        dst.images = ["n.exr"]
    tree = bpy.data.materials["Mat"].node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = dst.images[0]
    assert tex.image.library is not None and tex.image.name == "n.exr"
    nm = tree.nodes.new("ShaderNodeNormalMap")
    name = nm.name
    tree.links.new(tex.outputs["Color"], nm.inputs["Color"])
    local_nm = tree.nodes["Normal Map"]
    bsdf = local_nm.outputs["Normal"].links[0].to_node
    add = tree.nodes.new("ShaderNodeVectorMath")
    for socket, normal in enumerate((nm, local_nm) if local_first else (local_nm, nm)):
        tree.links.new(normal.outputs["Normal"], add.inputs[socket])
    tree.links.new(add.outputs["Vector"], bsdf.inputs["Normal"])
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    return blend, name


@pytest.mark.tier("bake")
def test_a_library_normal_map_named_as_a_local_one_is_judged(tmp_path, capsys):
    """Two Normal Map nodes read image "n.exr": a local one stored 0..1 and a library's stored
    in -1..1. Before: the normal map warnings kept each image by name, so with the local one
    met first the library's was never judged: exit 0, no warning. Now the library's is
    warned about (the walk meets them in the links' order: both orders)."""
    from test_faults_images35 import RANGE, _below_zero
    r, g = _below_zero()
    for local_first in (True, False):
        blend, name = _local_and_library_maps(tmp_path, local_first)
        out = tmp_path / f"out{local_first}"
        out.mkdir()
        rc, err = _bake_plane(capsys, blend, out / "m.png")
        assert rc == exit_codes.OK, err
        assert err.count(RANGE) == 1, err
        assert (f"image 'n.exr', read by Normal Map node '{name}' (material 'Mat'), has {r}% "
                f"of its texels below 0 in R and {g}% in G: {RANGE}") in err, err


@pytest.mark.tier("blender")
def test_a_library_image_named_as_a_local_one_is_counted_in_memory(tmp_path):
    """The same two images "n.exr", neither loaded: the memory check before a bake counted
    images by name, so it counted one (half the bytes). Now both, in either order."""
    from surfgrad_addon.addon import memory_limit as ML
    from surfgrad_addon.addon.image_memory import images_memory
    for local_first in (True, False):
        blend, _ = _local_and_library_maps(tmp_path, local_first)
        bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
        assert [i.has_data for i in bpy.data.images] == [False, False]
        got = images_memory(bpy.data.objects["Plane"])
        per_image = 16 * 16 * (ML.IMAGE_BYTES_PER_TEXEL[True] + ML.CYCLES_BYTES_PER_TEXEL[True])
        assert (got.count, got.baked) == (2, 2 * per_image), got
