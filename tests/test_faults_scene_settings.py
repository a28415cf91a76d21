"""Fault injection for what a user's file holds beyond the object (red team 28): settings of the
scene, the view layer and the collections, and modifiers that move UVs, which made
bake-normal-map write a wrong map with exit 0 (a grey map of zero-length normals under
holdout, a flat one under a material override, DirectX green from the file's bake swizzle, a
blank one when a modifier moved the UVs out of the tile baked) or fail after its checks (a
hidden collection). Each bake here is held to the same bake of the plain file, texel for
texel; the file is byte for byte as it was and the flags the bake lifted are back. Also: a
material in two slots is baked once and its active node put back, and an output that is one
of the images the materials read is refused, --overwrite or not."""

import hashlib
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 32


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _write_normal_png(path, size=16):
    """A tangent-space normal map that tilts every texel differently (stripes in x and y), so
    a flipped channel, a flat map and a grey map all differ from it."""
    y, x = np.mgrid[0:size, 0:size] / size
    nx, ny = 0.5 * np.sin(2 * np.pi * x), 0.5 * np.cos(2 * np.pi * y)
    nz = np.sqrt(1.0 - nx * nx - ny * ny)
    rgba = np.stack([nx, ny, nz, np.ones_like(nx)], -1)
    rgba[..., :3] = rgba[..., :3] * 0.5 + 0.5
    img = bpy.data.images.new("tmp_png", size, size)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(rgba.astype(np.float32).ravel())
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def _grid(name="Plane"):
    """A 2 x 2 quad grid filling the 0-1 UV square."""
    verts = [(x / 2, y / 2, 0.0) for y in range(3) for x in range(3)]
    faces = [(y * 3 + x, y * 3 + x + 1, y * 3 + x + 4, y * 3 + x + 3)
             for y in range(2) for x in range(2)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    layer = mesh.uv_layers.new(name="UVMap")
    uv = [(verts[i][0], verts[i][1]) for f in faces for i in f]
    layer.data.foreach_set("uv", np.asarray(uv, np.float32).ravel())
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _in_collection(obj, name="Props"):
    coll = bpy.data.collections.new(name)
    bpy.context.scene.collection.children.link(coll)
    coll.objects.link(obj)
    bpy.context.scene.collection.objects.unlink(obj)
    return coll, bpy.context.view_layer.layer_collection.children[name]


def _scene(tmp_path, fault=None):
    """tmp_path/<fault>.blend: object Plane whose material reads the stripes through a Normal
    Map node, carrying `fault`."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tex = tmp_path / "stripes.png"
    if not tex.exists():
        _write_normal_png(tex)
    obj = _grid()
    mat, tree, bsdf = diffuse_material("Mat")
    image = tree.nodes.new("ShaderNodeTexImage")
    image.image = bpy.data.images.load(str(tex))
    image.image.colorspace_settings.name = "Non-Color"
    nm = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(image.outputs["Color"], nm.inputs["Color"])
    tree.links.new(nm.outputs["Normal"], bsdf.inputs["Normal"])
    obj.data.materials.append(mat)
    if fault == "object_holdout":
        obj.is_holdout = True
    elif fault == "collection_holdout":
        _in_collection(obj)[1].holdout = True
    elif fault == "collection_hidden":
        coll, layer = _in_collection(obj)
        coll.hide_viewport = coll.hide_select = True
        layer.hide_viewport = True
    elif fault == "material_override":
        flat, _, _ = diffuse_material("Flat")
        bpy.context.view_layer.material_override = flat
    elif fault == "directx_swizzle":                 # left by an earlier bake for a game engine
        bpy.context.scene.render.bake.normal_g = "NEG_Y"
    elif fault in ("uv_warp", "uv_warp_render_only"):   # every UV moved into tile 1003
        warp = obj.modifiers.new("Warp", "UV_WARP")
        warp.uv_layer = "UVMap"
        warp.offset = (2.0, 0.0)
        warp.show_viewport = fault == "uv_warp"
    elif fault == "array_uv_offset":                 # the copy's UVs in tile 1002
        array = obj.modifiers.new("Array", "ARRAY")
        array.count, array.offset_u = 2, 1.0
    elif fault == "viewport_only_decimate":          # collapses the viewport mesh only
        dec = obj.modifiers.new("Decimate", "DECIMATE")
        dec.ratio, dec.show_render = 0.0, False
    blend = tmp_path / f"{fault or 'plain'}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    return blend


def _bake(capsys, blend, output, *options):
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(output), "--resolution", str(RES), *options])
    return rc, capsys.readouterr().err


def _pixels(path):
    img = bpy.data.images.load(str(path))
    try:
        px = np.empty(len(img.pixels), np.float32)
        img.pixels.foreach_get(px)
        return px.reshape(img.size[1], img.size[0], -1)[..., :3]
    finally:
        bpy.data.images.remove(img)


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    """The plain file's map: what every fault must bake too."""
    tmp = tmp_path_factory.mktemp("plain")
    blend = _scene(tmp)
    out = tmp / "plain.png"
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out), "--resolution", str(RES)])
    assert rc == exit_codes.OK
    px = _pixels(out)
    n = px * 2 - 1
    assert np.abs(np.linalg.norm(n, axis=-1) - 1).max() < 0.02      # unit normals
    assert np.ptp(n[..., 0]) > 0.5 and np.ptp(n[..., 1]) > 0.5      # the stripes, not flat
    return px


