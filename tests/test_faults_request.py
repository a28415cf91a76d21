"""Fault injection for the bake request (issue 20, item 1): each bad input is refused before
anything is baked, by the command line in a child process, with a message naming the thing
and the fix, exit code 2 (addon/exit_codes.py), no file written (no temporary left either) and
the .blend byte for byte as it was. A valid request still bakes; a deliberate partial layout
bakes with --allow-partial and prints its warning; bake-batch checks its whole plan first."""

import hashlib
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import exit_codes  # noqa: E402
from support.child import run_python  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("child")


RES = "32"


def _sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _write_png(path, size=8):
    """A flat tangent-space normal map: (0.5, 0.5, 1) everywhere, stored as data."""
    img = bpy.data.images.new("tmp_png", size, size)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(np.tile(np.float32([0.5, 0.5, 1.0, 1.0]), size * size))
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def _write_exr(path, bad_value, size=8):
    img = bpy.data.images.new("tmp_exr", size, size, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"         # written as given: Inf stays Inf
    px = np.full(size * size * 4, 0.5, np.float32)
    px[4 * 5] = bad_value                             # one channel of one texel
    img.pixels.foreach_set(px)
    img.filepath_raw = str(path)
    img.file_format = "OPEN_EXR"
    img.save()
    bpy.data.images.remove(img)


def _plane(verts=None, uvs=None, quads=1):
    """Quads side by side, UVs filling the 0-1 square each (or `uvs` per corner)."""
    vs, faces, uv = [], [], []
    for i in range(quads):
        b = len(vs)
        vs += [(1.1 * i, 0, 0), (1.1 * i + 1, 0, 0), (1.1 * i + 1, 1, 0), (1.1 * i, 1, 0)]
        faces.append((b, b + 1, b + 2, b + 3))
        uv += [(0, 0), (1, 0), (1, 1), (0, 1)]
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata(verts if verts is not None else vs, [], faces)
    layer = mesh.uv_layers.new(name="UVMap")
    layer.data.foreach_set("uv", np.asarray(uvs if uvs is not None else uv,
                                            np.float32).ravel())
    obj = bpy.data.objects.new("Plane", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _material(obj, image=None, in_group=False, no_image=False):
    """Image Texture (UV) -> Normal Map -> Diffuse BSDF Normal; the texture inside a node
    group with in_group."""
    mat, tree, bsdf = diffuse_material("Mat")
    nm = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(nm.outputs[0], bsdf.inputs["Normal"])
    if image is not None or no_image:
        host = tree
        if in_group:
            group = bpy.data.node_groups.new("Detail", "ShaderNodeTree")
            group.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
            gout = group.nodes.new("NodeGroupOutput")
            host = group
        tex = host.nodes.new("ShaderNodeTexImage")
        tex.name = "Bumps"
        tex.image = image
        if in_group:
            group.links.new(tex.outputs["Color"], gout.inputs[0])
            gnode = tree.nodes.new("ShaderNodeGroup")
            gnode.node_tree = group
            tree.links.new(gnode.outputs[0], nm.inputs["Color"])
        else:
            tree.links.new(tex.outputs["Color"], nm.inputs["Color"])
    obj.data.materials.append(mat)
    return mat


def _save(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return path


def _scene(tmp_path, fault):
    """A .blend (tmp_path/scene.blend) with object Plane carrying `fault`."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tex = tmp_path / "tex.png"
    _write_png(tex)
    image = None
    if fault in ("missing", "unreadable", "good", "partial", "far", "group_missing",
                 "nan_positions", "zero_area", "readonly", "overlap"):
        image = bpy.data.images.load(str(tex))
    if fault in ("nan_pixels", "inf_pixels"):
        exr = tmp_path / "tex.exr"
        _write_exr(exr, np.nan if fault == "nan_pixels" else np.inf)
        image = bpy.data.images.load(str(exr))
    if image is not None:
        image.colorspace_settings.name = "Non-Color"
    verts = uvs = None
    quads = 1
    if fault == "nan_positions":
        verts = [(0, 0, 0), (1, 0, 0), (1, float("nan"), 0), (0, 1, 0)]
    if fault == "zero_area":
        verts = [(0.3, 0.3, 0.0)] * 4
    if fault == "partial":                          # the second quad at v -1..0
        quads = 2
        uvs = [(0, 0), (1, 0), (1, 1), (0, 1), (0, -1), (1, -1), (1, 0), (0, 0)]
    if fault == "overlap":                          # two quads on the same 0-1 square
        quads = 2
    obj = _plane(verts, uvs, quads)
    if fault == "far":
        obj.location = (5000.0, 0.0, 0.0)
    _material(obj, image, in_group=fault == "group_missing", no_image=fault == "no_image")
    blend = _save(tmp_path / "scene.blend")
    if fault in ("missing", "group_missing"):
        tex.unlink()
    if fault == "unreadable":
        tex.write_bytes(b"not a png at all")
    return blend


def _bake_cli(blend, out, *more):
    return run_python(["-m", "surfgrad_addon", "bake-normal-map", "--blend", blend,
                       "--object", "Plane", "--output", out, "--resolution", RES, *more],
                      timeout=300)


def _listing(folder):
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


FAULTS = [
    ("missing", ["tex.png", "does not exist", "Find Missing Files", "material 'Mat'"]),
    ("unreadable", ["image 'tex.png'", "could not be read", "re-save it"]),
    ("nan_pixels", ["image 'tex.exr'", "non-finite pixels", "1 value(s)"]),
    ("inf_pixels", ["image 'tex.exr'", "non-finite pixels"]),
    ("no_image", ["image node 'Bumps'", "has no image", "magenta"]),
    ("group_missing", ["tex.png", "does not exist", "'Group > Bumps'"]),
    ("nan_positions", ["vertex positions of mesh 'Plane'", "NaN or Inf"]),
    ("zero_area", ["every face of mesh 'Plane'", "zero area"]),
    ("partial", ["1 face(s) of UV map 'UVMap'", "outside the UDIM range", "--allow-partial"]),
]


@pytest.mark.parametrize("fault,words", FAULTS, ids=[f for f, _ in FAULTS])
def test_a_bad_input_is_refused_before_baking(tmp_path, fault, words):
    blend = _scene(tmp_path, fault)
    before = _sha(blend)
    out_dir = tmp_path / "maps"
    out_dir.mkdir()
    res = _bake_cli(blend, out_dir / "n.png")
    assert res.returncode == exit_codes.BAD_REQUEST, (res.returncode, res.stderr[-2000:])
    for word in words:
        assert word in res.stderr, (word, res.stderr[-2000:])
    assert "Traceback" not in res.stderr
    assert "[2/3] baking" not in res.stdout                 # refused before Cycles ran
    assert _listing(out_dir) == []                          # no file, no temporary
    assert _sha(blend) == before


BAD_OPTIONS = [
    (["--margin", "-1"], "margin -1: use a whole number of texels from 0 to 1024"),
    (["--samples", "0"], "samples 0: use a whole number from 1 to 65536"),
    (["--resolution", "3"], "resolution 3: use a whole number of texels from 4 to 16384"),
    (["--tiles", "10o1"], "tiles '10o1': give UDIM numbers like 1001,1002"),
    (["--depth", "half"], "bit depth 'half' does not go with .png: use one of 8, 16"),
]


def test_bad_options_are_refused_with_every_problem_named(tmp_path):
    blend = _scene(tmp_path, "good")
    before = _sha(blend)
    out_dir = tmp_path / "maps"
    out_dir.mkdir()
    for args, message in BAD_OPTIONS:
        res = _bake_cli(blend, out_dir / "n.png", *args)
        assert res.returncode == exit_codes.BAD_REQUEST, (args, res.stderr[-2000:])
        assert message in res.stderr, (message, res.stderr[-2000:])
    # several at once: one message lists them all
    res = _bake_cli(blend, out_dir / "n.png", "--margin", "-1", "--samples", "0")
    assert res.returncode == exit_codes.BAD_REQUEST
    assert "2 problems:" in res.stderr and "margin -1" in res.stderr and "samples 0" in \
        res.stderr, res.stderr[-2000:]
    assert _listing(out_dir) == [] and _sha(blend) == before


def test_a_read_only_output_folder_is_refused_before_baking(tmp_path):
    blend = _scene(tmp_path, "readonly")
    before = _sha(blend)
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    immutable = False
    try:
        if os.access(ro, os.W_OK):            # root ignores modes: make the folder immutable
            immutable = subprocess.run(["chattr", "+i", str(ro)],
                                       capture_output=True).returncode == 0
            if not immutable:
                pytest.skip("cannot make a read-only folder here (root, no chattr)")
        res = _bake_cli(blend, ro / "n.png")
        assert res.returncode == exit_codes.BAD_REQUEST, res.stderr[-2000:]
        assert f"output folder {str(ro)!r} is not writable" in res.stderr, res.stderr[-2000:]
        assert ".part" not in res.stderr and "[2/3] baking" not in res.stdout
        assert _listing(ro) == []
        assert _sha(blend) == before
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(ro)])
        ro.chmod(0o755)


def test_a_valid_request_bakes_and_a_partial_layout_bakes_when_asked(tmp_path):
    blend = _scene(tmp_path, "good")
    res = _bake_cli(blend, tmp_path / "good.png")
    assert res.returncode == exit_codes.OK, res.stderr[-2000:]
    assert "[3/3] wrote" in res.stdout and "warning" not in res.stderr
    assert (tmp_path / "good.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = bpy.data.images.load(str(tmp_path / "good.png"))
    img.colorspace_settings.name = "Non-Color"
    px = np.empty(32 * 32 * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    # the texture is a flat normal map: the bake gives the surface normal back (tangent
    # space (0.5, 0.5, 1)), not Cycles' magenta for a missing image
    rgb = px.reshape(32, 32, 4)[8:24, 8:24, :3]
    assert np.allclose(rgb, [0.5, 0.5, 1.0], atol=2 / 255), rgb.reshape(-1, 3)[:3]

    blend = _scene(tmp_path / "p", "partial")
    before = _sha(blend)
    res = _bake_cli(blend, tmp_path / "partial.png", "--allow-partial")
    assert res.returncode == exit_codes.OK, res.stderr[-2000:]
    assert "surfgrad: warning: 1 face(s) of UV map 'UVMap' lie outside the UDIM range" in \
        res.stderr, res.stderr[-2000:]
    assert (tmp_path / "partial.png").is_file() and _sha(blend) == before


def test_far_from_the_origin_is_a_printed_warning(tmp_path):
    blend = _scene(tmp_path, "far")
    res = _bake_cli(blend, tmp_path / "far.png")
    assert res.returncode == exit_codes.OK, res.stderr[-2000:]
    assert "surfgrad: warning: object 'Plane' reaches 5001 m from the origin" in res.stderr, \
        res.stderr[-2000:]


def test_overlapping_uv_islands_are_a_printed_warning(tmp_path):
    """Two quads stacked on the same 0-1 square: every texel centre is under both, the 32 on
    each quad's diagonal too (a centre on a shared edge belongs to one of its triangles; before
    red team 50a to neither, and the warning said 97%), so all 1024 texels are contested at
    32 x 32: "100%" (not "1e+02%", as the 2g format wrote it)."""
    blend = _scene(tmp_path, "overlap")
    res = _bake_cli(blend, tmp_path / "overlap.png")
    assert res.returncode == exit_codes.OK, res.stderr[-2000:]
    assert "surfgrad: warning: UV map 'UVMap' of object 'Plane': 100% of tile 1001's texels " \
        "lie under more than one face" in res.stderr, res.stderr[-2000:]
    good = _scene(tmp_path / "g", "good")
    res = _bake_cli(good, tmp_path / "good.png")
    assert res.returncode == exit_codes.OK and "more than one face" not in res.stderr


@pytest.mark.tier("bake")
def test_the_api_refuses_in_process_and_leaves_the_file_as_it_was(tmp_path):
    from surfgrad_addon import api
    from surfgrad_addon.addon.bake_request import BakeRequestError
    blend = _scene(tmp_path, "nan_pixels")
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    image = bpy.data.images["tex.exr"]
    assert not image.has_data
    dirty = bpy.data.is_dirty            # 4.2's bpy module marks a file dirty on opening
    nodes = {m.name: len(m.node_tree.nodes) for m in bpy.data.materials}
    with pytest.raises(BakeRequestError, match="non-finite pixels") as err:
        api.bake_normal_map(bpy.data.objects["Plane"], tmp_path / "api.exr", resolution=16,
                            log=lambda *_: None)
    assert isinstance(err.value, ValueError)
    assert not image.has_data                    # loaded for the check, freed again
    assert {m.name: len(m.node_tree.nodes) for m in bpy.data.materials} == nodes
    assert sorted(i.name for i in bpy.data.images) == ["tex.exr"]
    assert not (tmp_path / "api.exr").exists()
    assert bpy.data.is_dirty == dirty


# bake-batch: the whole plan is checked before the first bake -------------------------------

def _two_assets(tmp_path):
    """good.blend (Plane, a readable texture) and bad.blend (Plane, its texture missing)."""
    good = _scene(tmp_path / "g", "good")
    bad = _scene(tmp_path / "b", "missing")
    return good, bad


def _batch_cli(*args):
    return run_python(["-m", "surfgrad_addon", "bake-batch", *args, "--resolution", RES,
                       "--workers", "0"], timeout=300)


def test_batch_fails_the_asset_with_a_missing_texture_before_any_bake(tmp_path):
    good, bad = _two_assets(tmp_path)
    hashes = {p: _sha(p) for p in (good, bad)}
    out = tmp_path / "out"
    res = _batch_cli(str(good), str(bad), "--output", str(out / "{file}_{object}.png"))
    assert res.returncode == exit_codes.BAKE_FAILED, res.stderr[-2000:]
    assert "surfgrad: error: scene.blend:Plane:" in res.stderr
    assert str(tmp_path / "b" / "tex.png") in res.stderr and "does not exist" in res.stderr
    manifest = json.loads((out / "surfgrad-bake-manifest.json").read_text())
    status = {Path(k).parent.name: v for k, v in manifest["assets"].items()}
    assert status["b"]["status"] == "failed" and "attempts" not in status["b"]   # never baked
    assert status["g"]["status"] == "baked"
    assert {p: _sha(p) for p in (good, bad)} == hashes
    assert "Traceback" not in res.stderr


def test_batch_bad_settings_and_collisions_are_refused_before_anything(tmp_path):
    good, bad = _two_assets(tmp_path)
    out = tmp_path / "out"
    settings = tmp_path / "s.json"
    settings.write_text(json.dumps({"defaults": {"resolution": "big"},
                                    "assets": {"Plane": {"margin": -1, "colour": 1}}}))
    res = _batch_cli(str(good), "--output", str(out / "{object}.png"), "--settings",
                     str(settings))
    assert res.returncode == exit_codes.BAD_REQUEST, res.stderr[-2000:]
    for word in ("resolution 'big'", "margin -1", "unknown setting(s) colour",
                 str(settings)):
        assert word in res.stderr, (word, res.stderr[-2000:])
    assert not out.exists()                                  # nothing at all
    # two assets on one file: refused before either bakes (the bad one's texture aside)
    other = _scene(tmp_path / "g2", "good")
    res = _batch_cli(str(good), str(other), "--output", str(out / "{object}.png"))
    assert res.returncode == exit_codes.BAD_REQUEST, res.stderr[-2000:]
    assert "would both write" in res.stderr and "tell them apart" in res.stderr
    assert _listing(out) == []
    assert "Traceback" not in res.stderr



def test_batch_refuses_a_partial_layout_unless_the_settings_allow_it(tmp_path):
    blend = _scene(tmp_path / "p", "partial")
    before = _sha(blend)
    out = tmp_path / "out"
    res = _batch_cli(str(blend), "--output", str(out / "{object}.png"))
    assert res.returncode == exit_codes.BAKE_FAILED, res.stderr[-2000:]
    assert "1 face(s) of UV map 'UVMap' of object 'Plane' lie outside the UDIM range" in \
        res.stderr and "--allow-partial" in res.stderr, res.stderr[-2000:]
    assert not (out / "Plane.png").exists()
    settings = tmp_path / "s.json"
    settings.write_text(json.dumps({"assets": {"Plane": {"allow_partial": True}}}))
    res = _batch_cli(str(blend), "--output", str(out / "{object}.png"), "--settings",
                     str(settings))
    assert res.returncode == exit_codes.OK, res.stderr[-2000:]
    assert "surfgrad: warning: scene.blend:Plane: 1 face(s) of UV map 'UVMap' lie outside" \
        in res.stderr, res.stderr[-2000:]
    assert (out / "Plane.png").is_file() and _sha(blend) == before
