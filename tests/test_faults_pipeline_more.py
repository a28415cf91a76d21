"""Fault injection, red team 29b: what a pipeline meets beyond the scene. Image files the
check only looked for (a damaged UDIM tile past the first, an image sequence's frame file, a
movie Blender cannot decode) baked Cycles' magenta with exit code 0; a full disk or a
file-size limit cut the map's file short and the cut-off file was published with exit code 0;
a damaged or edited batch manifest was taken as none (and replaced) or stopped the batch with
a traceback; a batch killed with SIGKILL left its worker baking to the end of its bake."""

import hashlib
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.batch import MANIFEST_NAME  # noqa: E402
from support.child import ROOT  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _write_png(path, size=16):
    """A tangent-space normal map with a tilt that varies over the texels."""
    y, x = np.mgrid[0:size, 0:size] / size
    nx, ny = 0.4 * np.sin(2 * np.pi * x), 0.4 * np.cos(2 * np.pi * y)
    rgba = np.stack([nx, ny, np.sqrt(1 - nx * nx - ny * ny), np.ones_like(nx)], -1)
    rgba[..., :3] = rgba[..., :3] * 0.5 + 0.5
    img = bpy.data.images.new("tmp_png", size, size)
    img.pixels.foreach_set(rgba.astype(np.float32).ravel())
    img.filepath_raw, img.file_format = str(path), "PNG"
    img.save()
    bpy.data.images.remove(img)


def _scene(blend, image_path, source="FILE", second_tile=False):
    """`blend`: object Plane (2 x 2 quads, UVs in tile 1001, or the right half moved to 1002)
    whose material reads `image_path` (source `source`) through a Normal Map node."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    verts = [(x / 2, y / 2, 0.0) for y in range(3) for x in range(3)]
    faces = [(y * 3 + x, y * 3 + x + 1, y * 3 + x + 4, y * 3 + x + 3)
             for y in range(2) for x in range(2)]
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata(verts, [], faces)
    uv = np.asarray([(verts[i][0], verts[i][1]) for f in faces for i in f], np.float32)
    if second_tile:
        uv[4:8, 0] += 1.0                           # the second face into tile 1002
    mesh.uv_layers.new(name="UVMap").data.foreach_set("uv", uv.ravel())
    obj = bpy.data.objects.new("Plane", mesh)
    bpy.context.scene.collection.objects.link(obj)
    mat, tree, bsdf = diffuse_material("Mat")
    node = tree.nodes.new("ShaderNodeTexImage")
    image = bpy.data.images.load(str(image_path), check_existing=False)
    image.source = source
    if source == "TILED":
        image.filepath = str(image_path).replace(".1001.", ".<UDIM>.")
        image.tiles.new(1002)
    image.colorspace_settings.name = "Non-Color"
    node.image = image
    nm = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(node.outputs["Color"], nm.inputs["Color"])
    tree.links.new(nm.outputs["Normal"], bsdf.inputs["Normal"])
    obj.data.materials.append(mat)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    return blend


def _damaged(kind, tmp_path):
    """(blend, the damaged file, output) for a file the image reads beyond its first."""
    tex = tmp_path / "tex"
    tex.mkdir()
    if kind == "udim_tile":                          # tile 1002's file cut in half
        for t in (1001, 1002):
            _write_png(tex / f"n.{t}.png")
        blend = _scene(tmp_path / "s.blend", tex / "n.1001.png", "TILED", second_tile=True)
        bad = tex / "n.1002.png"
        bad.write_bytes(bad.read_bytes()[:bad.stat().st_size // 2])
        return blend, bad, tmp_path / "out" / "map.<UDIM>.png"
    if kind == "sequence_frame":                     # the current frame's file is text
        for f in (1, 2, 3):
            _write_png(tex / f"seq.{f:04d}.png")
        blend = _scene(tmp_path / "s.blend", tex / "seq.0001.png", "SEQUENCE")
        bad = tex / "seq.0001.png"
    else:                                            # "movie": a file no decoder opens
        bad = tex / "clip.mp4"
        bad.write_text("not a movie\n")
        blend = _scene(tmp_path / "s.blend", bad, "MOVIE")
    bad.write_text("not an image\n")
    return blend, bad, tmp_path / "out" / "map.png"


@pytest.mark.parametrize("kind", ["udim_tile", "sequence_frame", "movie"])
def test_a_damaged_tile_frame_or_movie_is_refused_before_baking(kind, tmp_path, capsys):
    """Before: exit 0 and a map of Cycles' magenta where the file is read (tile 1002 of the
    UDIM map, the whole map for the frame and the movie)."""
    blend, bad, output = _damaged(kind, tmp_path)
    output.parent.mkdir()
    before = _sha(blend)
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(output), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    line = err.strip().splitlines()[-1]
    assert line.startswith("surfgrad: error: ") and "magenta" in line, err
    if kind == "movie":
        assert "movie 'clip.mp4'" in line and "image sequence" in line
    else:
        assert repr(str(bad)) in line and "re-save it as PNG or EXR" in line
    assert list(output.parent.iterdir()) == []
    assert _sha(blend) == before


def test_damaged_sequence_and_tile_files_of_good_images_still_bake(tmp_path, capsys):
    """The same scenes with whole files bake (the probes load them and free them again)."""
    tex = tmp_path / "tex"
    tex.mkdir()
    for t in (1001, 1002):
        _write_png(tex / f"n.{t}.png")
    blend = _scene(tmp_path / "s.blend", tex / "n.1001.png", "TILED", second_tile=True)
    out = tmp_path / "out"
    out.mkdir()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out / "map.<UDIM>.png"), "--resolution", "16"])
    assert rc == exit_codes.OK, capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["map.1001.png", "map.1002.png"]
    assert [i.name for i in bpy.data.images] == ["n.1001.png"]      # no probe left behind


def _run_with_file_limit(limit, args):
    """`python -m surfgrad_addon ARGS` where no file may grow past `limit` bytes
    (RLIMIT_FSIZE: Python ignores SIGXFSZ, so a write past it fails as on a full disk)."""
    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    return subprocess.run([sys.executable, "-m", "surfgrad_addon", *map(str, args)],
                          cwd=str(ROOT), env=env, capture_output=True, text=True, timeout=300,
                          preexec_fn=small_files)


def _warm_kernel_cache(args):
    """Run the command once without a limit: numba's kernel cache (beside the checkout) is
    then written, and the limited run's only large files are the command's own outputs."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    run = subprocess.run([sys.executable, "-m", "surfgrad_addon", *map(str, args)],
                         cwd=str(ROOT), env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]


