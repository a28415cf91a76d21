"""Red team 53c: what a render farm's batches meet (5.2 measured; the tests run on every line).

1. An asset list baked one entry a task (`bake-batch --asset-list L --asset-index N`, each with
   its own manifest: the OpenJD template's tasks, run here with the arguments its script
   passes), two entries of which land on one file: two files' objects of one name under a
   pattern without a folder per file (`in/a/rock.blend:Rock`, `in/b/rock.blend:Rock` and
   `{file}_{object}.exr`; or `{object}.exr`), or one asset listed twice (`a.blend` and, on
   another line, `sub/../a.blend:Rock`). A whole run refuses them (exit 2), but a task saw its
   own entry only. Measured (5.2, 16^2, float EXR): with Overwrite=yes both tasks exited 0, and
   the map entry 0's manifest recorded (with entry 0's hash) held entry 1's normals: 56.3 deg
   (mean; 125.2 max) off entry 0's own source; without it the task ending second failed,
   exit 1, "rock_Rock.exr exists; pass --overwrite (api: overwrite=True) to replace it": a fix
   that leads to the case above (and "exists" for the asset listed twice, whose map was
   baked). Now each task checks the other entries whose output is known without opening
   their file (batch/list_tasks.py): refused, exit 2, naming the entry, the file and the fix,
   nothing written (no map, no manifest); entries that write apart still bake, each its
   own normals.
2. The manifest's lock file (`.NAME.lock` beside it) opened for writing: another user's (a TD's
   and the farm's runs into one shared folder; 0644 as a run makes it) raised a raw
   PermissionError traceback, exit 1 (measured with an immutable lock file, which root may
   not write either: `Operation not permitted`), both while that user's run was under way
   (it should say "in use by another bake-batch run") and after such a run was killed with
   SIGKILL (the lock file stays; nothing holds it). A folder in its place: IsADirectoryError,
   the same. Now the lock is taken through a read-only descriptor where the file may not be
   written (flock needs no more): a live run is named as such, exit 2; a left one is taken and
   the batch bakes; one that cannot be opened at all (or on NFS, whose locks need writing) is
   refused naming the file and the fixes, exit 2; a folder in its place too.
3. The Flamenco job type (one task per object x tile, each `--open-file --objects=NAME`) with
   an output pattern that names one file for two of its objects: no {object} in it
   (`maps/{file}_nrm.<UDIM>.png` for 'Rock, Stone'), or two names that become one in a file
   name ('Wall:L' and 'Wall_L', '..' and '__'). The job compiled; the first task baked, the
   second failed, exit 1, "b_nrm.1001.png exists; pass --overwrite (api: overwrite=True)",
   an option the job does not have (which task won was the farm's scheduling). Now refused on
   submission naming both objects and the fix, where the file is certain (no {uv} in it).
4. `api.bake_batch(None, ...)` (the open file, in this session) from a script in a background
   session (`blender -b scene.blend --python-expr`, the bpy module): Blender's is_dirty, which
   the batch read for unsaved changes, stays False after a script's edits there. A script that
   baked, changed the material (another image: a normal tilted 36.9 deg) and baked again got
   the second call skipped ("inputs, settings and outputs unchanged"): the map kept the first
   state's normals, 54.9 deg (mean; 103.6 max) off the edited material's; and the manifest
   recorded the edited session's maps under the file's hash, so a later `bake-batch
   scene.blend` into that folder skipped them as the file's (a map of a state never saved,
   exit 0). Now a run of the
   open file in a background session started by a script (the API; not the command line's
   --open-file, which Blender has just opened: the Flamenco task) bakes every asset and records
   them as unsaved, which no run skips nor reuses the scan of. (The --open-file task is
   skipped when unchanged on every line now; on 5.0 and earlier, whose is_dirty is True once a
   file is opened in the bpy module, it had been baked again each time.)
5. An output whose path, with the temporary file the bake saves beside it first, passes the
   1023 bytes Blender keeps of a path (FILE_MAX, every line; a studio server's deep folders
   of long names): Blender cut the path short and saved the map there. Measured: a temporary
   file path of 1023 bytes is saved, 1024 is not. bake-normal-map and api.bake_normal_map
   (into a folder 1097 bytes deep): exit 1, "Blender wrote no file .../.r.part<pid>-<token>.png"
   with a stray file `.r.part<pid>-<token>.pn` left beside it; bake-batch: exit 1 for each
   asset, "BakeFailed: ... Blender wrote no file" (one tile) or "Blender could not write the
   map ... the disk may be full" (<UDIM>), the 18 folders made. Now refused before anything
   runs (the batch: exit 2, no folder made), naming the path's length, the limit and how many
   bytes to cut (normal_bake.blender_path_problem; it counts the longest temporary name, so up
   to 12 bytes under the limit are refused too).
6. A path option quoted with a leading '~' (`--output "~/maps/{object}.<UDIM>.png"`: patterns
   are quoted for their <UDIM>, as the docs write them, so the shell does not expand it):
   bake-batch made a folder named '~' in the current folder and baked there, exit 0 (and
   bake-normal-map `--output "~/r.png"` wrote ./~/r.png where that folder was); the asset list
   took '~' as the home folder already. Now a leading '~' of a path option of either command
   line (--output, --manifest, --settings, --asset-list, --blend, the .blend arguments, ...) is
   the home folder; where the process has none, refused naming the option and the fix, exit 2.
Left (docs/farm.md): an entry naming another file alone (its objects are known only by opening
it, which a task does not do) is not checked.
"""

