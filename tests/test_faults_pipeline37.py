"""Fault injection, red team 37b: names a studio file server meets, on a render farm's batch.

- Blender fills in a tiled image's <UDIM> by printf formatting (the token becomes %d), so a '%'
  elsewhere in an output path (a folder '100%', an object 'Rock%d' in {object}) was read as a
  format: the tiles were written into folders named by the tile number and stray numbers,
  exit 1 with the temporary files left there ('%s' crashed the whole batch: exit 139). Now
  the path Blender saves is escaped, and the maps land where they were asked.
- The same formatting reads a UDIM texture's tiles: one in a folder with '%' was refused as
  "damaged" ('%d'), or crashed the check (exit 139, '%s'). Now refused naming the '%'.
- bake-batch filled in the output pattern's tokens one after another, so an object named
  '{uv}' was baked into 'UVMap.png' (a file named after another token's value), exit 0.
- A manifest's reruns: a run of every tile after one of `--tiles 1001` skipped the asset (tile
  1002 never baked, exit 0), and a run whose output pattern had changed replaced a file at the
  new name that no run had written (an artist's), without --overwrite, exit 0.
- Two object names one only in Unicode normal form (é as one character, or e and an accent
  as macOS writes it) land on one file where the file system ignores forms (APFS, HFS+):
  the second map replaced the first with exit 0; the probe asked about case only.
- A UDIM texture's tiles were not among the files the manifest hashes (Blender lists the path
  with <UDIM>), nor the frame file an image sequence reads (only the file named in its path):
  a repainted tile or frame, and the rerun skipped the asset with the old map, exit 0.
- A `--manifest` named as one of the maps: with --overwrite the map became the manifest's
  JSON, exit 0; the settings file given as the manifest was taken for one and replaced.
- A share that does not lock files (ENOLCK) was called 'in use by another bake-batch run'.
- compare of a multi-tile object with '%' in $TMPDIR: its tiles read back through Blender's
  tile format went to other folders, and a raw RuntimeError ended it.
- A texture named with Blender's <UVTILE> (n.u1_v1.png), which Cycles reads, was refused as
  missing: the checks filled in <UDIM> only."""

import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.batch import MANIFEST_NAME  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402

pytestmark = pytest.mark.tier("bake")

SMALL = ["--resolution", "16", "--samples", "1", "--margin", "0"]