@pytest.mark.tier("child")
def test_a_map_cut_short_by_a_file_size_limit_is_not_published(tmp_path):
    """A full disk, simulated with a file-size limit (RLIMIT_FSIZE; Python ignores SIGXFSZ,
    so the write fails as on a full disk). Before: exit 0 and a cut-off PNG as the map."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "s.blend", tmp_path / "n.png")
    out = tmp_path / "out"
    out.mkdir()
    run = _run_with_file_limit(8192, [             # a 256^2 map of this scene: ~25 kB
        "bake-normal-map", "--blend", blend, "--object", "Plane", "--output", out / "map.png",
        "--resolution", "256"])
    assert run.returncode == exit_codes.BAKE_FAILED, run.stderr[-2000:]
    line = run.stderr.strip().splitlines()[-1]
    assert line.startswith("surfgrad: error: ") and "map.png" in line and \
        "disk is full" in line, run.stderr[-2000:]
    assert "Traceback" not in run.stderr
    assert list(out.iterdir()) == []                # neither the map nor its temporary


@pytest.mark.tier("child")
def test_an_exr_blender_cannot_write_is_one_line_naming_the_map(tmp_path):
    """Before: Blender's two lines ('Could not write image: Invalid argument', then the
    temporary file's name), saying neither the map nor the fix."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "s.blend", tmp_path / "n.png")
    out = tmp_path / "out"
    out.mkdir()
    run = _run_with_file_limit(8192, ["bake-normal-map", "--blend", blend, "--object",
                                      "Plane", "--output", out / "map.exr", "--resolution",
                                      "256"])
    assert run.returncode == exit_codes.BAKE_FAILED, run.stderr[-2000:]
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("surfgrad: error: ") and repr(str(out / "map.exr")) in last and \
        "the disk may be full" in last, run.stderr[-2000:]
    assert list(out.iterdir()) == []


