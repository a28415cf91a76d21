"""Batch bakes (issue 14): UDIM tiles against single-image bakes and the source map, bit
depths, anti-aliasing, skip-on-unchanged, worker processes with retry, and each bad input
failing its own asset while the rest go on."""

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import batch, normal_bake as NB  # noqa: E402
from surfgrad_addon.addon.batch import session, worker_main, workers  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from support.child import run_python  # noqa: E402

pytestmark = pytest.mark.tier("bake")


QUIET = dict(log=lambda *_: None)


def _pixels(path, size):
    img = bpy.data.images.load(str(path))
    img.colorspace_settings.name = "Non-Color"
    px = np.empty(size * size * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(size, size, 4)[..., :3] * 2 - 1


def _angle(a, b):
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip((a * b).sum(-1), -1, 1)))


def _open(path):
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)


@pytest.fixture
def asset(tmp_path):
    """A .blend with object Rock: two quads, UVs filling tiles 1001 and 1003."""
    return BA.write_asset(tmp_path / "in" / "rock.blend", ("Rock",), tiles=(1001, 1003),
                          image_size=64)


def test_udim_tiles_match_the_single_image_bake_and_the_source(asset, tmp_path):
    _open(asset)
    rock = bpy.data.objects["Rock"]
    assert NB.uv_tiles(rock.data, "UVMap") == ([1001, 1003], 0)
    out = tmp_path / "rock.<UDIM>.exr"
    res = NB.bake_normal_tiles(rock, out, resolution=64, margin=0, **QUIET)
    assert sorted(p.name for p in tmp_path.glob("rock.*.exr")) == ["rock.1001.exr",
                                                                   "rock.1003.exr"]
    assert res["tiles"] == [1001, 1003] and not (tmp_path / "rock.1002.exr").exists()
    assert not list(tmp_path.glob(".*part*"))                    # no temporary left
    single = NB.bake_normal_tiles(rock, tmp_path / "single.exr", resolution=64, margin=0,
                                  tiles=[1001], **QUIET)
    tile1 = _pixels(tmp_path / "rock.1001.exr", 64)
    assert np.abs(tile1 - _pixels(single["paths"][1001], 64)).max() < 1e-6
    # On flat quads the tangent-space bake is the source map, in both tiles.
    src = BA.source_normals(64)
    for t in (1001, 1003):
        err = _angle(_pixels(tmp_path / f"rock.{t}.exr", 64), src)
        assert np.median(err) < 0.05 and np.percentile(err, 99) < 0.5, (t, np.median(err))
    assert _angle(src, src * 0 + [0, 0, 1]).max() > 30          # the map is not flat
    # One tile alone (a farm task): the same texels as in the bake of every tile.
    alone = NB.bake_normal_tiles(rock, tmp_path / "alone.<UDIM>.exr", resolution=64, margin=0,
                                 tiles=[1003], **QUIET)
    assert list(alone["paths"]) == [1003] and not (tmp_path / "alone.1001.exr").exists()
    assert np.abs(_pixels(alone["paths"][1003], 64)
                  - _pixels(tmp_path / "rock.1003.exr", 64)).max() < 1e-6


def test_bit_depths_are_what_the_files_hold(asset, tmp_path):
    _open(asset)
    rock = bpy.data.objects["Rock"]
    for depth, ext in (("8", "png"), ("16", "png"), ("half", "exr"), ("float", "exr")):
        NB.bake_normal_tiles(rock, tmp_path / f"d{depth}.<UDIM>.{ext}", resolution=32,
                             margin=0, depth=depth, **QUIET)
    assert (tmp_path / "d8.1003.png").read_bytes()[24] == 8          # IHDR bit depth
    assert (tmp_path / "d16.1003.png").read_bytes()[24] == 16

    def exr_pixel_type(path):                   # the chlist's first channel: 1 half, 2 float
        data = path.read_bytes()[:1000]
        i = data.index(b"chlist\x00") + len(b"chlist\x00") + 4
        name_end = data.index(b"\x00", i)
        return struct.unpack("<i", data[name_end + 1:name_end + 5])[0]

    assert exr_pixel_type(tmp_path / "dhalf.1001.exr") == 1
    assert exr_pixel_type(tmp_path / "dfloat.1001.exr") == 2
    ref = _pixels(tmp_path / "dfloat.1003.exr", 32)
    for name, tol in (("dhalf.1003.exr", 2e-3), ("d16.1003.png", 1e-4), ("d8.1003.png", 8e-3)):
        assert np.abs(_pixels(tmp_path / name, 32) - ref).max() < tol, name
    assert bpy.context.scene.render.image_settings.file_format == "PNG"   # put back
    with pytest.raises(NB.NormalBakeError, match="does not go with .png"):
        NB.bake_normal_tiles(rock, tmp_path / "x.<UDIM>.png", resolution=32, depth="half",
                             **QUIET)


