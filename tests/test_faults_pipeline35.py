"""Fault injection, red team 35b: linked libraries and output places a pipeline meets.

A material reading a node group or an image linked from a library that is gone (moved, a
relative path broken, renamed there, unreadable, saved by a newer Blender), also one linked in
through another library: Blender leaves an empty placeholder, and the bake wrote a flat map
(a group that outputs nothing) or a uniform one (an image without pixels), exit 0. Only a
material linked from a missing library was refused. And the harness commands' outputs in a
place no file can be made (a read-only or system folder, a dangling symbolic link) ended in a
raw traceback, or in Python's bare "[Errno 17] File exists", or ran for minutes first. Also: a
working folder removed under the command (a traceback), a `--manifest` that is a dangling link
(replaced by a file), a loop of links (told "give a shorter path"), <UDIM> twice in an output
name (exit 1 and temporary files left), an output ending in '/' (baked into the file, exit 0),
and a batch stopped while reading its files ("0 asset(s) not baked")."""

import os
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402

pytestmark = pytest.mark.tier("bake")

FIX = "so Blender left an empty placeholder: "


def _link_into(scene, library, kind, names, use, obj="Rock"):
    """Open `scene`, link `names` of `kind` (node_groups, images, materials) from `library`
    (a relative path), hand them to use(object `obj`, linked blocks by name), save."""
    bpy.ops.wm.open_mainfile(filepath=str(scene), use_scripts=False)
    with bpy.data.libraries.load(str(library), link=True, relative=True) as (_src, dst):
        setattr(dst, kind, list(names))
    use(bpy.data.objects[obj], {b.name: b for b in getattr(dst, kind)})
    bpy.ops.wm.save_as_mainfile(filepath=str(scene), compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return scene


def _groups_of(obj):
    return [n for n in obj.material_slots[0].material.node_tree.nodes if n.type == "GROUP"]


def _scenes(tmp_path):
    """lib.blend (object Rock, material Rock_SG: SG groups and a packed image) and four shots
    reading it: its groups in a local material, its image in a local material, a material of
    sub/mid.blend whose SG Resolve group mid.blend links from lib.blend (indirect), and a
    library override of Rock_SG (local data, its groups and image still the library's)."""
    lib = BA.write_asset(tmp_path / "lib.blend", ("Rock",), tiles=(1001,), image_size=16)
    bpy.ops.wm.open_mainfile(filepath=str(lib), use_scripts=False)
    groups = sorted({n.node_tree.name for n in _groups_of(bpy.data.objects["Rock"])})
    bpy.ops.wm.read_factory_settings(use_empty=True)

    def use_groups(obj, linked):
        for node in _groups_of(obj):
            if node.node_tree.name in linked:
                node.node_tree = linked[node.node_tree.name]

    def use_image(obj, linked):
        for node in obj.material_slots[0].material.node_tree.nodes:
            if node.type == "TEX_IMAGE":
                node.image = linked["Rock_src"]

    def use_material(obj, linked):
        obj.data.materials[0] = next(iter(linked.values()))

    def use_override(obj, linked):
        obj.data.materials[0] = linked["Rock_SG"].override_create(remap_local_usages=True)

    def shot(name):
        return BA.write_asset(tmp_path / name, ("Rock",), tiles=(1001,), image_size=16)
    mid = BA.write_asset(tmp_path / "sub" / "mid.blend", ("Mid",), tiles=(1001,),
                         image_size=16)
    _link_into(mid, lib, "node_groups", ["SG Resolve"], use_groups, obj="Mid")
    return lib, {
        "groups": _link_into(shot("groups.blend"), lib, "node_groups", groups, use_groups),
        "image": _link_into(shot("image.blend"), lib, "images", ["Rock_src"], use_image),
        "indirect": _link_into(shot("indirect.blend"), mid, "materials", ["Mid_SG"],
                               use_material),
        "override": _link_into(shot("override.blend"), lib, "materials", ["Rock_SG"],
                               use_override)}


def _bake(capsys, blend, output):
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(output), "--resolution", "16"])
    return rc, capsys.readouterr().err