def _flags(fault):
    """The flags the bake lifts, as the open file has them after the bake."""
    obj = bpy.data.objects["Plane"]
    layer = bpy.context.view_layer.layer_collection.children.get("Props")
    coll = bpy.data.collections.get("Props")
    return {"object_holdout": lambda: obj.is_holdout,
            "collection_holdout": lambda: layer.holdout,
            "collection_hidden": lambda: (coll.hide_viewport, coll.hide_select,
                                          layer.hide_viewport),
            "material_override": lambda: bpy.context.view_layer.material_override.name,
            "directx_swizzle": lambda: bpy.context.scene.render.bake.normal_g}[fault]()


# fault -> its flags as the file has them, which the bake must put back
KEPT = {"object_holdout": True, "collection_holdout": True,
        "collection_hidden": (True, True, True), "material_override": "Flat",
        "directx_swizzle": "NEG_Y"}


@pytest.mark.parametrize("fault", sorted(KEPT))
def test_scene_settings_do_not_change_the_map(tmp_path, capsys, plain, fault):
    blend = _scene(tmp_path, fault)
    before = _sha(blend)
    rc, err = _bake(capsys, blend, tmp_path / "n.png")
    assert rc == exit_codes.OK, err[-2000:]
    assert np.abs(_pixels(tmp_path / "n.png") - plain).max() <= 1.5 / 255
    assert _flags(fault) == KEPT[fault]
    assert _sha(blend) == before


@pytest.mark.parametrize("fault,tiles", [
    ("uv_warp", "1003"),
    ("uv_warp_render_only", "1003"),
    ("array_uv_offset", "1001, 1002"),
])
def test_tiles_are_those_of_the_rendered_uvs(tmp_path, capsys, plain, fault, tiles):
    blend = _scene(tmp_path, fault)
    before = _sha(blend)
    maps = tmp_path / "maps"
    maps.mkdir()
    rc, err = _bake(capsys, blend, maps / "n.png")       # one image: the 0-1 square alone
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert f"tiles {tiles}" in err
    assert list(maps.iterdir()) == []
    rc, err = _bake(capsys, blend, maps / "n.<UDIM>.png")
    assert rc == exit_codes.OK, err[-2000:]
    written = sorted(p.name for p in maps.iterdir())
    assert written == [f"n.{t}.png" for t in tiles.split(", ")]
    for name in written:                         # each tile the stripes, as the plain bake
        assert np.abs(_pixels(maps / name) - plain).max() <= 1.5 / 255
    assert _sha(blend) == before