def _pixels(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        return np.array(img.pixels[:]).reshape(16, 16, 4)
    finally:
        bpy.data.images.remove(img)


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_udim_outputs_with_percent_and_token_text_in_their_names_land_as_asked(tmp_path,
                                                                                capsys):
    """A two-tile asset with objects 'Rock%d' and '{uv}', baked by bake-batch into
    '100%d/{object}.<UDIM>.png'. Before: Rock%d's tiles went to 'out/1001001/.m.7.partPID.png'
    style names (Blender's format ate the '%d's), the bake failed 'Blender wrote no file',
    exit 1, temporary files left; '{uv}' was written as 'UVMap.1001.png'. Now every tile is
    at its name, the same texels as a bake of Rock%d into a plain name."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock%d", "{uv}"), tiles=(1001, 1002),
                           image_size=16)
    plain = tmp_path / "plain"
    plain.mkdir()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock%d",
                           "--output", str(plain / "m.<UDIM>.png")] + SMALL)
    assert rc == 0, capsys.readouterr().err
    out = tmp_path / "out"
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(blend), "--output",
                           str(out / "100%d" / "{object}.<UDIM>.png"), "--workers", "0"]
                          + SMALL)
    assert rc == 0, capsys.readouterr().err
    maps = [f"100%d/{o}.{t}.png" for o in ("Rock%d", "{uv}") for t in (1001, 1002)]
    assert _files(out) == sorted(maps + ["100%d/surfgrad-bake-manifest.json"])
    for t in (1001, 1002):
        baked = _pixels(out / "100%d" / f"Rock%d.{t}.png")
        assert np.array_equal(baked, _pixels(plain / f"m.{t}.png"))
        assert np.ptp(baked[..., :3]) > 0.1             # a map with detail, not a flat one
    # bake-normal-map alike: a folder with '%' in it
    pct = tmp_path / "50% done"
    pct.mkdir()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock%d",
                           "--output", str(pct / "m%x.<UDIM>.png")] + SMALL)
    assert rc == 0, capsys.readouterr().err
    assert _files(pct) == ["m%x.1001.png", "m%x.1002.png"]
    assert _files(tmp_path).count("a.blend") == 1        # nothing went beside them
    assert not [f for f in _files(tmp_path) if ".part" in f]


def _png(path, colour):
    """An 8 x 8 PNG of one colour."""
    img = bpy.data.images.new("t", 8, 8)
    img.pixels.foreach_set(np.tile([*colour, 1.0], 64).astype(np.float32))
    img.filepath_raw, img.file_format = str(path), "PNG"
    img.save()
    bpy.data.images.remove(img)


def _normal_map_scene(tiles, image):
    """A plane over `tiles` whose Normal Map reads `image` (Non-Color); returns the Image
    Texture node."""
    obj = BA.tiled_plane(bpy, "Plane", tiles)
    image.colorspace_settings.name = "Non-Color"
    mat = new_material("M")
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(tex.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"],
                   tree.nodes["Principled BSDF"].inputs["Normal"])
    obj.data.materials.append(mat)
    return tex


def _save(blend):
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return blend


TILE_COLOURS = {1001: (0.8, 0.4, 0.9), 1002: (0.25, 0.6, 0.85)}
TILE_NAMES = {"<UDIM>": {1001: "1001", 1002: "1002"},
              "<UVTILE>": {1001: "u1_v1", 1002: "u2_v1"}}      # Blender's u<column>_v<row>


def _udim_texture_scene(folder, blend, token="<UDIM>"):
    """A plane over tiles 1001-1002 whose Normal Map reads a UDIM PNG in `folder` (named with
    <UDIM>, or with <UVTILE>: u1_v1, u2_v1)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    folder.mkdir()
    name = f"n.{token}.png"
    for t, colour in TILE_COLOURS.items():
        _png(folder / name.replace(token, TILE_NAMES[token][t]), colour)
    img = bpy.data.images.load(str(folder / name.replace(token, TILE_NAMES[token][1001])))
    img.source = "TILED"
    img.filepath = str(folder / name)
    _normal_map_scene((1001, 1002), img)
    return _save(blend)


def _assert_tiles_read_their_files(maps):
    """Each tile of the baked map holds its own file's normal (a flat plane: tangent space is
    the UV frame)."""
    for t, colour in TILE_COLOURS.items():
        n = 2 * np.array(colour) - 1
        expected = 0.5 * n / np.linalg.norm(n) + 0.5
        texels = _pixels(Path(str(maps).replace("<UDIM>", str(t))))[..., :3].reshape(-1, 3)
        assert np.abs(texels - expected).max() < 0.01, (t, texels.mean(0), expected)


def test_a_udim_texture_in_a_folder_with_percent_is_refused_naming_it(tmp_path, capsys):
    """Before: 'image ... could not be read (damaged, or a format Blender does not open):
    re-save it as PNG or EXR', the wrong fix (with '%s' in the folder: a segmentation fault,
    exit 139, not run here). Now exit 2 naming the '%' and the fix; in bake-batch the asset
    fails with the same line. The same scene in a plain folder bakes."""
    said = "whose '%' Blender takes as part of a format"
    blend = _udim_texture_scene(tmp_path / "tex%d", tmp_path / "s.blend")
    capsys.readouterr()
    out = tmp_path / "out"
    out.mkdir()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out / "m.<UDIM>.png")] + SMALL)
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST and said in err and "tex%d" in err, err
    rc = commands.execute(["bake-batch", str(blend), "--output", str(out / "b.<UDIM>.png"),
                           "--workers", "0"] + SMALL)
    err = capsys.readouterr().err
    assert rc == exit_codes.BAKE_FAILED and said in err, err
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    assert said in manifest["assets"][f"{blend}:Plane"]["error"]
    assert [f for f in _files(out) if f.endswith(".png")] == []
    good = _udim_texture_scene(tmp_path / "tex", tmp_path / "good.blend")
    rc = commands.execute(["bake-normal-map", "--blend", str(good), "--object", "Plane",
                           "--output", str(out / "g.<UDIM>.png")] + SMALL)
    assert rc == 0, capsys.readouterr().err
    _assert_tiles_read_their_files(out / "g.<UDIM>.png")


