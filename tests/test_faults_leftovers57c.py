"""Red team 57c: defects earlier helpers noticed and left, measured and fixed (bake-batch on a
full disk, symbolic links as outputs, the Flamenco job type's object names).

1. bake-batch whose manifest fills the disk (a 200 kB tmpfs with one 4 kB page free, 5.2,
   one 16^2 asset): the bake failed as it should (the map's write cut off), exit 1, its last
   manifest write failed with a clear line; but the run left `maps/` with a 1244-byte
   manifest holding only the scan (written before the bake), where nothing was baked. Now
   a run that made the manifest and put no map in place removes it and the folders it made
   when its last write fails: the tmpfs held nothing but the filler afterwards (also with
   `maps/{file}/...`). A manifest recording a map the run put in place stays (a rerun must
   know it as its own). Simulated here: every manifest write after the first fails.

2. An output that is a symbolic link to nothing (`maps/Rock.png -> /mnt/share/rock.png`,
   the share unmounted): bake-normal-map baked first, then said "... exists; pass
   --overwrite", exit 2; with --overwrite the link was replaced by the map, exit 0, the
   share's file never written. bake-batch resolved the link and said "output folder
   '/mnt/share' does not exist: create it first" (the target's folder, not the path given),
   and where the target's folder existed wrote the map there. Now refused before the bake,
   naming the link and its target, exit 2 (bake-batch: the asset fails, exit 1), the link
   left as it was. A link to a regular file is an existing output: without --overwrite
   refused ("exists"), with it the link is replaced by the map and its target left as it
   was, in bake-normal-map as before and now in bake-batch too (before, bake-batch resolved
   the link and replaced the target file: a versioned `v003.png` behind `latest.png`
   overwritten). Written up in docs/pipelines.md, "Known limits".

3. bake-batch with `maps/N.png -> /dev/null` (an output turned off), --overwrite: refused
   as "output '/dev/null': use a .png or .exr file name", the user's path not named, since
   the batch resolved the whole output path. Now the folder alone is resolved, and the
   refusal names the path given and the link's target: "output '.../N.png' is not a regular
   file (a named pipe, device or socket, through a symbolic link to '/dev/null')".

4. The Flamenco job type with objects "Rock" and "rock" (or "Café" with é as one code point
   and as e + U+0301) and `{object}` in the output: two tasks, maps/Rock.png and
   maps/rock.png, one file on a macOS or Windows disk or SMB share, where the second task
   failed ("exists", an option the job does not have); the manifest names of the two forms
   differed too (one file on APFS). Now refused on submission naming both objects; the
   manifest names fold forms as they fold case. (bake-batch and the OpenJD template probe the
   output's file system: output_names.py, list_tasks.py; fine.)
"""

import errno
import os
import sys
import unicodedata
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

sys.path.insert(0, str(Path(__file__).parent))
from support.flamenco import compile_job  # noqa: E402
from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.batch import manifest as M  # noqa: E402
from surfgrad_addon.addon.batch.run import bake_batch  # noqa: E402
from surfgrad_addon.addon.exit_codes import BakeFailed  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RUN = dict(defaults={"resolution": 16, "margin": 0}, log=lambda *_: None, workers=0)


def _blend(tmp_path):
    return BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)


@pytest.mark.parametrize("pattern", ["{object}.png", "{file}/{object}.png"])
def test_a_batch_whose_manifest_fills_the_disk_leaves_nothing(pattern, tmp_path, monkeypatch):
    blend = _blend(tmp_path)
    out = tmp_path / "out"
    write_json, writes = M._write_json, []

    def full_after_the_scan(path, data):         # the scan's write fits; nothing after it
        writes.append(path)
        if len(writes) > 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        write_json(path, data)
    monkeypatch.setattr(M, "_write_json", full_after_the_scan)
    with pytest.raises(BakeFailed) as err:
        bake_batch([str(blend)], str(out / "maps" / pattern), **RUN)
    manifest = out / "maps" / M.MANIFEST_NAME
    assert str(err.value).startswith(f"manifest {manifest} could not be written (No space "
                                     f"left on device)"), err.value
    assert len(writes) >= 3                        # the scan, the pending record, the last
    assert not out.exists(), sorted(str(p) for p in out.rglob("*"))


def test_a_manifest_recording_a_map_stays_when_the_last_write_fails(tmp_path, monkeypatch):
    """The control: the map was put in place and recorded; the last write fails."""
    blend = _blend(tmp_path)
    maps = tmp_path / "maps"
    write_json = M._write_json

    def full_at_the_end(path, data):
        if "total_s" in data:                      # (only the last write carries it)
            raise OSError(errno.ENOSPC, "No space left on device")
        write_json(path, data)
    monkeypatch.setattr(M, "_write_json", full_at_the_end)
    with pytest.raises(BakeFailed):
        bake_batch([str(blend)], str(maps / "{object}.png"), **RUN)
    assert sorted(p.name for p in maps.iterdir()) == ["Rock.png", M.MANIFEST_NAME]
    assert "Rock.png" in (maps / M.MANIFEST_NAME).read_text()