import errno
import fcntl
import json
import os
import pwd
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.baked_normals import degrees_between, read_normals  # noqa: E402
from support.flamenco import compile_job  # noqa: E402
from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon import normal_bake as NB  # noqa: E402
from surfgrad_addon.addon.batch import manifest as M  # noqa: E402
from surfgrad_addon.addon.batch import plan as P  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402

pytestmark = pytest.mark.tier("bake")

SIZE = 16


def _task(listing, index, output, manifests, overwrite=True):
    """One task of the OpenJD template (tools/farm/openjd/surfgrad-bake.yaml), tile 1001."""
    return commands.execute(
        ["bake-batch", "--asset-list", str(listing), "--asset-index", str(index),
         "--tiles", "1001", "--if-tile-empty", "skip", "--output", str(output),
         "--manifest", str(manifests / f"asset-{index}-tile-1001.json"),
         "--resolution", str(SIZE), "--samples", "1", "--margin", "0", "--space", "tangent",
         "--depth", "float", "--workers", "0"] + (["--overwrite"] if overwrite else []))


def _normals(path):
    return read_normals(path, SIZE)


@pytest.fixture
def two_rocks(tmp_path):
    """Two .blend files named rock.blend in two folders, each with an object Rock whose maps
    differ (hemispheres; noise)."""
    BA.write_asset(tmp_path / "in" / "a" / "rock.blend", ("Rock",), tiles=(1001,),
                   image_size=SIZE)
    BA.write_asset(tmp_path / "in" / "b" / "rock.blend", ("Rock",), tiles=(1001,),
                   image_size=SIZE, kind="noise", seed=5)
    listing = tmp_path / "in" / "assets.txt"
    listing.write_text("a/rock.blend:Rock\nb/rock.blend:Rock\n")
    return listing


@pytest.mark.parametrize("pattern", ["{file}_{object}.exr", "{object}.exr"])
def test_two_entries_on_one_map_are_refused_by_each_task(two_rocks, tmp_path, capsys,
                                                          pattern):
    maps, manifests = tmp_path / "maps", tmp_path / "manifests"
    for index in (0, 1):
        assert _task(two_rocks, index, maps / pattern, manifests) == exit_codes.BAD_REQUEST
        err = capsys.readouterr().err
        other = ("b", 1) if index == 0 else ("a", 0)
        assert (f"rock.blend:Rock and entry {other[1]} of the asset list {two_rocks} "
                f"('{two_rocks.parent / other[0]}/rock.blend:Rock') would both write "
                f"{maps / pattern.format(file='rock', object='Rock')}") in err, err
        assert "make the output pattern tell them apart" in err and "(nothing was baked)" in err
        assert "Traceback" not in err
    assert not maps.exists() and not manifests.exists()


def test_entries_that_write_apart_bake_their_own_normals(two_rocks, tmp_path):
    """The check does not refuse what a whole run takes: b's file under another name."""
    (two_rocks.parent / "b" / "rock.blend").rename(two_rocks.parent / "b" / "cliff.blend")
    two_rocks.write_text("a/rock.blend:Rock\nb/cliff.blend:Rock\n")
    maps, manifests = tmp_path / "maps", tmp_path / "manifests"
    assert [_task(two_rocks, i, maps / "{file}_{object}.exr", manifests) for i in (0, 1)] \
        == [0, 0]
    own = {"rock": BA.source_normals(SIZE), "cliff": BA.source_normals(SIZE, "noise", 5)}
    for name, src in own.items():
        err = degrees_between(_normals(maps / f"{name}_Rock.exr"), src)
        assert np.median(err) < 0.5, (name, float(np.median(err)))
    # (the two sources are far apart: a map holding the other's is plainly wrong)
    assert degrees_between(own["rock"], own["cliff"]).mean() > 10
    for i in (0, 1):
        recorded = json.loads((manifests / f"asset-{i}-tile-1001.json").read_text())
        assert [a["status"] for a in recorded["assets"].values()] == ["baked"]