def test_a_rerun_bakes_tiles_it_has_not_and_leaves_files_it_did_not_record(tmp_path, capsys):
    """One manifest (the output folder's), a two-tile asset. Before: a run of `--tiles 1001`
    and then one of every tile skipped the asset as unchanged, exit 0, tile 1002 never baked;
    and a run whose pattern had changed since (`{object}_n` for `{object}`) replaced an
    artist's own file at the new name without --overwrite, exit 0 (the earlier record's files
    being unchanged let it replace whatever was there). Now the second run bakes tile 1002
    (and 1001 again; 1002 the same texels as a bake of it alone), and the third fails that
    asset naming the file, which stays as it was. Tile by tile and then all skips the last
    run."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001, 1002), image_size=16,
                           kind="noise")
    alone = tmp_path / "alone"
    alone.mkdir()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(alone / "m.<UDIM>.png"), "--tiles", "1002"] + SMALL)
    assert rc == 0, capsys.readouterr().err
    maps = tmp_path / "maps"
    batch = ["bake-batch", str(blend), "--workers", "0"] + SMALL
    rc = commands.execute(batch + ["--output", str(maps / "{object}.<UDIM>.png"),
                                   "--tiles", "1001"])
    assert rc == 0, capsys.readouterr().err
    capsys.readouterr()
    rc = commands.execute(batch + ["--output", str(maps / "{object}.<UDIM>.png")])
    out = capsys.readouterr().out
    assert rc == 0 and "[1/1] baked a.blend:Rock: tile(s) 1001, 1002 " in out, out
    assert np.array_equal(_pixels(maps / "Rock.1002.png"), _pixels(alone / "m.1002.png"))
    manifest = json.loads((maps / MANIFEST_NAME).read_text())
    assert sorted(manifest["assets"][f"{blend}:Rock"]["files"]) == ["1001", "1002"]
    rc = commands.execute(batch + ["--output", str(maps / "{object}.<UDIM>.png")])
    assert rc == 0 and "[1/1] skipped a.blend:Rock" in capsys.readouterr().out
    # tile by tile, then all: each run keeps the record of the other's tile, so none is lost
    # (then taken for someone else's file) and the last run has nothing to do
    by_tile = batch + ["--output", str(tmp_path / "by_tile" / "{object}.<UDIM>.png")]
    for tile in ("1001", "1002"):
        assert commands.execute(by_tile + ["--tiles", tile]) == 0
    capsys.readouterr()
    rc = commands.execute(by_tile)
    assert rc == 0 and "[1/1] skipped a.blend:Rock" in capsys.readouterr().out
    artists = maps / "Rock_n.1001.png"
    artists.write_bytes(b"an artist's own map")
    rc = commands.execute(batch + ["--output", str(maps / "{object}_n.<UDIM>.png")])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAKE_FAILED and f"{artists} exists; pass --overwrite" in err, err
    assert artists.read_bytes() == b"an artist's own map"
    assert not (maps / "Rock_n.1002.png").exists()


def test_names_one_only_in_unicode_form_are_refused_where_the_file_system_ignores_forms(
        tmp_path, capsys, monkeypatch):
    """Objects 'Café' typed on Linux (é one character, NFC) and 'Café' from a Mac (e and a
    combining accent, NFD) into maps/{object}.png: two names, but one file on a file system
    that does not tell the forms apart (APFS, HFS+, an SMB share of them), where the second
    map replaced the first with exit 0 (the probe asked about case only). Such a file system
    is faked: refused naming both and why, nothing baked. This one keeps them apart (the probe
    says so and leaves nothing): both are baked."""
    from surfgrad_addon.addon.batch import output_names
    nfc, nfd = "Caf\u00e9", "Cafe\u0301"
    blend = BA.write_asset(tmp_path / "x.blend", (nfc, nfd), tiles=(1001,), image_size=16)
    out = tmp_path / "maps"
    batch = ["bake-batch", str(blend), "--output", str(out / "{object}.png"), "--workers",
             "0"] + SMALL
    monkeypatch.setattr(output_names, "ignores_forms", lambda folder: True, raising=False)
    capsys.readouterr()
    rc = commands.execute(batch)
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert err.strip().splitlines()[-2:] == [
        f"surfgrad: error: x.blend:{nfc} and x.blend:{nfd} would write {out / nfc}.png and "
        f"{out / nfd}.png, one file on this file system (it does not tell Unicode's normal "
        f"forms apart: an accent as part of a letter or as a character of its own, as macOS "
        f"writes names): the second map would replace the first; rename one, or make the "
        f"output pattern tell them apart", "(nothing was baked)"]
    assert not out.exists()
    monkeypatch.undo()
    probe_in = tmp_path / "probe"
    probe_in.mkdir()
    assert output_names.ignores_forms(str(probe_in / "not" / "yet")) is False
    assert list(probe_in.iterdir()) == []
    rc = commands.execute(batch)
    assert rc == 0, capsys.readouterr().err
    assert {f"{nfc}.png", f"{nfd}.png"} <= set(_files(out))


def test_a_rerun_bakes_again_when_a_udim_texture_tile_changed(tmp_path, capsys):
    """The manifest hashes the files a .blend uses, but Blender lists a UDIM texture by its
    path with <UDIM> (no file), which was left out. Before: a tile file repainted (an artist
    saving tile 1002 on the share), the rerun skipped the asset as unchanged, exit 0, and the
    map kept the old tile. Now the tiles are hashed: the rerun bakes, and tile 1002's map
    holds the new normal."""
    blend = _udim_texture_scene(tmp_path / "tex", tmp_path / "s.blend")
    out = tmp_path / "out"
    batch = ["bake-batch", str(blend), "--output", str(out / "m.<UDIM>.png"), "--workers",
             "0"] + SMALL
    assert commands.execute(batch) == 0, capsys.readouterr().err
    capsys.readouterr()
    assert commands.execute(batch) == 0
    assert "[1/1] skipped s.blend:Plane" in capsys.readouterr().out
    _png(tmp_path / "tex" / "n.1002.png", (0.5, 0.5, 1.0))     # repainted flat: (0, 0, 1)
    assert commands.execute(batch) == 0
    assert "[1/1] baked s.blend:Plane: tile(s) 1001, 1002 " in capsys.readouterr().out
    texels = _pixels(out / "m.1002.png")[..., :3].reshape(-1, 3)
    assert np.abs(texels - (0.5, 0.5, 1.0)).max() < 0.01, texels.mean(0)


def test_a_rerun_bakes_again_when_the_sequence_frame_it_reads_changed(tmp_path, capsys):
    """An image sequence read at frame 2 (the file's current frame): Blender lists its path
    as the first frame's file, which alone was hashed. Before: frame 2's file repainted, the
    rerun skipped the asset, exit 0, the map of the old frame kept. Now it bakes again."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    _png(tmp_path / "f_0001.png", (0.8, 0.4, 0.9))
    _png(tmp_path / "f_0002.png", (0.25, 0.6, 0.85))
    img = bpy.data.images.load(str(tmp_path / "f_0001.png"))
    img.source = "SEQUENCE"
    tex = _normal_map_scene((1001,), img)
    tex.image_user.frame_start, tex.image_user.frame_duration = 1, 2
    bpy.context.scene.frame_current = 2
    blend = _save(tmp_path / "s.blend")
    batch = ["bake-batch", str(blend), "--output", str(tmp_path / "out" / "m.png"),
             "--workers", "0"] + SMALL
    assert commands.execute(batch) == 0, capsys.readouterr().err
    _png(tmp_path / "f_0002.png", (0.5, 0.5, 1.0))
    capsys.readouterr()
    assert commands.execute(batch) == 0
    assert "[1/1] baked s.blend:Plane: tile(s) 1001 " in capsys.readouterr().out
    texels = _pixels(tmp_path / "out" / "m.png")[..., :3].reshape(-1, 3)
    assert np.abs(texels - (0.5, 0.5, 1.0)).max() < 0.01, texels.mean(0)


@pytest.mark.tier("blender")
def test_a_manifest_named_as_a_map_is_refused_before_anything_runs(tmp_path, capsys):
    """`--manifest out/Rock.1002.png` (a slip: one of the maps' names). Before: the run wrote
    its manifest there, then failed the asset as 'Rock.1002.png exists; pass --overwrite';
    with --overwrite it baked, and its manifest write replaced the map: exit 0, tile 1002's
    'map' the manifest's JSON. Now exit 2 naming the fix, nothing made."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001, 1002), image_size=16)
    out = tmp_path / "out"
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(blend), "--output", str(out / "{object}.<UDIM>.png"),
                           "--manifest", str(out / "Rock.1002.png"), "--overwrite",
                           "--workers", "0"] + SMALL)
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert err.strip().splitlines()[-1].endswith("a map's name: a map the batch writes there "
                                                 "would replace it, and it the map (with "
                                                 "--overwrite, the map was the manifest's "
                                                 "JSON, exit 0); name it .json"), err
    assert not out.exists()


@pytest.mark.tier("blender")
def test_a_settings_file_given_as_the_manifest_is_refused_and_kept(tmp_path, capsys):
    """`--settings per_asset.json --manifest per_asset.json` (a slip). A settings file's
    "assets" table (patterns to settings) passed for a manifest's. Before: exit 0, and the run
    replaced the settings file with its manifest (its "defaults" gone). Now exit 2 naming the
    file, which stays as it was."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    settings = tmp_path / "per_asset.json"
    text = json.dumps({"defaults": {"resolution": 16}, "assets": {"Rock*": {"samples": 2}}})
    settings.write_text(text)
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(blend), "--output", str(tmp_path / "out" /
                                                                     "{object}.png"),
                           "--settings", str(settings), "--manifest", str(settings),
                           "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert err.strip().splitlines()[-1].startswith(
        f"surfgrad: error: manifest {settings} is not a surfgrad manifest"), err
    assert settings.read_text() == text
    assert not (tmp_path / "out").exists()