def _bake_normal_map(blend, out, capsys, *extra):
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(out), "--resolution", "16", "--margin", "0",
                           *extra])
    return rc, capsys.readouterr().err


@pytest.mark.parametrize("overwrite", [[], ["--overwrite"]])
def test_a_link_to_nothing_as_output_is_refused_naming_its_target(overwrite, tmp_path, capsys):
    blend = _blend(tmp_path)
    target = tmp_path / "share" / "rock.png"          # (the share: not mounted)
    out = tmp_path / "maps" / "Rock.png"
    out.parent.mkdir()
    out.symlink_to(target)
    rc, err = _bake_normal_map(blend, out, capsys, *overwrite)
    assert rc == exit_codes.BAD_REQUEST, err
    assert (f"output {str(out)!r} is a symbolic link to {str(target)!r}, which does not exist"
            in err), err
    assert "baking" not in err and "Traceback" not in err     # (before the bake)
    assert out.is_symlink() and os.readlink(out) == str(target)
    report = bake_batch([str(blend)], str(out.parent / "{object}.png"), overwrite=bool(overwrite),
                        manifest=str(tmp_path / "m.json"), **RUN)
    (rock,) = report["assets"].values()
    assert rock["status"] == "failed", rock
    assert f"output {str(out)!r} is a symbolic link to {str(target)!r}" in rock["error"]
    assert out.is_symlink() and not target.parent.exists()
    # (the share's folder there, its file not: the batch wrote the map into it before)
    target.parent.mkdir()
    report = bake_batch([str(blend)], str(out.parent / "{object}.png"), overwrite=bool(overwrite),
                        manifest=str(tmp_path / "m.json"), **RUN)
    (rock,) = report["assets"].values()
    assert rock["status"] == "failed", rock
    assert list(target.parent.iterdir()) == []


def test_a_link_to_a_file_is_replaced_not_its_target_in_both_commands(tmp_path, capsys):
    blend = _blend(tmp_path)
    maps = tmp_path / "maps"
    maps.mkdir()
    for name in ("Rock.png", "Other.png"):
        (maps / f"v003_{name}").write_bytes(b"version 3")
        (maps / name).symlink_to(maps / f"v003_{name}")
    rc, err = _bake_normal_map(blend, maps / "Other.png", capsys)
    assert rc == exit_codes.BAD_REQUEST and f"{maps / 'Other.png'} exists" in err, err
    rc, err = _bake_normal_map(blend, maps / "Other.png", capsys, "--overwrite")
    assert rc == 0, err
    report = bake_batch([str(blend)], str(maps / "{object}.png"), overwrite=True,
                        manifest=str(tmp_path / "m.json"), **RUN)
    assert report["counts"]["baked"] == 1, report["assets"]
    for name in ("Rock.png", "Other.png"):
        assert not (maps / name).is_symlink(), name
        assert (maps / name).read_bytes()[:4] == b"\x89PNG", name
        assert (maps / f"v003_{name}").read_bytes() == b"version 3", name


def test_a_batch_output_linked_to_dev_null_is_named_as_given(tmp_path):
    blend = _blend(tmp_path)
    out = tmp_path / "N.png"
    out.symlink_to(os.devnull)
    report = bake_batch([str(blend)], str(out), overwrite=True,
                        manifest=str(tmp_path / "m.json"), **RUN)
    (rock,) = report["assets"].values()
    assert rock["status"] == "failed", rock
    assert rock["error"].startswith(
        f"output {str(out)!r} is not a regular file (a named pipe, device or socket, through "
        f"a symbolic link to {os.devnull!r})"), rock["error"]
    assert os.readlink(out) == os.devnull


def _job(objects, pattern="/p/maps/{object}.png"):
    return compile_job({"objects": objects, "tiles": "1001", "blendfile": "/p/a.blend",
                        "output_pattern": pattern, "manifest_dir": "/p/m"})


NFC, NFD = unicodedata.normalize("NFC", "Café"), unicodedata.normalize("NFD", "Café")


@pytest.mark.tier("child")                          # (node compiles the job)
@pytest.mark.parametrize("a, b", [("Rock", "rock"), (NFC, NFD), ("ROCK:1", "rock_1")])
def test_flamenco_refuses_objects_one_file_apart_only_in_case_or_form(a, b):
    assert len(NFC) == 4 and len(NFD) == 5
    job = _job(f"{a},{b}")
    assert "tasks" not in job, job
    assert f"names one file for objects '{a}' and '{b}'" in job["error"], job
    assert "rename one of them" in job["error"]
    assert "tasks" in _job("Rock,Tree"), "control: names apart"
    # With {uv} the maps may be apart (UV maps are known only on the farm): two tasks, and two
    # manifests whose names are apart in case and form too.
    job = _job(f"{a},{b}", "/p/maps/{object}_{uv}.png")
    manifests = [next(x for x in t["commands"][0]["parameters"]["args"] if x.endswith(".json"))
                 for t in job["tasks"]]
    assert len(manifests) == 2
    assert len({unicodedata.normalize("NFC", m).lower() for m in manifests}) == 2, manifests