def test_a_viewport_only_modifier_is_not_what_the_checks_see(tmp_path, capsys, plain):
    blend = _scene(tmp_path, "viewport_only_decimate")
    rc, err = _bake(capsys, blend, tmp_path / "n.png")
    assert rc == exit_codes.OK, err[-2000:]
    assert np.abs(_pixels(tmp_path / "n.png") - plain).max() <= 1.5 / 255


@pytest.mark.tier("blender")
def test_a_blend_from_a_newer_line_is_named_as_such(tmp_path, capsys):
    """A header two lines ahead of the running one over content no Blender reads: the open
    fails, and the refusal says which Blender saved it (4.2 calls 5.x files "not a blend")."""
    major, minor = bpy.app.version[:2]
    blend = tmp_path / "from the future.blend"
    blend.write_bytes(f"BLENDER17-01v{major + 2:02d}{minor:02d}REND".encode() + b"\x01" * 64)
    before = _sha(blend)
    maps = tmp_path / "maps"
    maps.mkdir()
    rc, err = _bake(capsys, blend, maps / "n.png")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert f".blend file {str(blend)!r} could not be opened (" in err
    assert (f"it was saved by Blender {major + 2}.{minor}, newer than this Blender "
            f"({major}.{minor}): open it with Blender {major + 2}.{minor} or later") in err
    assert list(maps.iterdir()) == [] and _sha(blend) == before


def test_a_material_in_two_slots_is_baked_once_and_put_back(tmp_path, plain):
    """Joined objects keep one material in two slots: the bake added an image node per slot
    and left the material's active node unset (the api bakes the open file in place)."""
    from surfgrad_addon import api
    _scene(tmp_path)
    obj = bpy.data.objects["Plane"]
    mat = obj.data.materials[0]
    obj.data.materials.append(mat)
    for i, face in enumerate(obj.data.polygons):
        face.material_index = i % 2
    tree = mat.node_tree
    tree.nodes.active = tree.nodes["Image Texture"]
    names = sorted(n.name for n in tree.nodes)
    api.bake_normal_map(obj, str(tmp_path / "n.png"), resolution=RES)
    assert np.abs(_pixels(tmp_path / "n.png") - plain).max() <= 1.5 / 255
    assert sorted(n.name for n in tree.nodes) == names
    assert tree.nodes.active is not None and tree.nodes.active.name == "Image Texture"


@pytest.mark.tier("blender")
@pytest.mark.parametrize("how", ["absolute", "relative"])
def test_an_output_that_is_an_input_image_is_refused_even_with_overwrite(
        tmp_path, capsys, monkeypatch, how):
    blend = _scene(tmp_path)
    tex = tmp_path / "stripes.png"
    before, tex_before = _sha(blend), _sha(tex)
    monkeypatch.chdir(tmp_path)
    rc, err = _bake(capsys, blend, tex if how == "absolute" else Path("stripes.png"),
                    "--overwrite")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert ("is the file of image 'stripes.png', which material 'Mat' reads: the bake would "
            "replace its own input; write the map to another file") in err
    assert _sha(tex) == tex_before and _sha(blend) == before