def test_uv_layouts_that_miss_the_target_tiles_are_refused(asset, tmp_path):
    _open(asset)
    rock = bpy.data.objects["Rock"]
    cases = [
        (dict(output=tmp_path / "r.png"), "spans UDIM tiles 1001, 1003 .* has no <UDIM>"),
        (dict(output=tmp_path / "r.<UDIM>.png", tiles=[1002]),
         r"tile\(s\) 1002 hold no UVs .* \(its UVs are in 1001, 1003\)"),
        (dict(output=tmp_path / "r.png", tiles=[1003]), "has no <UDIM>: only tile 1001"),
    ]
    for kw, message in cases:
        with pytest.raises(NB.NormalBakeError, match=message):
            NB.bake_normal_tiles(rock, resolution=16, **kw, **QUIET)
    # UVs only in tile 1002 and a single image: nothing inside the 0-1 square (each quad
    # squeezed into 1002, keeping its area: a zero-area face covers no tile).
    uv = rock.data.uv_layers["UVMap"].data
    for d in uv:
        d.uv = ((d.uv[0] * 0.999) % 1 + 1, (d.uv[1] * 0.999) % 1)
    with pytest.raises(NB.NormalBakeError, match="puts nothing inside the 0-1 UV square .* "
                                                 "tiles 1002"):
        NB.bake_normal_tiles(rock, tmp_path / "r.png", resolution=16, **QUIET)
    # A farm task over asset x tile skips a tile without UVs instead.
    res = NB.bake_normal_tiles(rock, tmp_path / "r.<UDIM>.png", resolution=16, tiles=[1005],
                               empty_tiles="skip", **QUIET)
    assert res["paths"] == {} and res["tiles"] == []
    assert list(tmp_path.glob("r.*")) == []


def test_samples_anti_alias_detail_finer_than_a_texel(tmp_path):
    """Per-texel random normals at 4x the bake resolution: one sample per texel picks one
    source texel; 16 jittered samples approach the texel's average (the box-filtered source,
    computed here from the map itself)."""
    blend = BA.write_asset(tmp_path / "noise.blend", ("N",), tiles=(1001,), image_size=256,
                           kind="noise", seed=3)
    _open(blend)
    obj = bpy.data.objects["N"]
    errs = {}
    box = BA.source_normals(256, "noise", 3).reshape(64, 4, 64, 4, 3).mean(axis=(1, 3))
    for samples in (1, 16):
        NB.bake_normal_tiles(obj, tmp_path / f"s{samples}.exr", resolution=64, margin=0,
                             samples=samples, **QUIET)
        errs[samples] = float(np.mean(_angle(_pixels(tmp_path / f"s{samples}.exr", 64), box)))
    print("mean angle to the box-filtered source (deg):", errs)
    assert errs[16] < 0.5 * errs[1], errs
    assert errs[1] > 5, errs                                  # the aliasing is real


def _run(blends, out, **kw):
    return batch.bake_batch([str(b) for b in blends], str(out), **{"log": lambda *_: None,
                                                                     **kw})


@pytest.fixture
def three(tmp_path):
    files = [BA.write_asset(tmp_path / "in" / f"a{i}.blend", (f"Rock{i}", f"Tree{i}"),
                            image_size=32, seed=i) for i in range(3)]
    return files