@pytest.mark.tier("child")
def test_a_manifest_the_disk_cannot_take_is_one_line_and_leaves_no_temporary(tmp_path):
    """The maps fit, the manifest does not (a 2 kB limit: a 16^2 map is under 1 kB, the
    manifest over 2 kB). Before: a traceback (OSError: File too large) and the manifest's
    cut-off temporary file left beside the maps."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "maps"
    run = _run_with_file_limit(2048, ["bake-batch", blend, "--output",
                                      out / "{file}_{object}.png", "--resolution", "16",
                                      "--workers", "0"])
    assert run.returncode == exit_codes.BAKE_FAILED, run.stderr[-2000:]
    assert "Traceback" not in run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith(f"surfgrad: error: manifest {out / MANIFEST_NAME} could not be "
                           f"written") and "ulimit -f" in last, run.stderr[-2000:]
    # An earlier, smaller write (after the scan) stays whole; no temporary, no lock file.
    assert sorted(p.name for p in out.iterdir()) == ["a_Plane.png", MANIFEST_NAME]
    assert json.loads((out / MANIFEST_NAME).read_text())["files"]


def _damage_truncated(text):
    return text[:len(text) // 2]


def _damage_asset_entry(text):
    data = json.loads(text)
    data["assets"][next(iter(data["assets"]))] = 5
    return json.dumps(data)


def _damage_files_list(text):
    data = json.loads(text)
    data["files"] = []
    return json.dumps(data)


def _damage_written_record(text):
    data = json.loads(text)
    next(iter(data["assets"].values()))["files"] = {"1001": "map.png"}
    return json.dumps(data)


def _foreign_json(text):
    return json.dumps({"name": "the studio's own settings"})


@pytest.mark.parametrize("damage, said", [
    (_damage_truncated, "is damaged (not valid JSON"),
    (_damage_asset_entry, "is not a table"),
    (_damage_files_list, "\"files\" is not a table"),
    (_damage_written_record, "is not a table of {path, sha256} records"),
    (_foreign_json, "is not a surfgrad manifest"),
])
def test_a_damaged_or_edited_manifest_is_refused_and_kept(damage, said, tmp_path, capsys):
    """Before: a damaged (or foreign) file was taken as no manifest and replaced, and the
    run failed every asset with 'exists; pass --overwrite'; an edited one stopped the batch
    with a traceback (AttributeError). Now: exit 2 before anything is scanned, naming the
    manifest and the fix; the manifest and the maps are left as they were."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "maps"
    args = ["bake-batch", str(blend), "--output", str(out / "{file}_{object}.png"),
            "--resolution", "16", "--workers", "0"]
    assert commands.execute(args) == exit_codes.OK, capsys.readouterr().err
    capsys.readouterr()
    manifest = out / MANIFEST_NAME
    manifest.write_text(damage(manifest.read_text()))
    kept = {p.name: _sha(p) for p in out.iterdir()}
    rc = commands.execute(args)
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    line = err.strip().splitlines()[-1]
    assert line.startswith(f"surfgrad: error: manifest {manifest} ") and said in line, err
    assert "Traceback" not in err
    assert {p.name: _sha(p) for p in out.iterdir()} == kept


def _children(pid):
    """Process ids whose parent is `pid` (Linux /proc)."""
    out = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid:
            out.add(int(stat.parent.name))
    return out


def _alive(pids):
    out = []
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            out.append(pid)
    return out