def _noisy_scene(tmp_path, simplify):
    """A 256 px map of random tilts (no two neighbours alike, so any downscale shows), the
    scene's Simplify with its 128 px texture limit on or off."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    rng = np.random.default_rng(28)
    n = rng.uniform(-0.5, 0.5, (256, 256, 3))
    n[..., 2] = np.sqrt(1.0 - n[..., 0] ** 2 - n[..., 1] ** 2)
    img = bpy.data.images.new("noisy", 256, 256)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(np.concatenate([n * 0.5 + 0.5, np.ones((256, 256, 1))], -1)
                           .astype(np.float32).ravel())
    img.filepath_raw = str(tmp_path / "noisy.png")
    img.file_format = "PNG"
    img.save()
    obj = _grid()
    mat, tree, bsdf = diffuse_material("Mat")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    nm = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(tex.outputs["Color"], nm.inputs["Color"])
    tree.links.new(nm.outputs["Normal"], bsdf.inputs["Normal"])
    obj.data.materials.append(mat)
    scene = bpy.context.scene
    scene.render.use_simplify = simplify
    scene.cycles.texture_limit_render = "128"
    blend = tmp_path / f"simplify_{simplify}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    return blend


def test_simplify_texture_limit_does_not_blur_the_map(tmp_path, capsys):
    """Simplify for quick previews shrank every texture the bake read: a blurred map."""
    maps = {}
    for simplify in (False, True):
        blend = _noisy_scene(tmp_path, simplify)
        maps[simplify] = tmp_path / f"n_{simplify}.png"
        rc, err = _bake(capsys, blend, maps[simplify], "--resolution", "128")
        assert rc == exit_codes.OK, err[-2000:]
    sharp, limited = _pixels(maps[False]), _pixels(maps[True])
    assert np.std(sharp - 0.5) > 0.1                         # the noise is there
    assert np.abs(limited - sharp).max() <= 1.5 / 255
    assert bpy.context.scene.cycles.texture_limit_render == "128"     # put back


@pytest.mark.tier("blender")
def test_a_material_without_a_node_tree_is_refused_before_baking(tmp_path, capsys):
    """Before 5.0 a material made without Use Nodes has no node tree: the bake raised
    AttributeError after its checks (a traceback, exit 1)."""
    blend = _scene(tmp_path)
    bare = bpy.data.materials.new("Bare")
    if bare.node_tree is not None:
        pytest.skip("from 5.0 every new material has a node tree")
    obj = bpy.data.objects["Plane"]
    obj.data.materials.append(bare)
    obj.data.polygons[0].material_index = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    before = _sha(blend)
    maps = tmp_path / "maps"
    maps.mkdir()
    rc, err = _bake(capsys, blend, maps / "n.png")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert ("material 'Bare' has no node tree (Use Nodes is off), so the bake has nowhere to "
            "write its faces: turn on Use Nodes for it") in err
    assert "Traceback" not in err
    assert list(maps.iterdir()) == [] and _sha(blend) == before


@pytest.mark.tier("blender")
def test_a_blend_a_newer_line_saved_is_opened_with_a_warning_on_stderr(tmp_path, capsys):
    """A file from a newer line that this one still opens (4.5's on 4.2) may lose what that
    line added: Blender said so on stdout only."""
    blend = _scene(tmp_path)
    major, minor = bpy.app.version[:2]
    data = bytearray(blend.read_bytes())
    if data[7:9].isdigit():                          # the header from 5.0 on: BLENDER17-01v0502
        data[13:17] = f"{major:02d}{minor + 1:02d}".encode()
    else:                                            # BLENDER-v402
        data[9:12] = f"{major}{minor + 1:02d}".encode()
    blend.write_bytes(bytes(data))
    rc, err = _bake(capsys, blend, tmp_path / "n.png", "--object", "Nope")   # opened, refused
    assert rc == exit_codes.BAD_REQUEST
    assert (f"surfgrad: warning: .blend file {str(blend)!r} was saved by Blender "
            f"{major}.{minor + 1}, newer than this Blender ({major}.{minor}): what that line "
            f"added to the file may be lost") in err
    assert "no object named 'Nope'" in err


def test_a_request_reads_the_rendered_mesh_once(fresh, tmp_path, monkeypatch):
    """The checks' tiles, the checks' mesh arrays and the bake's tile plan each read the mesh
    as the bake renders it; for an object with modifiers each read was a render-mode pass
    (three per bake). Now one per request, and the map is the same."""
    from surfgrad_addon import api
    from surfgrad_addon.addon import render_mesh
    from surfgrad_addon.harness import scenes
    passes, real = [], render_mesh.read_in_render_mode

    def counted(*args, **kwargs):
        passes.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(render_mesh, "read_in_render_mode", counted)
    obj = scenes.new_scene(("Sphere",))["Sphere"]
    mat, _tree, _bsdf = diffuse_material("Plain")
    obj.data.materials.append(mat)
    obj.modifiers.new("Subdivision", "SUBSURF").render_levels = 2
    bpy.context.view_layer.update()
    path = api.bake_normal_map(obj, str(tmp_path / "n.png"), resolution=16, log=lambda *_: None)
    assert len(passes) == 1 and Path(path).is_file()