def test_batch_skips_unchanged_and_rebakes_what_changed(three, tmp_path):
    out = tmp_path / "out" / "{file}" / "{object}.<UDIM>.png"
    r1 = _run(three, out, defaults={"resolution": 32}, workers=0)
    assert r1["counts"] == {"baked": 6, "skipped": 0, "failed": 0}
    files = sorted(p.relative_to(tmp_path / "out").as_posix()
                   for p in (tmp_path / "out").rglob("*.png"))
    assert files == sorted(f"a{i}/{o}{i}.{t}.png" for i in range(3) for o in ("Rock", "Tree")
                           for t in (1001, 1002))
    manifest = json.loads((tmp_path / "out" / batch.MANIFEST_NAME).read_text())
    entry = manifest["assets"][f"{three[0].resolve()}:Rock0"]
    assert entry["status"] == "baked" and entry["settings"]["resolution"] == 32
    assert entry["settings"]["uv_map"] == "UVMap" and entry["timings"]["bake_s"] > 0
    assert set(entry["files"]) == {"1001", "1002"}
    mtimes = {p: p.stat().st_mtime_ns for p in (tmp_path / "out").rglob("*.png")}

    r2 = _run(three, out, defaults={"resolution": 32}, workers=0)
    assert r2["counts"] == {"baked": 0, "skipped": 6, "failed": 0}
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes          # nothing rewritten

    # A changed setting for one asset (settings file), a changed input file, and --force.
    settings = tmp_path / "per_asset.json"
    settings.write_text(json.dumps({"assets": {"a1.blend:Tree1": {"resolution": 16}}}))
    BA.write_asset(three[2], ("Rock2", "Tree2"), image_size=32, seed=99)
    r3 = _run(three, out, defaults={"resolution": 32}, settings_file=settings, workers=0)
    status = {k.split(":")[-1]: v["status"] for k, v in r3["assets"].items()}
    assert status == {"Rock0": "skipped", "Tree0": "skipped", "Rock1": "skipped",
                      "Tree1": "baked", "Rock2": "baked", "Tree2": "baked"}
    img = bpy.data.images.load(str(tmp_path / "out" / "a1" / "Tree1.1001.png"))
    assert tuple(img.size) == (16, 16)
    r4 = _run(three, out, defaults={"resolution": 32}, settings_file=settings, workers=0,
              force=True)
    assert r4["counts"]["baked"] == 6


def test_batch_never_overwrites_files_it_did_not_write(three, tmp_path):
    out = tmp_path / "out" / "{object}.<UDIM>.png"
    (tmp_path / "out").mkdir()
    foreign = tmp_path / "out" / "Rock0.1002.png"
    foreign.write_bytes(b"someone else's map")
    r = _run(three[:1], out, defaults={"resolution": 16}, workers=0)
    assert r["assets"][f"{three[0].resolve()}:Rock0"]["status"] == "failed"
    assert "--overwrite" in r["assets"][f"{three[0].resolve()}:Rock0"]["error"]
    assert r["assets"][f"{three[0].resolve()}:Tree0"]["status"] == "baked"
    assert foreign.read_bytes() == b"someone else's map"
    assert not (tmp_path / "out" / "Rock0.1001.png").exists()    # the asset wrote nothing
    r = _run(three[:1], out, defaults={"resolution": 16}, workers=0, overwrite=True)
    assert r["counts"] == {"baked": 1, "skipped": 1, "failed": 0}
    assert foreign.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.tier("child")