@pytest.mark.tier("child")
@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="reads /proc")
def test_a_batch_killed_with_sigkill_takes_its_workers_with_it(tmp_path):
    """A farm's hard kill (or the OOM killer) of the batch: its workers, each in a process
    group of its own, went on baking to the end of the bake (~25 s here) and burnt the
    node's CPUs. Now each notices its parent gone and stops as on SIGTERM: within seconds,
    no map or temporary file left, and a rerun bakes the asset."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "maps"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(ROOT), TMPDIR=str(tmp_path))
    args = [sys.executable, "-m", "surfgrad_addon", "bake-batch", str(blend), "--output",
            str(out / "{file}_{object}.png"), "--workers", "1"]
    proc = subprocess.Popen(args + ["--resolution", "1024", "--samples", "64"], cwd=str(ROOT),
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    manifest = out / MANIFEST_NAME
    workers, t0 = set(), time.monotonic()
    try:
        while time.monotonic() - t0 < 120:          # scanned (manifest written), baking
            workers |= _children(proc.pid)
            if workers and manifest.is_file() and json.loads(manifest.read_text())["files"]:
                break
            assert proc.poll() is None
            time.sleep(0.1)
        time.sleep(2.0)
        proc.kill()
        proc.wait(10)
        t1 = time.monotonic()
        while _alive(workers) and time.monotonic() - t1 < 10:
            time.sleep(0.1)
        left = _alive(workers)
    finally:
        for pid in _alive(workers):
            os.kill(pid, signal.SIGKILL)
    assert workers and left == [], f"workers still baking 10 s after the batch died: {left}"
    # Nor the worker's temp folder (red team 30b: it was left empty; the killed batch's own
    # blender_* session folder stays, nobody can remove it).
    assert not list(tmp_path.glob("surfgrad-worker-*"))
    # No map, no temporary; the killed run's lock file stays (the system dropped its lock).
    lock = f".{MANIFEST_NAME}.lock"
    assert sorted(p.name for p in out.iterdir()) == [lock, MANIFEST_NAME]
    rerun = subprocess.run(args + ["--resolution", "16"], cwd=str(ROOT), env=env,
                           capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    assert sorted(p.name for p in out.iterdir()) == ["a_Plane.png", MANIFEST_NAME]


@pytest.mark.tier("child")
def test_a_second_batch_on_the_same_manifest_is_refused_while_the_first_runs(tmp_path):
    """Two runs into one output folder (two artists, a farm task retried beside the one
    still running). Before: both baked; the one that wrote its manifest last dropped the
    other's records (one that failed every asset with 'exists' kept no record of the maps),
    and every later run failed those assets until --overwrite. Now the second is refused, exit
    2, naming the manifest; the first bakes on; after it ends the folder is free again."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "maps"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(ROOT))
    args = [sys.executable, "-m", "surfgrad_addon", "bake-batch", str(blend), "--output",
            str(out / "{file}_{object}.png"), "--workers", "0"]
    first = subprocess.Popen(args + ["--resolution", "1024", "--samples", "64"],
                             cwd=str(ROOT), env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
    manifest = out / MANIFEST_NAME
    try:
        t0 = time.monotonic()
        while not (manifest.is_file() and json.loads(manifest.read_text())["files"]):
            assert first.poll() is None and time.monotonic() - t0 < 120
            time.sleep(0.1)
        kept = manifest.read_bytes()
        second = subprocess.run(args + ["--resolution", "16"], cwd=str(ROOT), env=env,
                                capture_output=True, text=True, timeout=300)
        assert first.poll() is None, "the first run ended before the second was tried"
    finally:
        first.send_signal(signal.SIGTERM)
        first.communicate(timeout=60)
    assert second.returncode == exit_codes.BAD_REQUEST, second.stderr[-2000:]
    line = second.stderr.strip().splitlines()[-1]
    assert line.startswith(f"surfgrad: error: manifest {manifest} is in use by another "
                           f"bake-batch run"), second.stderr[-2000:]
    assert not (out / "a_Plane.png").exists() and kept     # the second baked nothing
    assert first.returncode == exit_codes.TERMINATED
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME]    # no lock file left
    third = subprocess.run(args + ["--resolution", "16"], cwd=str(ROOT), env=env,
                           capture_output=True, text=True, timeout=300)
    assert third.returncode == 0, third.stderr[-2000:]
    assert sorted(p.name for p in out.iterdir()) == ["a_Plane.png", MANIFEST_NAME]