@pytest.mark.tier("blender")
def test_a_share_that_does_not_lock_is_not_called_another_run(tmp_path, capsys, monkeypatch):
    """flock on a share whose lock service does not answer (NFS without lockd: ENOLCK).
    Before: 'manifest ... is in use by another bake-batch run ...: wait for that run to end',
    a run that does not exist, on every try. Now exit 2 naming the file system and the fix;
    the lock file and the folder it made are gone. A manifest another run holds is still
    named as such."""
    import errno
    import fcntl
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    out = tmp_path / "out"
    args = ["bake-batch", str(blend), "--output", str(out / "{object}.png"), "--workers", "0"]

    def no_lock_service(fd, op):
        raise OSError(errno.ENOLCK, os.strerror(errno.ENOLCK))
    with monkeypatch.context() as m:
        m.setattr(fcntl, "flock", no_lock_service)
        capsys.readouterr()
        rc = commands.execute(args)
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert "its folder's file system does not lock files (No locks available)" in err, err
    assert "in use by another" not in err
    assert not out.exists()
    out.mkdir()
    lock = out / f".{MANIFEST_NAME}.lock"
    with open(lock, "w") as held:                   # another run holds it
        fcntl.flock(held, fcntl.LOCK_EX)
        rc = commands.execute(args)
    assert rc == exit_codes.BAD_REQUEST and "is in use by another bake-batch run" in \
        capsys.readouterr().err