def test_workers_bake_the_same_files_and_retry_a_dead_worker(three, tmp_path):
    one = _run(three, tmp_path / "w0" / "{file}_{object}.<UDIM>.png",
               defaults={"resolution": 32}, workers=0)
    two = _run(three, tmp_path / "w2" / "{file}_{object}.<UDIM>.png",
               defaults={"resolution": 32}, workers=2)
    assert one["counts"] == two["counts"] == {"baked": 6, "skipped": 0, "failed": 0}
    for p in (tmp_path / "w0").glob("*.png"):
        assert np.abs(_pixels(p, 32) - _pixels(tmp_path / "w2" / p.name, 32)).max() < 1e-6
    assert len(two["process_start_s"]) == 2 and all(s > 0 for s in two["process_start_s"])

    env = dict(os.environ, **{session.FAULT_ENV: "die-once:Tree1"})
    r = _run(three, tmp_path / "r1" / "{file}_{object}.<UDIM>.png",
             defaults={"resolution": 16}, workers=2, worker_env=env)
    tree1 = r["assets"][f"{three[1].resolve()}:Tree1"]
    assert tree1["status"] == "baked" and len(tree1["attempts"]) == 2
    assert "worker process died (exit code 70)" in tree1["attempts"][0]["error"]
    assert r["counts"] == {"baked": 6, "skipped": 0, "failed": 0}

    env = dict(os.environ, **{session.FAULT_ENV: "die:Tree1"})
    r = _run(three, tmp_path / "r2" / "{file}_{object}.<UDIM>.png",
             defaults={"resolution": 16}, workers=2, worker_env=env)
    tree1 = r["assets"][f"{three[1].resolve()}:Tree1"]
    assert tree1["status"] == "failed" and len(tree1["attempts"]) == 2
    assert "worker process died" in tree1["error"]
    assert r["counts"] == {"baked": 5, "skipped": 0, "failed": 1}
    assert not (tmp_path / "r2" / "a1_Tree1.1001.png").exists()
    assert not list((tmp_path / "r2").glob(".*"))                 # nothing half-written