def test_a_folder_given_as_the_blend_is_named_a_folder(tmp_path, capsys):
    """Before: '.blend file 'rock.blend' does not exist' for a folder named rock.blend."""
    folder = tmp_path / "rock.blend"
    folder.mkdir()
    rc = commands.execute(["bake-normal-map", "--blend", str(folder), "--object", "Rock",
                           "--output", str(tmp_path / "n.png")])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST
    assert err.strip().splitlines()[-1] == (f"surfgrad: error: .blend file {str(folder)!r} is "
                                            f"a folder: give a .blend file")


def test_an_asset_list_with_home_paths_duplicates_and_relative_paths(tmp_path, monkeypatch,
                                                                     capsys):
    """Before: `~/assets/a.blend` in a list was read as a folder named '~' beside the list
    ('.../~/assets/a.blend: no such file', exit 1); the shell expands it on the command line
    only. Duplicates and a relative path naming the same file bake it once."""
    home = tmp_path / "home"
    (home / "assets").mkdir(parents=True)
    _write_png(home / "assets" / "n.png")
    _scene(home / "assets" / "a.blend", home / "assets" / "n.png")
    monkeypatch.setenv("HOME", str(home))
    listed = home / "assets" / "list.txt"
    listed.write_text("~/assets/a.blend\n~/assets/a.blend:Plane\na.blend\n")
    out = tmp_path / "maps"
    rc = commands.execute(["bake-batch", "--asset-list", str(listed), "--output",
                           str(out / "{file}_{object}.png"), "--resolution", "16",
                           "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.OK, err
    assert sorted(p.name for p in out.iterdir()) == ["a_Plane.png", MANIFEST_NAME]
    assets = json.loads((out / MANIFEST_NAME).read_text())["assets"]
    assert list(assets) == [f"{home / 'assets' / 'a.blend'}:Plane"]


def test_a_folder_given_as_the_asset_list_is_named_a_folder(tmp_path, capsys):
    """Before: 'asset list DIR: no such file' for a folder that exists."""
    rc = commands.execute(["bake-batch", "--asset-list", str(tmp_path), "--output",
                           str(tmp_path / "maps" / "{file}_{object}.png")])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert err.strip().splitlines()[-1].startswith(
        f"surfgrad: error: asset list {tmp_path} is a folder: give the list's file")


@pytest.mark.parametrize("space, warned", [("sRGB", True), ("Non-Color", False)])
def test_an_srgb_normal_map_is_baked_with_a_warning(space, warned, tmp_path, capsys):
    """The most common artist slip: a normal map left in sRGB. Before: exit 0, not a word,
    and a map bent by up to 0.31 per channel from the Non-Color one. Now the same map (it is
    what Cycles renders) with a warning naming the image, the node and the fix."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "s.blend", tmp_path / "n.png")
    bpy.data.images["n.png"].colorspace_settings.name = space
    bpy.ops.wm.save_mainfile()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(tmp_path / "map.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.OK, err
    warning = (f"surfgrad: warning: image 'n.png' is read in colour space {space!r} by Normal "
               f"Map node 'Normal Map' (material 'Mat'): ")
    assert (warning in err) == warned, err
    if warned:
        assert "set the image's Color Space to Non-Color" in err
    assert (tmp_path / "map.png").is_file()


def test_an_srgb_map_into_sg_normal_map_is_warned_too(tmp_path, capsys):
    """Before: the sRGB warning looked at Normal Map nodes only, so the same slip into SG Normal
    Map (the extension's own group) baked without a word."""
    from surfgrad_addon.addon import groups as G
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "s.blend", tmp_path / "n.png")
    mat = bpy.data.materials["Mat"]
    tree = mat.node_tree
    nm = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeNormalMap")
    image_node = nm.inputs["Color"].links[0].from_node
    bsdf = nm.outputs["Normal"].links[0].to_node
    sg = tree.nodes.new("ShaderNodeGroup")
    sg.node_tree = G.normal_map_group()
    resolve = tree.nodes.new("ShaderNodeGroup")
    resolve.node_tree = G.resolve_group()
    tree.nodes.remove(nm)
    tree.links.new(image_node.outputs["Color"], sg.inputs["Color"])
    tree.links.new(sg.outputs[0], resolve.inputs["Surface Gradient"])
    tree.links.new(resolve.outputs["Normal"], bsdf.inputs["Normal"])
    bpy.data.images["n.png"].colorspace_settings.name = "sRGB"
    node_name = sg.name                     # the file is opened again by the command
    bpy.ops.wm.save_mainfile()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(tmp_path / "map.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.OK, err
    assert (f"surfgrad: warning: image 'n.png' is read in colour space 'sRGB' by SG Normal Map "
            f"node '{node_name}' (material 'Mat'): ") in err, err
    assert (tmp_path / "map.png").is_file()


def _linked_from_missing_library(tmp_path):
    """tmp_path/shot.blend links object Plane from lib.blend, which is then moved away."""
    _write_png(tmp_path / "n.png")
    lib = _scene(tmp_path / "lib.blend", tmp_path / "n.png")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with bpy.data.libraries.load(str(lib), link=True) as (_, into):
        into.objects = ["Plane"]
    bpy.context.scene.collection.objects.link(into.objects[0])
    shot = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(shot), compress=False)
    lib.rename(tmp_path / "lib_moved.blend")
    return shot, lib


def test_an_object_whose_library_is_missing_is_named_as_such(tmp_path, capsys):
    """Before: bake-normal-map said "object 'Plane' is a empty, not a mesh: pick a mesh
    object"; bake-batch of the whole file said it had no mesh object with a material, and of
    file:Plane that Plane is an empty. Now all three name the missing library and the fix."""
    shot, lib = _linked_from_missing_library(tmp_path)
    said = (f"object 'Plane' is linked from library '//lib.blend' ({lib}), which is missing, "
            f"so Blender left an empty placeholder: put the library file there or relink it")
    rc = commands.execute(["bake-normal-map", "--blend", str(shot), "--object", "Plane",
                           "--output", str(tmp_path / "map.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST and said in err.strip().splitlines()[-1], err
    for entry in (str(shot), f"{shot}:Plane"):
        rc = commands.execute(["bake-batch", entry, "--output",
                               str(tmp_path / "maps" / "{file}_{object}.png"),
                               "--resolution", "16", "--workers", "0"])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAKE_FAILED, err
        assert err.strip().splitlines()[-1] == f"surfgrad: error: shot.blend:Plane: {said} " \
            f"(File > External Data > Find Missing Files)", err
    assert not (tmp_path / "map.png").exists()


@pytest.mark.tier("child")
def test_ctrl_c_while_the_command_starts_is_one_line_and_exit_130(tmp_path):
    """Ctrl-C in the first half second (Python, numpy and bpy loading, before the command's
    own stop is in place). Before: a KeyboardInterrupt traceback from inside an import, and
    the process killed by SIGINT."""
    _write_png(tmp_path / "n.png")
    blend = _scene(tmp_path / "s.blend", tmp_path / "n.png")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    # Once through, so no module is compiled to bytecode while the signal comes.
    subprocess.run([sys.executable, "-m", "surfgrad_addon", "--help"], cwd=str(ROOT), env=env,
                   capture_output=True, timeout=120)
    # Ctrl-C as in a terminal: the child starts with SIGINT at its default, whatever this
    # process inherited (a shell's background job ignores SIGINT, and Python then keeps it
    # ignored: the command ran to the end with exit 0 when the tests ran under `cmd &`).
    proc = subprocess.Popen([sys.executable, "-m", "surfgrad_addon", "bake-normal-map",
                             "--blend", str(blend), "--object", "Plane", "--output",
                             str(tmp_path / "map.png")], cwd=str(ROOT), env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # Inside the imports (until about 0.3 s, when the command's own stop takes over), past
    # the interpreter's own start-up (a few hundredths), which no code of ours can cover.
    time.sleep(0.15)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == exit_codes.INTERRUPTED, err[-2000:]
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err[-2000:]
    assert err.strip().splitlines()[-1].startswith("surfgrad: interrupted by SIGINT: stopped")
    assert not (tmp_path / "map.png").exists()


@pytest.mark.tier("child")
def test_the_main_job_on_a_full_disk_is_one_line_and_leaves_its_folder(tmp_path):
    """`run.sh main` (demo) when its disk fills (a file-size limit here). Before: a numpy
    traceback ('OSError: 12288 requested and 10208 written'), naming no folder and no fix.
    The folder keeps what it held; no hidden working folder is left."""
    _warm_kernel_cache(["demo", "--out", tmp_path / "warm", "--no-bake", "--resolution", "64"])
    shutil.rmtree(tmp_path / "warm")
    out = tmp_path / "demo"
    out.mkdir()
    (out / "summary.md").write_text("the last complete run\n")
    run = _run_with_file_limit(8192, ["demo", "--out", out, "--overwrite", "--no-bake",
                                      "--resolution", "64"])
    assert run.returncode == exit_codes.BAKE_FAILED, run.stderr[-2000:]
    assert "Traceback" not in run.stderr, run.stderr[-2000:]
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith(f"surfgrad: error: the run could not write its files for "
                           f"{str(out)!r}") and "free space" in last, last
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]
    assert [p.name for p in out.iterdir()] == ["summary.md"]
    assert (out / "summary.md").read_text() == "the last complete run\n"


@pytest.mark.tier("child")
def test_compare_on_a_full_disk_leaves_no_cut_off_report(tmp_path):
    """Before: a PIL traceback, exit 1, and a cut-off heat map (and the JSON) left where
    the report goes. A file-size limit between the two files' sizes (the warm-up run's): the
    JSON (~1 kB) fits, the heat map does not. (A fixed 2 kB stopped holding once the reference
    took Blender's scan weights: the heat map of a near-zero error compresses to 2035 bytes.)"""
    args = ["compare", "--object", "Torus", "--method", "normal-map", "--resolution", "64"]
    _warm_kernel_cache(args + ["--json", tmp_path / "warm" / "torus.json"])
    json_size = (tmp_path / "warm" / "torus.json").stat().st_size
    heat_size = (tmp_path / "warm" / "torus_error.png").stat().st_size
    assert json_size + 256 < heat_size, (json_size, heat_size)     # the premise
    out = tmp_path / "report" / "torus.json"
    run = _run_with_file_limit((json_size + heat_size) // 2, [
        "compare", "--object", "Torus", "--method", "normal-map", "--resolution", "64",
        "--json", out])
    assert run.returncode == exit_codes.BAKE_FAILED, run.stderr[-2000:]
    assert "Traceback" not in run.stderr, run.stderr[-2000:]
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith(f"surfgrad: error: could not write {str(out)!r} and its heat map") \
        and "free space" in last, last
    assert sorted(p.name for p in tmp_path.iterdir()) == ["warm"]   # nor the folder made


@pytest.mark.skipif(sys.platform == "win32", reason="no fcntl: the lock is a no-op there")
def test_the_lock_taken_is_the_one_at_the_path_when_the_holder_lets_go_meanwhile(
        tmp_path, monkeypatch):
    """The run that held a manifest removes its lock file as it lets go. A run that opened
    that file just before, and locks it just after, holds a lock on a removed file, and a
    third run would lock the new one beside it: two runs on one manifest. hold() takes the
    lock at the path."""
    import fcntl
    from surfgrad_addon.addon.batch import manifest as M
    path = tmp_path / "maps" / MANIFEST_NAME
    path.parent.mkdir()
    lock = path.with_name(f".{path.name}.lock")
    lock.write_text("")
    real_flock, calls = fcntl.flock, []

    def holder_lets_go_first(fd, op):
        if not calls:                       # the other run removes its lock file now
            lock.unlink()
            lock.write_text("")
        calls.append(op)
        return real_flock(fd, op)
    monkeypatch.setattr(fcntl, "flock", holder_lets_go_first)
    try:
        M.hold(path)
        fd = M._HELD[path][0]
        assert os.fstat(fd).st_ino == os.stat(lock).st_ino
        assert len(calls) == 2              # the first lock held a removed file
    finally:
        M.release(path)
    assert not lock.exists()
