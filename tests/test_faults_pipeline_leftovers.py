"""Fault injection, red team 30b: what red team 29b left. A batch killed with SIGKILL left
each worker's empty surfgrad-worker-* folder in $TMPDIR; a map the disk cut short was baked a
second time in a fresh process; a grey, grey+alpha or -1..1 float image feeding a Normal Map
baked without a word."""

import json
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.batch import MANIFEST_NAME  # noqa: E402
from support.child import ROOT  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("bake")

# A batch's pool in miniature: start one worker, wait until it is ready (idle, reading its
# input), say where its folders are, and wait to be killed.
IDLE_PARENT = (
    "import sys, time\n"
    "from surfgrad_addon.addon.batch import workers\n"
    "from surfgrad_addon.addon.batch.worker_main import RESULT_MARK\n"
    "w = workers.Worker(workers.worker_command())\n"
    "while '\"ready\"' not in (line := w.lines.get(timeout=120)):\n"
    "    pass\n"
    "print(w.proc.pid, w.tempdir, flush=True)\n"
    "time.sleep(600)\n")


def _gone(pid, within_s):
    t0 = time.monotonic()
    while time.monotonic() - t0 < within_s:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return True
        if state == "Z":
            return True
        time.sleep(0.1)
    return False


@pytest.mark.tier("child")
@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="reads /proc")
def test_an_idle_worker_whose_batch_was_killed_removes_its_temp_folder(tmp_path):
    """The batch SIGKILLed while its worker waits for work: the worker's input ends and it
    exits. Before: its empty surfgrad-worker-* folder stayed in $TMPDIR (the batch removes it
    only once the worker has ended, and a killed batch never does). A folder the worker was not
    given stays."""
    temp = tmp_path / "tmp"
    temp.mkdir()
    (temp / "surfgrad-worker-not-mine").mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(ROOT), TMPDIR=str(temp))
    parent = subprocess.Popen([sys.executable, "-c", IDLE_PARENT], cwd=str(ROOT), env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    worker = None
    try:
        pid, folder = parent.stdout.readline().split()
        worker = int(pid)
        assert Path(folder).parent == temp and Path(folder).is_dir()
        assert any(p.name.startswith("blender_") for p in Path(folder).iterdir())
        parent.kill()
        parent.wait(10)
        assert _gone(worker, 10), "the worker outlived its batch by 10 s"
    finally:
        parent.kill()
        if worker is not None and not _gone(worker, 0.1):
            os.kill(worker, signal.SIGKILL)
    left = sorted(p.name for p in temp.iterdir())
    assert [n for n in left if n.startswith("surfgrad-worker-")] == \
        ["surfgrad-worker-not-mine"], left


def _normal_texels(size=16):
    """A tangent-space normal map, encoded 0..1, whose tilt varies over the texels (RGBA)."""
    y, x = np.mgrid[0:size, 0:size] / size
    nx, ny = 0.4 * np.sin(2 * np.pi * x), 0.4 * np.cos(2 * np.pi * y)
    rgba = np.stack([nx, ny, np.sqrt(1 - nx * nx - ny * ny), np.ones_like(nx)], -1)
    rgba[..., :3] = rgba[..., :3] * 0.5 + 0.5
    return rgba


def _write_image(path, rgba, file_format="PNG", float_buffer=False, **settings):
    """Write `rgba` (H, W, 4) to `path` with Blender's writer; settings: the image's
    file-format options (color_mode, color_depth) through a scene's image settings."""
    h, w = rgba.shape[:2]
    img = bpy.data.images.new("tmp_img", w, h, float_buffer=float_buffer)
    img.pixels.foreach_set(rgba.astype(np.float32).ravel())
    scene = bpy.context.scene
    s = scene.render.image_settings
    s.file_format = file_format
    s.color_mode = settings.get("color_mode", "RGBA")
    if "color_depth" in settings:
        s.color_depth = settings["color_depth"]
    img.save_render(str(path), scene=scene)
    bpy.data.images.remove(img)


def _scene(blend, image_path, via="ShaderNodeNormalMap", space="Non-Color", pack=False):
    """`blend`: object Plane (one quad filling the 0-1 UV square) whose material reads
    `image_path` (colour space `space`; packed into the .blend if `pack`) into the Color
    input of node `via`: a node type, or a surfgrad group's name (through SG Resolve)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=1.0)      # one quad, UVs filling 0-1 ("UVMap")
    obj = bpy.context.object
    mat, tree, bsdf = diffuse_material("Mat")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(image_path), check_existing=False)
    tex.image.colorspace_settings.name = space
    if pack:
        tex.image.pack()
    if via.startswith("SG "):
        nm = tree.nodes.new("ShaderNodeGroup")
        nm.node_tree = api.node_group(via)
        resolve = tree.nodes.new("ShaderNodeGroup")
        resolve.node_tree = api.node_group("SG Resolve")
        tree.links.new(nm.outputs["Surface Gradient"], resolve.inputs["Surface Gradient"])
        tree.links.new(resolve.outputs["Normal"], bsdf.inputs["Normal"])
    else:
        nm = tree.nodes.new(via)
        tree.links.new(nm.outputs["Normal"], bsdf.inputs["Normal"])
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(tex.outputs["Color"], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], nm.inputs["Color"])
    obj.data.materials.append(mat)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    return blend


@pytest.mark.tier("child")
@pytest.mark.parametrize("workers", ["0", "1"])
def test_a_batch_map_the_disk_cuts_short_fails_at_once_without_a_retry(workers, tmp_path):
    """A full disk (a file-size limit: 8 kB, a 256^2 map is ~25 kB, the manifest fits).
    Before: '... is incomplete ... - retrying once in a fresh process', the bake done twice
    and failed the same way. Now the asset fails at its first attempt with the same line
    bake-normal-map prints, and nothing but the manifest is left."""
    _write_image(tmp_path / "n.png", _normal_texels())
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "maps"

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (8192, 8192))

    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    run = subprocess.run([sys.executable, "-m", "surfgrad_addon", "bake-batch", str(blend),
                          "--output", str(out / "{file}_{object}.png"), "--resolution", "256",
                          "--workers", workers], cwd=str(ROOT), env=env, capture_output=True,
                         text=True, timeout=300, preexec_fn=small_files)
    assert run.returncode == exit_codes.BAKE_FAILED, run.stderr[-3000:]
    text = run.stdout + run.stderr
    assert "retrying" not in text and "Traceback" not in text, text[-3000:]
    entry = json.loads((out / MANIFEST_NAME).read_text())["assets"][f"{blend}:Plane"]
    assert entry["status"] == "failed" and entry["kind"] == "output"
    assert len(entry["attempts"]) == 1
    said = (f"the bake of 'Plane' failed: the file written for {str(out / 'a_Plane.png')!r} "
            f"is incomplete (cut off after ")
    assert entry["error"].startswith(said), entry["error"]
    assert "the disk is full or a file-size limit (ulimit -f) was hit" in entry["error"]
    assert f"a.blend:Plane: {said}" in run.stderr, run.stderr[-3000:]
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME]


def _grey_png(path, mode):
    """The normal map's R as a PNG of colour type grey ('L') or grey and alpha ('LA'), as
    Pillow writes them (Blender's writer makes no grey+alpha PNG); 'RGB': the same grey in
    three channels, what Blender makes of the others once loaded."""
    from PIL import Image
    grey = np.round(_normal_texels()[::-1, :, 0] * 255).astype(np.uint8)
    planes = {"L": [grey], "LA": [grey, np.full_like(grey, 255)], "RGB": [grey] * 3}[mode]
    Image.fromarray(np.dstack(planes) if len(planes) > 1 else grey, mode).save(path)


def _bake(blend, output, capsys):
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(output), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.OK, err
    return err


@pytest.mark.parametrize("mode, via, pack", [
    ("L", "ShaderNodeNormalMap", False), ("LA", "ShaderNodeNormalMap", False),
    ("L", "SG Normal Map", False), ("LA", "SG Tangent Normal", True)])
def test_a_grey_normal_map_is_baked_as_rendered_with_a_warning(mode, via, pack, tmp_path,
                                                               capsys):
    """A grey (1 channel) or grey+alpha (2) PNG as the normal map. Before: exit 0, not a word,
    every normal leaning along (1, 1). Now the same map (what Cycles renders: the map of an RGB
    file holding the grey thrice, texel for texel) with a warning naming the image, the node,
    what the file holds and the fix; packed images are read from their packed data."""
    _grey_png(tmp_path / "grey.png", mode)
    _grey_png(tmp_path / "rgb.png", "RGB")
    kind = "Normal Map" if via == "ShaderNodeNormalMap" else via
    name = "Normal Map" if via == "ShaderNodeNormalMap" else "Group"      # Blender's names
    err = _bake(_scene(tmp_path / "g.blend", tmp_path / "grey.png", via, pack=pack),
                tmp_path / "grey_map.png", capsys)
    channels, what = {"L": (1, "1 channel"), "LA": (2, "2 channels")}[mode]
    where = "packed" if pack else "grey.png"
    said = {"L": "grey PNG", "LA": "grey and alpha PNG"}[mode]
    assert (f"surfgrad: warning: image 'grey.png', read by {kind} node '{name}' (material "
            f"'Mat'), holds {what} in its file ({where}: {said}): Blender spreads the grey "
            f"over R, G and B") in err, err
    assert "save the normal map as RGB (three channels)" in err
    rgb = _bake(_scene(tmp_path / "c.blend", tmp_path / "rgb.png", via, pack=pack),
                tmp_path / "rgb_map.png", capsys)
    # (the RGB file holds three channels: no channel warning; its grey blue is warned of by
    # its pixels, normal_map_checks.blue_problem, as for any such map)
    assert "in its file (" not in rgb and "blue at or below 0.5" in rgb, rgb
    assert (tmp_path / "grey_map.png").read_bytes() == (tmp_path / "rgb_map.png").read_bytes()


def test_a_grey_jpeg_is_warned_and_an_unread_format_is_not(tmp_path, capsys):
    """A grey JPEG: its frame header says 1 component (past an APP segment). A grey TIFF: a
    header not read here, so no word of its channels (never a guess); its pixels' grey blue
    is warned of as any map's (round 59)."""
    from PIL import Image
    grey = np.round(_normal_texels()[:, :, 0] * 255).astype(np.uint8)
    Image.fromarray(grey, "L").save(tmp_path / "g.jpg", quality=95, dpi=(72, 72))
    err = _bake(_scene(tmp_path / "j.blend", tmp_path / "g.jpg"), tmp_path / "j.png", capsys)
    assert "holds 1 channel in its file (g.jpg: grey JPEG)" in err, err
    Image.fromarray(grey, "L").save(tmp_path / "g.tif")
    err = _bake(_scene(tmp_path / "t.blend", tmp_path / "g.tif"), tmp_path / "t.png", capsys)
    # No channel count claimed; its grey blue is warned of by its pixels (blue_problem).
    assert "in its file (" not in err and "blue at or below 0.5" in err, err


def _exr_of_channels(path, planes, sampling=None):
    """An uncompressed single-part half EXR holding exactly `planes` ({name: (H, W) array},
    row 0 at v = 0), written by hand from the OpenEXR file layout: Blender's writer always
    writes R, G and B. `sampling`: {name: (x, y) subsampling}, that plane (H / y, W / x)."""
    import struct

    def attr(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data
    names = sorted(planes)
    sampling = {n: (sampling or {}).get(n, (1, 1)) for n in names}
    h, w = next(planes[n].shape for n in names if sampling[n] == (1, 1))
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", 1, 0, *sampling[n])
                      for n in names) + b"\0"
    box = struct.pack("<4i", 0, 0, w - 1, h - 1)
    header = (attr("channels", "chlist", chlist) + attr("compression", "compression", b"\0")
              + attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box)
              + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1))
              + attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0")
    head = b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + header
    rows = []                                   # EXR's first line is the top: v = 1
    for y in range(h):
        lines = [planes[n][len(planes[n]) - 1 - y // sampling[n][1]] for n in names
                 if y % sampling[n][1] == 0]
        data = b"".join(line.astype("<f2").tobytes() for line in lines)
        rows.append(struct.pack("<ii", y, len(data)) + data)
    offsets, at = [], len(head) + 8 * h
    for row in rows:
        offsets.append(at)
        at += len(row)
    path.write_bytes(head + struct.pack(f"<{h}Q", *offsets) + b"".join(rows))


@pytest.mark.parametrize("channels", ["Y", "YA"])
def test_an_exr_without_r_g_and_b_is_baked_as_rendered_with_a_warning(channels, tmp_path,
                                                                      capsys):
    """EXR normal maps with a grey channel (Y, Y+A). Blender spreads Y over R, G and B.
    Before: not a word. Now the same map (for Y: that of an RGB EXR holding the grey thrice)
    and a warning naming what the file holds. (An R, G map, whose B a game engine rebuilds:
    refused on every line, tests/test_exr_channels.py.)"""
    t = _normal_texels()
    planes = {"Y": {"Y": t[..., 0]}, "YA": {"Y": t[..., 0], "A": t[..., 3]}}[channels]
    _exr_of_channels(tmp_path / "n.exr", planes)
    err = _bake(_scene(tmp_path / "e.blend", tmp_path / "n.exr"), tmp_path / "m.png", capsys)
    held = {"Y": "1 channel in its file (n.exr: Y (grey) EXR): Blender spreads the grey",
            "YA": "2 channels in its file (n.exr: Y (grey) and A EXR): Blender spreads the "
                  "grey"}[channels]
    assert f"surfgrad: warning: image 'n.exr', read by Normal Map node 'Normal Map' " \
           f"(material 'Mat'), holds {held}" in err, err
    assert err.count("surfgrad: warning") == 1, err
    if channels == "Y":
        _exr_of_channels(tmp_path / "rgb.exr", {c: t[..., 0] for c in "RGB"})
        rgb = _bake(_scene(tmp_path / "c.blend", tmp_path / "rgb.exr"), tmp_path / "c.png",
                    capsys)
        # (three channels: no channel warning; its grey blue warned of by its pixels)
        assert "in its file (" not in rgb and "blue at or below 0.5" in rgb, rgb
        assert (tmp_path / "m.png").read_bytes() == (tmp_path / "c.png").read_bytes()


@pytest.mark.parametrize("encoding, warned", [("-1..1", True), ("0..1", False)])
def test_a_float_normal_map_stored_in_minus_one_to_one_is_warned(encoding, warned, tmp_path,
                                                                 capsys):
    """A float EXR holding n in -1..1 (not n * 0.5 + 0.5). Before: exit 0, not a word, every
    normal pulled toward (-1, -1). Now a warning with the share below 0; a 0..1 one says
    nothing."""
    rgba = _normal_texels()
    if encoding == "-1..1":
        rgba[..., :3] = rgba[..., :3] * 2 - 1
    _write_image(tmp_path / "n.exr", rgba, "OPEN_EXR", float_buffer=True, color_depth="32")
    err = _bake(_scene(tmp_path / "f.blend", tmp_path / "n.exr"), tmp_path / "m.png", capsys)
    below = [round(100 * np.mean(rgba[..., c] < 0)) for c in (0, 1)]
    said = (f"surfgrad: warning: image 'n.exr', read by Normal Map node 'Normal Map' "
            f"(material 'Mat'), has {below[0]}% of its texels below 0 in R and {below[1]}% in "
            f"G: it looks stored in -1..1")
    assert (said in err) == warned, err
    assert ("surfgrad: warning" in err) == warned, err
    if warned:
        assert min(below) > 5 and "store it as n * 0.5 + 0.5" in err


@pytest.mark.tier("child")
def test_a_batch_records_the_grey_normal_map_warning(tmp_path):
    """The warning reaches bake-batch's output and its manifest, as the sRGB one does."""
    _grey_png(tmp_path / "grey.png", "L")
    blend = _scene(tmp_path / "a.blend", tmp_path / "grey.png")
    out = tmp_path / "maps"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    run = subprocess.run([sys.executable, "-m", "surfgrad_addon", "bake-batch", str(blend),
                          "--output", str(out / "{file}_{object}.png"), "--resolution", "16",
                          "--workers", "1"], cwd=str(ROOT), env=env, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    said = ("image 'grey.png', read by Normal Map node 'Normal Map' (material 'Mat'), holds "
            "1 channel in its file (grey.png: grey PNG)")
    assert f"surfgrad: warning: a.blend:Plane: {said}" in run.stderr, run.stderr[-3000:]
    entry = json.loads((out / MANIFEST_NAME).read_text())["assets"][f"{blend}:Plane"]
    assert [w for w in entry["warnings"] if w.startswith(said)], entry["warnings"]


@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch", "--manifest"])
def test_an_output_written_blenders_way_is_refused_not_put_in_the_root(command, tmp_path,
                                                                        capsys):
    """`--output //maps/n.png`, Blender's 'beside the .blend', copied from its interface.
    Before: exit 0 and the map written to /maps/n.png, the file system's root (a root farm
    node takes it; elsewhere 'not writable'). Now refused, exit 2, nothing written."""
    _write_image(tmp_path / "n.png", _normal_texels())
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    name = f"surfgrad-probe-{os.getpid()}"
    if command == "bake-normal-map":
        args = ["--blend", str(blend), "--object", "Plane", "--output", f"//{name}.png"]
        said = f"output '//{name}.png' starts with '//'"
    elif command == "bake-batch":
        args = [str(blend), "--output", f"//{name}/{{object}}.png", "--workers", "0"]
        said = f"output pattern '//{name}/{{object}}.png' starts with '//'"
    else:
        args = [str(blend), "--output", str(tmp_path / "maps" / "{object}.png"),
                "--workers", "0", "--manifest", f"//{name}.json"]
        said = f"manifest '//{name}.json' starts with '//'"
    try:
        rc = commands.execute([command if command != "--manifest" else "bake-batch", *args,
                               "--resolution", "16"])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAD_REQUEST, err
        _assert_refused_blend_relative(err, said, name)
    finally:
        _remove_from_root(name)


def _assert_refused_blend_relative(err, said, name):
    line = err.strip().splitlines()[-1]
    assert line.startswith(f"surfgrad: error: {said}, Blender's 'beside the .blend file', "
                           f"which a path given here does not mean (it would be written in "
                           f"the root: '/{name}") and "give the folder itself" in line, err
    assert not list(Path("/").glob(f"{name}*"))


def _remove_from_root(name):
    import shutil
    for p in Path("/").glob(f"{name}*"):
        shutil.rmtree(p) if p.is_dir() else p.unlink()


@pytest.mark.tier("child")
def test_a_compare_report_written_blenders_way_is_refused_not_put_in_the_root():
    """`compare --json //t.json`. Before: exit 0, /t.json and /t_error.png written in the
    file system's root."""
    name = f"surfgrad-probe-{os.getpid()}"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    try:
        run = subprocess.run([sys.executable, "-m", "surfgrad_addon", "compare", "--object",
                              "Torus", "--method", "normal-map", "--resolution", "16",
                              "--json", f"//{name}.json"], cwd=str(ROOT), env=env,
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == exit_codes.BAD_REQUEST, run.stderr[-3000:]
        _assert_refused_blend_relative(run.stderr, f"output '//{name}.json' starts with '//'",
                                       name)
    finally:
        _remove_from_root(name)


@pytest.mark.parametrize("errno_name, fix", [
    ("EROFS", "check that {folder!r} still takes files (its permissions, a read-only mount)"),
    ("ENOSPC", "free space in {folder!r} (the disk may be full)")])
def test_a_manifest_a_folder_refuses_names_the_folder_not_a_full_disk(errno_name, fix,
                                                                     tmp_path, monkeypatch):
    """The output folder made read-only during a batch (probed: an ext4 folder made immutable
    after the first map; the rest failed 'not writable' one by one). Before: the run's last
    line said 'free space ... (the disk may be full)' for a folder that had room. Simulated
    here (the suite may run as root, whom permissions do not bind): the rename fails."""
    import errno
    from surfgrad_addon.addon.batch import manifest as M
    code = getattr(errno, errno_name)

    def refuse(*_):
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(M.os, "replace", refuse)
    path = tmp_path / MANIFEST_NAME
    with pytest.raises(exit_codes.BakeFailed) as err:
        M.write_final(path, {"assets": {}, "files": {}})
    assert str(err.value) == (
        f"manifest {path} could not be written ({os.strerror(code)}): it does not record this "
        f"run; {fix.format(folder=str(tmp_path))} and bake again (--overwrite to replace the "
        f"maps it could not record)")
    assert list(tmp_path.iterdir()) == []               # no temporary left


def _without_root_reads():
    """The command prefix that makes file permissions bind this process: none for a user;
    for root, setpriv dropping the capabilities that let root read any file."""
    if os.geteuid() != 0:
        return []
    import shutil
    if not shutil.which("setpriv"):
        pytest.skip("root, and no setpriv to drop CAP_DAC_OVERRIDE")
    return ["setpriv", "--bounding-set", "-dac_override,-dac_read_search", "--"]


@pytest.mark.tier("child")
@pytest.mark.skipif(not hasattr(os, "geteuid"), reason="POSIX permissions")
@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch"])
def test_a_texture_this_user_may_not_read_is_named_as_such(command, tmp_path):
    """A texture whose read permission is denied (another user's file, mode 600). Before:
    'could not be read (damaged, or a format Blender does not open): re-save it as PNG or
    EXR', the wrong fix; bake-batch also printed a PermissionError traceback from a pool
    thread (the input hash of the file's dependencies), which killed that thread."""
    (tmp_path / "tex").mkdir()
    texture = tmp_path / "tex" / "n.png"
    _write_image(texture, _normal_texels())
    blend = _scene(tmp_path / "a.blend", texture)
    texture.chmod(0)
    out = tmp_path / "out"
    out.mkdir()
    args = {"bake-normal-map": ["--blend", blend, "--object", "Plane", "--output",
                                out / "n.png"],
            "bake-batch": [blend, "--output", out / "{object}.png", "--workers", "1"]}[command]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    try:
        run = subprocess.run([*_without_root_reads(), sys.executable, "-m", "surfgrad_addon",
                              command, *map(str, args), "--resolution", "16"], cwd=str(ROOT),
                             env=env, capture_output=True, text=True, timeout=300)
    finally:
        texture.chmod(0o644)
    want = {"bake-normal-map": exit_codes.BAD_REQUEST, "bake-batch": exit_codes.BAKE_FAILED}
    assert run.returncode == want[command], run.stderr[-3000:]
    text = run.stdout + run.stderr
    assert "Traceback" not in text and "damaged" not in text, text[-3000:]
    line = run.stderr.strip().splitlines()[-1]
    assert f"image 'n.png' reads {str(texture)!r}, which cannot be opened (Permission " \
           f"denied): Cycles would bake its magenta 'missing' colour; let this user read it " \
           f"(its permissions or owner), or pack it" in line, text[-3000:]
    assert [p.name for p in out.iterdir() if p.suffix == ".png"] == []