def test_an_asset_listed_twice_is_refused_naming_the_entry(tmp_path, capsys):
    BA.write_asset(tmp_path / "in" / "a.blend", ("Rock", "Stone"), tiles=(1001,),
                   image_size=SIZE)
    (tmp_path / "in" / "sub").mkdir()
    listing = tmp_path / "in" / "assets.txt"
    listing.write_text("# every asset of a.blend, and Rock again\na.blend\nsub/../a.blend:Rock\n"
                       "a.blend:Stone\n")
    maps, manifests = tmp_path / "maps", tmp_path / "manifests"
    # without Overwrite (the template's default): before, entry 1 failed "exists", exit 1
    assert _task(listing, 1, maps / "{object}.exr", manifests, overwrite=False) == \
        exit_codes.BAD_REQUEST
    err = capsys.readouterr().err
    assert (f"a.blend:Rock is also baked by entry 0 of the asset list {listing} "
            f"('{listing.parent}/a.blend'), into the same file {maps / 'Rock.exr'}") in err, err
    assert "list it once" in err and "exists" not in err.split("(--asset-index)")[0]
    assert _task(listing, 0, maps / "{object}.exr", manifests, overwrite=False) == \
        exit_codes.BAD_REQUEST
    err = capsys.readouterr().err
    assert "a.blend:Rock is also baked by entry 1" in err, err
    assert "a.blend:Stone is also baked by entry 2" in err, err
    assert not maps.exists() and not manifests.exists()