def test_compare_of_a_udim_object_with_percent_in_the_temporary_folder(tmp_path,
                                                                      monkeypatch):
    """compare reads a multi-tile bake back through 32-bit EXR tiles in a temporary folder,
    saved through Blender's tile format. With '%d' in $TMPDIR (a farm's per-task folder):
    before, the tiles went to folders named by the tile numbers beside it, and a raw
    RuntimeError ('Cannot read .../bake.1001.exr') ended the compare. Now the same agreement
    as in a plain folder, and nothing beside it."""
    from surfgrad_addon.harness import api as harness_api
    pct = tmp_path / "t%d"
    pct.mkdir()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = BA.tiled_plane(bpy, "P", (1001, 1002))
    monkeypatch.setattr(tempfile, "tempdir", str(pct))
    report = harness_api.compare(obj, "triplanar", resolution=16)
    assert report["texels_compared"] == 2 * 16 * 16 and report["max_deg"] < 0.01, report
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t%d"]
    assert list(pct.iterdir()) == []


def test_a_texture_named_with_uvtile_is_read_tile_by_tile(tmp_path, capsys):
    """A UDIM texture named Blender's other way, n.<UVTILE>.png (n.u1_v1.png, n.u2_v1.png:
    Mari's and Mudbox's names), which Blender and Cycles read. Before: refused, exit 2, 'reads
    .../n.<UVTILE>.png, which does not exist' (the checks filled in <UDIM> only). Now each
    tile of the map holds its own file's normal, and a batch hashes both files."""
    blend = _udim_texture_scene(tmp_path / "tex", tmp_path / "s.blend", "<UVTILE>")
    out = tmp_path / "out"
    out.mkdir()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out / "m.<UDIM>.png")] + SMALL)
    assert rc == 0, capsys.readouterr().err
    _assert_tiles_read_their_files(out / "m.<UDIM>.png")
    rc = commands.execute(["bake-batch", str(blend), "--output", str(out / "b.<UDIM>.png"),
                           "--workers", "0"] + SMALL)
    assert rc == 0, capsys.readouterr().err
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    assert manifest["files"][str(blend)]["dependencies"] == [
        str(tmp_path / "tex" / "n.u1_v1.png"), str(tmp_path / "tex" / "n.u2_v1.png")]