@pytest.mark.tier("child")
def test_the_worker_is_a_file_that_loads_surfgrad_from_its_own_folder(three, tmp_path):
    """The worker command runs worker_main.py as a file (no code string), here from a folder
    outside the checkout: it loads the package it sits in, says ready, answers a scan with
    the file's assets, and ends at the end of its input. Imported, the file loads nothing."""
    cmd = workers.worker_command()
    assert cmd[1:] == ["-P", str(Path(worker_main.__file__).resolve())]
    assert worker_main.PACKAGE not in sys.modules
    request = {"op": "scan", "id": 7, "blend": str(three[1]), "objects": None}
    res = subprocess.run(cmd, input=json.dumps(request) + "\n", capture_output=True,
                         text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    mark = worker_main.RESULT_MARK
    replies = [json.loads(line[len(mark):]) for line in res.stdout.splitlines()
               if line.startswith(mark)]
    assert [(r["op"], r.get("id")) for r in replies] == [("ready", None), ("scan", 7)]
    scan = replies[1]
    assert scan["status"] == "ok" and scan["errors"] == []
    assert sorted(a["object"] for a in scan["assets"]) == ["Rock1", "Tree1"]
    assert all(a["uv_maps"] == {"UVMap": [1001, 1002]} for a in scan["assets"]), scan["assets"]


@pytest.mark.tier("child")
def test_command_line_bad_inputs_fail_their_asset_and_the_rest_go_on(three, tmp_path):
    notblend = tmp_path / "in" / "notes.txt"
    notblend.write_text("not a blend")
    fake = tmp_path / "in" / "fake.blend"
    fake.write_text("not a blend either")
    lists = tmp_path / "assets.txt"
    lists.write_text("# farm list\nin/a0.blend:Rock0\nin/a1.blend\n")
    out = tmp_path / "out" / "{file}_{object}.<UDIM>.png"
    cases = [
        ([str(notblend), str(three[0])], "notes.txt is not a .blend file", 2),
        ([str(fake), str(three[0])], "is named .blend but is not a Blender file", 2),
        ([str(three[0]), "--uv-map", "Detail"], "has no UV map 'Detail'; it has ['UVMap']", 0),
        ([str(three[0]), "--tiles", "1003"], "tile(s) 1003 hold no UVs", 0),
    ]
    for i, (args, message, baked) in enumerate(cases):
        res = run_python(["-m", "surfgrad_addon", "bake-batch", *args, "--output",
                          str(out).replace("out", f"out{i}"), "--resolution", "16",
                          "--workers", "0"])
        assert res.returncode == 1, (args, res.stderr[-2000:])
        assert message in res.stderr, (message, res.stderr[-2000:])
        assert "Traceback" not in res.stderr
        assert len(list((tmp_path / f"out{i}").glob("*.png"))) == 2 * baked, args
    # no <UDIM> for multi-tile assets; the asset list's one entry
    res = run_python(["-m", "surfgrad_addon", "bake-batch", "--asset-list", str(lists),
                      "--asset-index", "0", "--output", str(tmp_path / "o5" / "{object}.png"),
                      "--resolution", "16", "--workers", "0"])
    assert res.returncode == 1 and "has no <UDIM>" in res.stderr and "Rock0" in res.stderr
    res = run_python(["-m", "surfgrad_addon", "bake-batch", "--asset-list", str(lists),
                      "--output", str(tmp_path / "o6" / "{file}_{object}.<UDIM>.png"),
                      "--resolution", "16", "--workers", "1"])
    assert res.returncode == 0, res.stderr[-2000:]
    assert sorted(p.name for p in (tmp_path / "o6").glob("*.png")) == [
        "a0_Rock0.1001.png", "a0_Rock0.1002.png", "a1_Rock1.1001.png", "a1_Rock1.1002.png",
        "a1_Tree1.1001.png", "a1_Tree1.1002.png"]
    assert "[3/3]" in res.stdout and "ETA" in res.stdout
    res = run_python(["-m", "surfgrad_addon", "bake-batch", str(three[0]), "--output",
                      str(tmp_path / "o7" / "{name}.png")])
    assert res.returncode == 2 and "unknown token {name}" in res.stderr


@pytest.mark.tier("child")
def test_collections_and_the_api(tmp_path):
    blend = BA.write_asset(tmp_path / "c.blend", ("A", "B", "C"), tiles=(1001,),
                           image_size=16, collection="Props")
    _open(blend)
    bpy.data.collections["Props"].objects.unlink(bpy.data.objects["C"])
    bpy.ops.wm.save_mainfile()
    from surfgrad_addon import api
    r = api.bake_batch([str(blend)], str(tmp_path / "o" / "{object}_{uv}.png"),
                       collections=["Props"], workers=1, resolution=16, samples=2, log=print)
    assert sorted(a["object"] for a in r["assets"].values()) == ["A", "B"]
    assert sorted(p.name for p in (tmp_path / "o").glob("*.png")) == ["A_UVMap.png",
                                                                       "B_UVMap.png"]
    assert all(a["settings"]["samples"] == 2 for a in r["assets"].values())
    # The open file in this session (no worker processes), its objects given directly.
    r = api.bake_batch(None, str(tmp_path / "o2" / "{file}-{object}.png"),
                       objects=[bpy.data.objects["C"]], resolution=16, log=lambda *_: None)
    assert r["counts"]["baked"] == 1 and (tmp_path / "o2" / "c-C.png").is_file()
    with pytest.raises(ValueError, match="takes no setting colour"):
        api.bake_batch([str(blend)], "x.png", colour=1)


@pytest.mark.tier("child")
def test_the_readme_example_bakes_the_procedural_assets(tmp_path):
    """README: batch-assets, then bake-batch over them with 2 workers (as a fresh clone)."""
    res = run_python(["-m", "surfgrad_addon", "batch-assets", "--out", tmp_path / "assets",
                      "--count", "3"])
    assert res.returncode == 0, res.stderr[-2000:]
    blends = sorted((tmp_path / "assets").glob("*.blend"))
    assert len(blends) == 3
    res = run_python(["-m", "surfgrad_addon", "bake-batch", *blends, "--output",
                      tmp_path / "maps" / "{file}_{object}.<UDIM>.png", "--resolution", "32",
                      "--workers", "2"])
    assert res.returncode == 0, res.stderr[-2000:]
    assert sorted(p.name for p in (tmp_path / "maps").glob("*.png")) == [
        f"asset_{i:03d}_Asset{i:03d}.{t}.png" for i in range(3) for t in (1001, 1002)]
    again = run_python(["-m", "surfgrad_addon", "batch-assets", "--out", tmp_path / "assets",
                        "--count", "3"])
    assert again.returncode == 2 and "--overwrite" in again.stderr