@pytest.fixture
def foreign_lock(tmp_path, monkeypatch):
    """A lock file beside the manifest that this user may read, not write (another user's, as
    their run leaves it): opening it for writing is refused as the system would (the tests run
    as root, whom file modes do not stop)."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=SIZE)
    maps = tmp_path / "maps"
    maps.mkdir()
    lock = maps / ".surfgrad-bake-manifest.json.lock"
    lock.write_bytes(b"")
    real_open = os.open

    def as_another_user(path, flags, *args):
        if os.path.abspath(path) == str(lock) and flags & (os.O_RDWR | os.O_WRONLY):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *args)
    monkeypatch.setattr(M.os, "open", as_another_user)
    command = ["bake-batch", str(blend), "--output", str(maps / "{object}.png"),
               "--resolution", str(SIZE), "--margin", "0", "--workers", "0"]
    return command, maps, lock


def test_another_users_live_run_is_named_as_a_run_under_way(foreign_lock, capsys):
    command, maps, lock = foreign_lock
    held = os.open(lock, os.O_RDONLY)            # that user's run: it holds the lock
    try:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        rc = commands.execute(command)           # before: PermissionError raised out
    finally:
        os.close(held)
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert "is in use by another bake-batch run" in err and str(lock) in err, err
    assert sorted(p.name for p in maps.iterdir()) == [lock.name]


def test_another_users_lock_left_by_a_killed_run_is_taken(foreign_lock, capsys):
    command, maps, lock = foreign_lock
    assert commands.execute(command) == 0, capsys.readouterr().err     # before: raised
    assert (maps / "Rock.png").read_bytes().endswith(b"IEND\xaeB`\x82")
    recorded = json.loads((maps / "surfgrad-bake-manifest.json").read_text())["assets"]
    assert [a["status"] for a in recorded.values()] == ["baked"]


def test_a_lock_that_cannot_be_opened_or_is_a_folder_is_named(foreign_lock, capsys,
                                                              monkeypatch):
    command, maps, lock = foreign_lock
    real_open = M.os.open

    def unreadable(path, flags, *args):          # (0600: not even read)
        if os.path.abspath(path) == str(lock):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *args)
    monkeypatch.setattr(M.os, "open", unreadable)
    assert commands.execute(command) == exit_codes.BAD_REQUEST
    err = capsys.readouterr().err
    assert (f"its lock file {lock} is another user's (this user may not open it: Permission "
            f"denied)") in err and f"rm {lock}" in err, err
    monkeypatch.undo()
    lock.unlink()
    lock.mkdir()
    assert commands.execute(command) == exit_codes.BAD_REQUEST
    err = capsys.readouterr().err
    assert f"{lock} is a folder, where bake-batch keeps the manifest's lock file" in err, err
    assert "Traceback" not in err
    assert sorted(p.name for p in maps.iterdir()) == [lock.name]


@pytest.mark.tier("child")
@pytest.mark.parametrize("names, pattern, one", [
    ("Rock, Stone", "/o/{file}_nrm.<UDIM>.png", None),
    ("Wall:L, Wall_L", "/o/{object}.png", "Wall_L"),
    ("a|b, a?b", "/o/{file}/{object}.<UDIM>.exr", "a_b"),
    (r"\.\., __", "/o/{object}.png", "__"),
])
def test_a_flamenco_job_whose_objects_share_one_file_is_refused(names, pattern, one):
    settings = {"objects": names, "tiles": "1001", "blendfile": "/farm/b.blend",
                "output_pattern": pattern, "manifest_dir": "/o/manifests"}
    objects = [n.strip().replace("\\", "") for n in names.split(", ")]
    # bake-batch's own names for them: one file (the job type's rule agrees with the planner's)
    assert len({P.expand(pattern, "b.blend", o, "UVMap") for o in objects}) == 1
    error = compile_job(settings).get("error")                     # before: it compiled
    assert error and error.startswith(f"output_pattern '{pattern}' names one file for objects "
                                      f"'{objects[0]}' and '{objects[1]}'"), error
    assert error.endswith("rename one of them" if one else "put {object} in the pattern")
    if one:
        assert f"(both become '{one}' in a file name)" in error


@pytest.mark.tier("child")
def test_a_flamenco_job_whose_objects_write_apart_compiles():
    base = {"tiles": "1001-1002", "blendfile": "/farm/b.blend", "manifest_dir": "/o/m"}
    # (Names that differ in case alone are refused since round 57: test_faults_leftovers57c.)
    for names, pattern in (("Rock, Moss, Stone", "/o/{object}.<UDIM>.png"),
                           ("Wall:L, Wall_L", "/o/{uv}.<UDIM>.png"),      # (UV maps unknown)
                           ("Rock", "/o/{file}.<UDIM>.png")):
        objects = names.split(", ")
        if "{uv}" not in pattern:
            assert len({P.expand(pattern, "b.blend", o, "UVMap") for o in objects}) == \
                len(objects)
        job = compile_job(dict(base, objects=names, output_pattern=pattern))
        assert "error" not in job, job
        assert len(job["tasks"]) == 2 * len(objects)


def _tilted_image(normal):
    img = bpy.data.images.new("Tilted", 4, 4, alpha=False, float_buffer=True)
    img.colorspace_settings.is_data = True
    img.pixels.foreach_set(np.tile([*(0.5 * np.asarray(normal) + 0.5), 1.0], 16)
                           .astype(np.float32))
    img.pack()
    return img


def test_a_script_edit_in_a_background_session_is_baked_not_skipped(tmp_path):
    blend = BA.write_asset(tmp_path / "d.blend", ("Rock",), tiles=(1001,), image_size=SIZE)
    out = tmp_path / "maps" / "{object}.exr"
    rock = tmp_path / "maps" / "Rock.exr"
    hemispheres = BA.source_normals(SIZE)
    tilted = np.array([0.6, 0.0, 0.8])                    # 36.9 deg off the surface normal
    opts = dict(objects=["Rock"], resolution=SIZE, margin=0, depth="float", log=None)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    assert bpy.app.background
    first = api.bake_batch(None, str(out), **opts)
    assert [a["status"] for a in first["assets"].values()] == ["baked"]
    assert np.median(degrees_between(_normals(rock), hemispheres)) < 0.5
    # the script's edit: the material reads another image (not saved)
    tree = bpy.data.objects["Rock"].active_material.node_tree
    next(n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage").image = \
        _tilted_image(tilted)
    second = api.bake_batch(None, str(out), **opts)
    assert [a["status"] for a in second["assets"].values()] == ["baked"]     # before: skipped
    off = degrees_between(_normals(rock), tilted)
    assert off.max() < 0.5, off.max()                    # before: 36.9 mean (the first map)
    # The file itself, as Blender's command line opens it: its map, not the session's.
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    command = ["bake-batch", f"{blend}:Rock", "--output", str(out), "--resolution", str(SIZE),
               "--margin", "0", "--depth", "float", "--workers", "0"]
    assert commands.execute(command) == 0                 # (it opens the file in this session)
    recorded = json.loads((tmp_path / "maps" / "surfgrad-bake-manifest.json").read_text())
    assert [a["status"] for a in recorded["assets"].values()] == ["baked"]   # before: skipped
    assert np.median(degrees_between(_normals(rock), hemispheres)) < 0.5
    assert commands.execute(command) == 0
    recorded = json.loads((tmp_path / "maps" / "surfgrad-bake-manifest.json").read_text())
    assert [a["status"] for a in recorded["assets"].values()] == ["skipped"]
    # A Flamenco task: Blender's command line opened the file, no script between: skipped.
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    assert commands.execute(["bake-batch", "--open-file", "--objects=Rock", "--output",
                             str(out), "--resolution", str(SIZE), "--margin", "0", "--depth",
                             "float", "--workers", "0"]) == 0
    recorded = json.loads((tmp_path / "maps" / "surfgrad-bake-manifest.json").read_text())
    assert [a["status"] for a in recorded["assets"].values()] == ["skipped"]


def _deep(root, total):
    """A folder under `root` whose absolute path has `total` bytes (names of 200 bytes)."""
    path, rest = str(root), total - len(str(root))
    while rest > 0:
        k = min(200, rest - 1) if rest > 201 else rest - 1
        k = max(k, 1)
        path += "/" + "e" * k
        rest = total - len(path)
    assert len(path) == total, (len(path), total)
    return path


def test_an_output_path_too_long_for_blender_is_refused_before_anything_runs(tmp_path,
                                                                             capsys):
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=SIZE)
    before = sorted(tmp_path.rglob("*"))
    deep = _deep(tmp_path / "maps", 1100)
    rc = commands.execute(["bake-batch", str(blend), "--output", f"{deep}/{{object}}.png",
                           "--resolution", str(SIZE), "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err                      # before: 1, after baking
    assert "a.blend:Rock: output '" in err and "is too long a path for Blender" in err, err
    assert "Blender takes 1023" in err and "bytes shorter" in err and "Traceback" not in err
    assert sorted(tmp_path.rglob("*")) == before                  # (no folder made)
    # bake-normal-map into a folder that exists: before, a stray cut-off file was left there
    os.makedirs(deep)
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", f"{deep}/r.png", "--resolution", str(SIZE)])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST and "is too long a path for Blender" in err, err
    assert list(Path(deep).iterdir()) == []
    # At the limit, counted as the check counts (a 7-digit process id, a half EXR's name): it
    # bakes, and the map is whole where it was asked.
    name = "r.png"
    extra = len(f"/.r.half.png") + NB.TEMP_NAME_EXTRA
    fits = _deep(tmp_path / "fits", NB.BLENDER_PATH_MAX - extra)
    os.makedirs(fits)
    out = Path(fits) / name
    assert NB.blender_path_problem(out) is None
    assert NB.blender_path_problem(Path(fits + "e") / name) is not None
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(out), "--resolution", str(SIZE)])
    assert rc == 0, capsys.readouterr().err
    assert [p.name for p in Path(fits).iterdir()] == [name]
    assert out.read_bytes().endswith(NB.PNG_END)


def test_a_quoted_tilde_in_a_path_option_is_the_home_folder(tmp_path, monkeypatch, capsys):
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=SIZE)
    home, cwd = tmp_path / "home", tmp_path / "cwd"
    home.mkdir()
    cwd.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(cwd)
    small = ["--resolution", str(SIZE), "--workers", "0"]
    assert commands.execute(["bake-batch", str(blend), "--output", "~/maps/{object}.<UDIM>.png",
                             "--manifest", "~/m.json", *small]) == 0, capsys.readouterr().err
    assert list(cwd.iterdir()) == []                          # before: a folder '~' here
    assert sorted(p.name for p in home.rglob("*")) == ["Rock.1001.png", "m.json", "maps"]
    assert (home / "maps" / "Rock.1001.png").read_bytes().endswith(NB.PNG_END)
    assert commands.execute(["bake-normal-map", "--blend", "~/../a.blend", "--object", "Rock",
                             "--output", "~/r.png", "--resolution", str(SIZE)]) == 0
    assert (home / "r.png").read_bytes().endswith(NB.PNG_END) and list(cwd.iterdir()) == []

    def no_entry(uid):
        raise KeyError(f"getpwuid(): uid not found: {uid}")
    monkeypatch.delenv("HOME")
    monkeypatch.setattr(pwd, "getpwuid", no_entry)          # a container's arbitrary uid
    capsys.readouterr()
    assert commands.execute(["bake-batch", str(blend), "--output", "~/n/{object}.png",
                             *small]) == exit_codes.BAD_REQUEST
    assert capsys.readouterr().err.strip() == (
        "surfgrad: error: --output '~/n/{object}.png' starts with '~', but this process has no "
        "home folder (HOME is not set, and the system knows none for this user): set HOME, or "
        "write the path in full")
    assert list(cwd.iterdir()) == []