def _rgb(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        return np.asarray(img.pixels[:], np.float32).reshape(16, 16, 4)[..., :3]
    finally:
        bpy.data.images.remove(img)


def test_data_linked_from_a_library_that_is_gone_is_refused_naming_it(tmp_path, capsys):
    """Before, with lib.blend moved away: the groups, the indirect and the override shot baked
    a flat map, every texel (0.502, 0.502, 1.0), exit 0, in bake-normal-map and bake-batch
    alike; the image shot a uniform (0.212, 0.212, 0.788), exit 0, under a warning about
    colour space ''.
    With the library there they bake the library's own map."""
    lib, shots = _scenes(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    rc, err = _bake(capsys, lib, out / "lib.png")
    assert rc == 0, err
    own = _rgb(out / "lib.png")
    assert own.std(axis=(0, 1)).min() > 0.1              # a map with detail, not a flat one
    for name, blend in shots.items():
        rc, err = _bake(capsys, blend, out / f"{name}.png")
        assert rc == 0, err
        assert np.abs(_rgb(out / f"{name}.png") - own).max() < 1e-6, name
    moved = lib.rename(tmp_path / "lib_moved.blend")
    where = f"linked from library '//lib.blend' ({lib})"
    said = {"groups": f"node group 'SG Resolve' is {where}, which is missing, {FIX}",
            "image": f"image 'Rock_src' is {where}, which is missing, {FIX}",
            "indirect": f"node group 'SG Resolve' is linked from library '//lib.blend' ({lib}) "
                        f"(linked in through library '//sub/mid.blend'), which is missing, "
                        f"{FIX}put the library file there or relink it",
            "override": f"node group 'SG Resolve' is {where}, which is missing, {FIX}"}
    for name, blend in shots.items():
        rc, err = _bake(capsys, blend, out / f"gone_{name}.png")
        assert rc == exit_codes.BAD_REQUEST and said[name] in err, (name, err)
        assert "Traceback" not in err
        rc = commands.execute(["bake-batch", str(blend), "--output",
                               str(out / "batch" / f"{name}_{{object}}.png"),
                               "--resolution", "16", "--workers", "0"])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAKE_FAILED and said[name] in err, (name, err)
    assert sorted(p.name for p in out.rglob("*.png")) == sorted(
        ["lib.png"] + [f"{n}.png" for n in shots])
    # The library back, but the group renamed there; then a file no Blender line reads,
    # saved (by its header) by a far newer one.
    moved.rename(lib)
    bpy.ops.wm.open_mainfile(filepath=str(lib), use_scripts=False)
    bpy.data.node_groups["SG Resolve"].name = "SG Resolve (old)"
    bpy.ops.wm.save_mainfile()
    rc, err = _bake(capsys, shots["groups"], out / "renamed.png")
    assert rc == exit_codes.BAD_REQUEST, err
    assert "node group 'SG Resolve' is linked from library '//lib.blend', which no longer " \
           "holds it (renamed or removed there)" in err, err
    lib.write_bytes(b"BLENDER17-01v0999" + bytes(4096))
    for name in ("groups", "image"):
        rc, err = _bake(capsys, shots[name], out / "newer.png")
        assert rc == exit_codes.BAD_REQUEST, err
        line = err.strip().splitlines()[-1]
        assert str(lib) in line and "saved by Blender 9.99, newer than this Blender" in line \
            and "bake with Blender 9.99 or later" in line, err
    assert not (out / "renamed.png").exists() and not (out / "newer.png").exists()


def test_a_library_a_newer_line_saved_is_warned_about(tmp_path, capsys, monkeypatch):
    """Probed for real: 4.5 baked a shot whose library 5.2 had saved, exit 0 and no word (the
    main file's own line is warned about); 4.2, which cannot read the library, refused it as
    "could not be opened (... lib.blend ...): give a .blend file Blender can open", naming the
    shot as the file to fix. Here the running line is taken as one older than this one."""
    from surfgrad_addon.addon import open_blend
    lib = BA.write_asset(tmp_path / "lib.blend", ("Rock",), tiles=(1001,), image_size=16)
    shot = _link_into(BA.write_asset(tmp_path / "shot.blend", ("Rock",), tiles=(1001,),
                                     image_size=16),
                      lib, "materials", ["Rock_SG"],
                      lambda obj, linked: obj.data.materials.__setitem__(0, linked["Rock_SG"]))
    major, minor = bpy.app.version[:2]
    older = (major, minor - 1) if minor else (major - 1, 5)
    monkeypatch.setattr(open_blend, "running_line", lambda: older)
    rc, err = _bake(capsys, shot, tmp_path / "n.png")
    assert rc == 0, err
    assert (f"surfgrad: warning: library '//lib.blend' of .blend file {str(shot)!r} was saved "
            f"by Blender {major}.{minor}, newer than this Blender ({older[0]}.{older[1]})") in err
    # The library Blender could not read, named as the thing to fix (4.2's error text).
    reason = f"Failed to read blend file '{lib}', not a blend file"
    assert open_blend._unreadable_library(reason, shot) == str(lib)
    assert open_blend._unreadable_library(f"Failed to read blend file '{shot}'", shot) is None


@pytest.mark.tier("blender")
def test_harness_outputs_where_no_file_can_be_made_are_refused_before_any_work(tmp_path,
                                                                              capsys):
    """Before: `demo --out /proc/x`, `demo-blend`, `batch-assets` into such a place and
    `compare --json` below it ended in a raw FileNotFoundError / PermissionError traceback
    (exit 1; bench-reference and bench-compare still running after 120 s), and so did a
    `compare --json` or `bench-reference --out` name too long (OSError, File name too long;
    bench-reference after its work); `compare-all --out`
    a dangling symbolic link said "[Errno 17] File exists: 'dang'" (exit 2, no fix). Now each
    is refused at once, exit 2, naming the place and the fix, and nothing is made."""
    from surfgrad_addon.harness.cli import main
    gone = tmp_path / "unmounted"
    (tmp_path / "dang").symlink_to(gone)
    system = Path("/proc") / f"surfgrad-{os.getpid()}"
    cases = [
        (["compare-all", "--out", tmp_path / "dang"], "is a symbolic link to"),
        (["compare-all", "--out", tmp_path / "dang" / "sub"], "is a symbolic link to"),
        (["demo", "--no-bake", "--out", system], "'/proc' is not writable"),
        (["demo-blend", "--out", system / "d.blend"], "'/proc' is not writable"),
        (["batch-assets", "--out", system, "--count", "1"], "'/proc' is not writable"),
        (["bench-reference", "--out", tmp_path / "dang" / "r.json"], "is a symbolic link to"),
        (["compare", "--object", "Sphere", "--method", "normal-map", "--resolution", "8",
          "--json", system / "r.json"], "'/proc' is not writable"),
        (["compare", "--object", "Sphere", "--method", "normal-map", "--resolution", "8",
          "--json", tmp_path / "dang" / "r.json"], "is a symbolic link to"),
        (["compare", "--object", "Sphere", "--method", "normal-map", "--resolution", "8",
          "--json", tmp_path / f"{'x' * 300}.json"], "(File name too long)"),
        (["bench-reference", "--out", tmp_path / f"{'x' * 300}.json"], "(File name too long)")]
    for args, said in cases:
        capsys.readouterr()
        rc = main([str(a) for a in args])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAD_REQUEST, (args, err)
        assert err.startswith("surfgrad: error: ") and said in err, (args, err)
        assert ("pick a folder you can write to" in err) or \
            ("mount or create it, or give another folder" in err) or \
            ("give a shorter name (most file systems take 255 bytes a name" in err), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dang"] and not gone.exists()
    assert not system.exists()
    # A folder output that exists and takes files is still taken (the check made nothing).
    assert main(["batch-assets", "--out", str(tmp_path / "a"), "--count", "1"]) == 0
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["asset_000.blend"]


@pytest.mark.tier("child")
def test_a_batch_stopped_while_it_reads_its_files_says_what_is_left(tmp_path):
    """SIGTERM (a farm's cancel) while the workers still read the files: before, the last
    lines said "stopped 1 worker process(es); 0 asset(s) not baked", as if nothing were left.
    Now they count the files not read; no map, no lock, no worker is left, and a rerun bakes
    every asset. Red team 36a: the stop also wrote a manifest with no assets into the folders
    the run made (maps/set); with no file read it now writes none and removes them."""
    import signal
    import subprocess
    import sys
    import time
    from support.child import ROOT
    from test_faults_interrupt import alive, descendants
    from surfgrad_addon.addon.batch import MANIFEST_NAME
    blends = [str(BA.write_asset(tmp_path / "in" / f"a{i}.blend", (f"R{i}",), tiles=(1001,),
                                 image_size=16, seed=i)) for i in range(2)]
    maps = tmp_path / "maps" / "set"
    args = [sys.executable, "-m", "surfgrad_addon", "bake-batch", *blends, "--output",
            str(maps / "{object}.png"), "--resolution", "16"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(args + ["--workers", "1"], cwd=str(tmp_path), env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = set()
    for line in proc.stdout:                    # the worker starts (seconds) after this line
        if " to scan; " in line:
            break
    time.sleep(0.3)
    seen |= descendants(proc.pid)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-2:] == [
        f"[batch] SIGTERM: stopped 1 worker process(es); 0 asset(s) not baked, 2 file(s) not "
        f"read yet (a rerun reads and bakes them); nothing was recorded (no manifest "
        f"written)",
        "surfgrad: interrupted by SIGTERM: stopped the batch; exit code 143"], err
    assert list(tmp_path.iterdir()) == [tmp_path / "in"]          # no maps/set, no manifest
    assert seen and alive(seen) == []
    assert commands.execute(args[3:] + ["--workers", "0"]) == 0       # the rerun, here
    assert sorted(p.name for p in maps.iterdir()) == sorted([MANIFEST_NAME, "R0.png",
                                                             "R1.png"])


@pytest.mark.tier("blender")
def test_a_working_folder_removed_under_the_command_is_one_line(tmp_path, capsys):
    """A shell (or a farm task) left in a folder removed since, and a relative path: before,
    bake-normal-map ended in a raw FileNotFoundError from os.path.realpath and compare-all in
    one from os.path.abspath, exit 1. Now both say so in one line, exit 2, and write nothing."""
    from surfgrad_addon.harness.cli import main
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    gone = tmp_path / "gone"
    gone.mkdir()
    here = os.getcwd()
    os.chdir(gone)
    try:
        gone.rmdir()
        capsys.readouterr()
        codes = [commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                                   "--output", "n.png", "--resolution", "16"]),
                 main(["compare-all", "--out", "c", "--resolution", "8"])]
    finally:
        os.chdir(here)
    err = capsys.readouterr().err
    assert codes == [exit_codes.BAD_REQUEST] * 2, err
    assert err.splitlines() == ["surfgrad: error: the current folder no longer exists (removed "
                                "after this shell or task entered it): cd to a folder that "
                                "exists and run the command again"] * 2, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend"]


@pytest.mark.tier("blender")
def test_a_dangling_manifest_link_and_a_loop_of_links_are_named(tmp_path, capsys):
    """Before: `--manifest` a symbolic link to a share not mounted (a dangling link) was read
    as no manifest and replaced by a new file, exit 0: the link to the share's manifest was
    gone. An output folder that is a loop of links (a -> b -> a) was told to "give a shorter
    folder path" (ELOOP taken as a name too long). Now both are refused, exit 2, with the fix,
    and nothing is made."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    share = tmp_path / "share" / "m.json"
    (tmp_path / "m.json").symlink_to(share)
    (tmp_path / "loop_a").symlink_to(tmp_path / "loop_b")
    (tmp_path / "loop_b").symlink_to(tmp_path / "loop_a")

    def batch(output, *more):
        capsys.readouterr()
        rc = commands.execute(["bake-batch", str(blend), "--output", str(output),
                               "--resolution", "16", "--workers", "0", *more])
        return rc, capsys.readouterr().err.strip().splitlines()[-1]
    rc, line = batch(tmp_path / "maps" / "{object}.png", "--manifest", str(tmp_path / "m.json"))
    assert rc == exit_codes.BAD_REQUEST and line == (
        f"surfgrad: error: manifest {tmp_path / 'm.json'}: is a symbolic link to {str(share)!r}, "
        f"which does not exist (an unmounted share or a moved file?): mount or restore it, or "
        f"give another --manifest"), line
    assert (tmp_path / "m.json").is_symlink()
    rc, line = batch(tmp_path / "loop_a" / "{object}.png")
    assert rc == exit_codes.BAD_REQUEST and \
        f"output folder {str(tmp_path / 'loop_a')!r} cannot be used (a loop of symbolic " \
        f"links: " in line and line.endswith("fix the links, or give another folder"), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend", "loop_a", "loop_b",
                                                          "m.json"]


@pytest.mark.tier("blender")
def test_udim_twice_in_an_output_name_is_refused_before_baking(tmp_path, capsys):
    """Before: `--output out/n_<UDIM>_<UDIM>.png` on a two-tile asset baked, Blender put the
    tile number in the first token only (temporary files .n_1001_7.partPID.png and
    .n_1002_510550075.partPID.png), the bake failed "Blender wrote no file", exit 1, and both
    temporary files stayed in the folder; bake-batch failed the asset the same way. Now
    refused before anything runs, exit 2, and the folder stays empty."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001, 1002), image_size=16)
    out = tmp_path / "out"
    out.mkdir()
    said = "has <UDIM> 2 times: Blender puts the tile number in the first only; put <UDIM> " \
           "in the file name once"
    for args in (["bake-normal-map", "--blend", str(blend), "--object", "Rock", "--output",
                  str(out / "n_<UDIM>_<UDIM>.png")],
                 ["bake-batch", str(blend), "--output", str(out / "{object}_<UDIM>_<UDIM>.png"),
                  "--workers", "0"]):
        capsys.readouterr()
        rc = commands.execute(args + ["--resolution", "16"])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAD_REQUEST and said in err.strip().splitlines()[-1], err
    assert list(out.iterdir()) == []


@pytest.mark.tier("blender")
def test_an_output_ending_in_a_slash_is_a_folder_not_a_file(tmp_path, capsys):
    """Before: `--output out/t.png/` (a folder meant, not there yet) baked into the file
    out/t.png, exit 0: Path() drops the trailing '/', so the check for it never fired. Now
    refused, exit 2, nothing written."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    out = tmp_path / "out"
    out.mkdir()
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", f"{out}/t.png/", "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST and err.strip().splitlines()[-1] == \
        f"surfgrad: error: output '{out}/t.png/' is a folder: give a file name in it", err
    assert list(out.iterdir()) == []
