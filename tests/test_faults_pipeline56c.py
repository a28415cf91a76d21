"""Red team 56c: faults a headless pipeline meets (interrupts, full disks, odd output paths,
bad pixels, damaged files), probed through bake-normal-map and api.bake_normal_map.

1. A normal map whose OpenEXR copy was cut short (a copy, download or sync interrupted: the
   file's last chunk, here its last 1 %, missing). Blender's load gives a full-size image
   (5.0 and 5.2: the chunk missing black; 4.2, 4.5 as the file's start), so no check saw
   it, and the bake went on, exit 0. Measured with a 32^2 plane, float EXR of (0.5, 0.5, 1):
   5.2 baked Cycles' magenta 'missing' colour in every texel (the Normal Map node's
   (1, -1, 1): 54.7 degrees off the whole file's map, 1024 of 1024 texels); 5.0, 4.5 and
   4.2 baked every texel wrong too, up to 174.8 degrees off. The same for a WebP cut short
   on 4.2, 4.5 and 5.0 (Blender loads transparent black at full size; Cycles bakes magenta,
   54.7 degrees, exit 0; 5.2 refuses the load). The header check (image_headers.cut_short)
   knew JPEG, TIFF and SGI only. Now a single-part EXR (scanline or tiled) whose offset
   table or chunks run past the file's end, or a WebP shorter than its RIFF header says, is
   refused before baking, exit 2, naming the file and the fix, no map written.

2. A SIGTERM (a farm's cancel) or Ctrl-C while `python -m surfgrad_addon bake-normal-map`
   (bake-batch, compare, ...) imported bpy, Blender's start: Blender makes its session folder
   ($TMPDIR/blender_XXXXXX) early in that import, before bpy is in sys.modules, and the stop
   (interrupts.stop) finds the folder through bpy.app.tempdir: it was left behind, exit 143.
   Measured (5.2, SIGTERM sent 0.7 to 1.4 s after the start, 14 runs): 8 left a blender_*
   folder in $TMPDIR; a farm node's /tmp gathers one per cancelled task. Now bpy is imported
   with the signals held (interrupts.stoppable(load_blender=True)) by those three, and one
   that came meanwhile stops the command as soon as bpy is in, its folder removed: 12 of 12 runs left
   nothing. Pinned deterministically: the signal is sent from inside that import.

3. An output that is a named pipe, or a symbolic link to a device (`maps/rock_nrm.exr ->
   /dev/null`, an output a TD turned off), with --overwrite: bake-normal-map and bake-batch
   renamed the finished map over it, exit 0, the pipe or link gone (a regular 439-byte PNG in
   its place), where `compare --json` refuses such a path ("is not a regular file"). Now
   refused before the bake (bake_request.output_problems), exit 2 (bake-batch: the asset
   fails, exit 1), the pipe or link left as it was; a regular file is still replaced.

Probed and fine (not pinned here): a PNG, BMP, Radiance HDR, TGA or JPEG 2000 cut short
(Blender refuses the load, and so does the bake; a PNG losing only its IEND chunk loads whole
on 4.2 and bakes right, 0.3 degrees).
"""

import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.image_headers import cut_short  # noqa: E402
from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16


def _bake(blend, output, capsys):
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(output), "--resolution", str(RES), "--samples", "1"])
    return rc, capsys.readouterr().err


def _cut(path, keep):
    """A copy of `path` holding its first `keep` share of bytes (a copy interrupted)."""
    data = path.read_bytes()
    cut = path.with_name("cut" + path.suffix)
    cut.write_bytes(data[:int(len(data) * keep)])
    return cut


def _cut_bytes(path, n):
    data = path.read_bytes()
    cut = path.with_name(f"cut{n}" + path.suffix)
    cut.write_bytes(data[:-n])
    return cut


@pytest.mark.parametrize("file_format, suffix, keep, name",
                         [("OPEN_EXR", ".exr", 0.99, "an OpenEXR"),
                          ("WEBP", ".webp", 0.9, "a WebP")])
def test_a_normal_map_cut_short_is_refused_before_the_bake(file_format, suffix, keep, name,
                                                           tmp_path, capsys):
    """The whole file bakes (exit 0, a map); its copy cut short is refused, exit 2, no map,
    naming the file, what is wrong and the fix. Before: exit 0, a map of Cycles' magenta
    (54.7 degrees off) or of garbage (up to 174.8 degrees off)."""
    whole = tmp_path / f"n{suffix}"
    _write_image(whole, _normal_texels(RES), file_format,
                 float_buffer=file_format == "OPEN_EXR", color_mode="RGB")
    blend = _scene(tmp_path / "whole.blend", whole)
    out = tmp_path / "whole.png"
    rc, err = _bake(blend, out, capsys)
    assert rc == 0 and out.exists(), err

    cut = _cut(whole, keep)
    blend = _scene(tmp_path / "cut.blend", cut)
    before = blend.read_bytes()
    out = tmp_path / "cut_map.png"
    rc, err = _bake(blend, out, capsys)
    assert rc == exit_codes.BAD_REQUEST, err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["whole.blend", "whole.png", "cut.blend", whole.name, cut.name]), err
    assert f"reads '{cut.name}', {name} cut short" in err, err
    assert "copy or export the file again, whole" in err, err
    assert "Traceback" not in err
    assert blend.read_bytes() == before


@pytest.mark.parametrize("codec", ["NONE", "RLE", "ZIPS", "ZIP", "PIZ", "PXR24", "B44",
                                   "DWAA", "DWAB", "HTJ2K"])
def test_blender_exrs_whole_and_one_byte_short(codec, tmp_path):
    """Every EXR codec Blender writes: the whole file is not called cut short (no false
    refusal), the file one byte short, or missing its last chunk's half, is."""
    path = tmp_path / "n.exr"
    img = bpy.data.images.new("tmp_img", 40, 40, float_buffer=True)
    img.pixels.foreach_set(np.random.default_rng(0).random(40 * 40 * 4).astype(np.float32))
    s = bpy.context.scene.render.image_settings
    s.file_format = "OPEN_EXR"
    try:
        s.exr_codec = codec
    except TypeError:
        bpy.data.images.remove(img)
        pytest.skip(f"this Blender line writes no {codec} float EXR")
    img.save_render(str(path), scene=bpy.context.scene)
    bpy.data.images.remove(img)
    with open(path, "rb") as f:
        assert cut_short(f) is None
    for n in (1, 100):
        with open(_cut_bytes(path, n), "rb") as f:
            assert cut_short(f) == "OpenEXR", (codec, n)


def test_blenders_packed_exrs_whole_and_cut(tmp_path):
    """A float image packed into the .blend: Blender writes it to memory as an EXR whose
    offset table is left zeros (OpenEXR's reader rebuilds it by walking the chunks). Whole:
    not called cut short (the first version of this check refused every packed float image);
    cut to a half or nine tenths, it is."""
    import io
    img = bpy.data.images.new("packed_float", 40, 40, float_buffer=True)
    img.pixels.foreach_set(np.random.default_rng(2).random(40 * 40 * 4).astype(np.float32))
    img.pack()
    data = bytes(img.packed_file.data)
    bpy.data.images.remove(img)
    assert data[:4] == b"\x76\x2f\x31\x01"
    assert cut_short(io.BytesIO(data)) is None
    for keep in (len(data) // 2, len(data) * 9 // 10):     # (5.0 pads the data with zeros)
        assert cut_short(io.BytesIO(data[:keep])) == "OpenEXR", keep


def _exr_file(tiled, order=0, size=16, tile=8):
    """A hand-written uncompressed half RGB EXR (OpenEXR file layout): scanline with line
    order `order` (1: decreasing y, chunks stored bottom first), or tiled (one level,
    tile x tile). Returns its bytes, the pixels written, (size, size, 3), and where its
    offset table starts."""
    def attr(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data
    px = np.random.default_rng(1).random((size, size, 3)).astype(np.float16)
    chlist = b"".join(c + b"\0" + struct.pack("<iB3xii", 1, 0, 1, 1) for c in (b"B", b"G", b"R"))
    box = struct.pack("<4i", 0, 0, size - 1, size - 1)
    header = (attr("channels", "chlist", chlist + b"\0")
              + attr("compression", "compression", b"\0")
              + attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box)
              + attr("lineOrder", "lineOrder", bytes([order]))
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1))
              + attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1)))
    if tiled:
        header += attr("tiles", "tiledesc", struct.pack("<IIB", tile, tile, 0))
    head = b"\x76\x2f\x31\x01" + struct.pack("<i", 2 | (0x200 if tiled else 0)) + header + b"\0"

    def lines(y0, y1, x0, x1):
        return b"".join(px[y, x0:x1, c].astype("<f2").tobytes()
                        for y in range(y0, y1) for c in (2, 1, 0))
    if tiled:
        keys = [(tx, ty) for ty in range(size // tile) for tx in range(size // tile)]
        chunks = {k: struct.pack("<4i", k[0], k[1], 0, 0) for k in keys}
        for (tx, ty) in keys:
            data = lines(ty * tile, ty * tile + tile, tx * tile, tx * tile + tile)
            chunks[(tx, ty)] += struct.pack("<i", len(data)) + data
    else:
        keys = list(range(size))
        chunks = {y: struct.pack("<i", y) + struct.pack("<i", 6 * size) + lines(y, y + 1, 0, size)
                  for y in keys}
    stored = keys[::-1] if order == 1 else keys
    at = len(head) + 8 * len(keys)
    where = {}
    for k in stored:
        where[k] = at
        at += len(chunks[k])
    table = struct.pack(f"<{len(keys)}Q", *(where[k] for k in keys))
    return head + table + b"".join(chunks[k] for k in stored), px, len(head)


@pytest.mark.parametrize("tiled, order", [(False, 1), (True, 0)])
def test_tiled_and_bottom_first_exrs(tiled, order, tmp_path):
    """Layouts Blender does not write: a tiled EXR, and one stored bottom line first (its
    offset table not ascending). Whole: Blender loads the pixels written, and the check
    passes it; cut short by one byte, or its offset table cut, it is caught."""
    data, px, table = _exr_file(tiled, order)
    path = tmp_path / "t.exr"
    path.write_bytes(data)
    img = bpy.data.images.load(str(path))
    got = np.empty(16 * 16 * 4, np.float32)
    img.pixels.foreach_get(got)
    bpy.data.images.remove(img)
    assert np.allclose(got.reshape(16, 16, 4)[::-1, :, :3], px, atol=1e-3)  # (top line first)
    with open(path, "rb") as f:
        assert cut_short(f) is None
    for keep in (len(data) - 1, len(data) - 300, table + 12):
        path.write_bytes(data[:keep])
        with open(path, "rb") as f:
            assert cut_short(f) == "OpenEXR", keep


# Sends this process SIGTERM from inside bpy's import, once Blender has made its session folder
# and before bpy is in sys.modules (when Python looks up _bpy_types; bpy_types before 5.0),
# then runs the command as `python -m surfgrad_addon` does.
SIGNAL_IN_IMPORT = """
import os, runpy, signal, sys
class Finder:
    def find_spec(self, name, path=None, target=None):
        if name in ("_bpy_types", "bpy_types") and "bpy" not in sys.modules:
            os.kill(os.getpid(), signal.SIGTERM)
        return None
sys.meta_path.insert(0, Finder())
sys.argv = ["surfgrad_addon", *sys.argv[1:]]
runpy.run_module("surfgrad_addon", run_name="__main__", alter_sys=True)
"""


@pytest.mark.tier("child")
@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch", "compare"])
def test_a_sigterm_while_blender_starts_leaves_no_session_folder(command, tmp_path):
    """Exit 143 with one line, no output, the .blend unchanged, and nothing left in $TMPDIR
    (before: its blender_XXXXXX session folder, for each of these commands)."""
    _write_image(tmp_path / "n.png", _normal_texels(RES))
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    before = blend.read_bytes()
    temp = tmp_path / "tmp"
    temp.mkdir()
    out = tmp_path / "m.png"
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, TMPDIR=str(temp),
               PYTHONPATH=os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]))
    args, what = {
        "bake-normal-map": (["--blend", str(blend), "--object", "Plane", "--output", str(out)],
                            "the bake"),
        "bake-batch": ([str(blend), "--output", str(out), "--workers", "0", "--manifest",
                        str(tmp_path / "m.json")], "the batch"),
        "compare": (["--blend", str(blend), "--object", "Plane", "--method", "normal-map",
                     "--json", str(tmp_path / "r.json")], "compare")}[command]
    run = subprocess.run([sys.executable, "-c", SIGNAL_IN_IMPORT, command, *args,
                          "--resolution", str(RES)], capture_output=True, text=True, env=env,
                         cwd=tmp_path, timeout=120)
    assert run.returncode == 143, run.stderr
    assert f"surfgrad: interrupted by SIGTERM: stopped {what}; exit code 143" in run.stderr
    assert "Traceback" not in run.stderr + run.stdout
    assert sorted(p.name for p in temp.iterdir()) == [], run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend", "n.png", "tmp"]
    assert blend.read_bytes() == before


@pytest.mark.parametrize("kind", ["pipe", "link to /dev/null", "regular file"])
def test_an_output_that_is_not_a_regular_file_is_refused_even_with_overwrite(kind, tmp_path,
                                                                              capsys):
    """Exit 2, the pipe or link as it was, no map; a regular file (the control) is replaced,
    exit 0."""
    _write_image(tmp_path / "n.png", _normal_texels(RES))
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "out.png"
    if kind == "pipe":
        os.mkfifo(out)
    elif kind == "link to /dev/null":
        out.symlink_to(os.devnull)
    else:
        out.write_bytes(b"old")
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out), "--resolution", str(RES), "--samples", "1",
                           "--overwrite"])
    err = capsys.readouterr().err
    if kind == "regular file":
        assert rc == 0 and out.read_bytes()[:4] == b"\x89PNG", err
        return
    assert rc == exit_codes.BAD_REQUEST, err
    assert (f"output {str(out)!r} is not a regular file (a named pipe, device or socket"
            in err), err
    assert "give a file path" in err and "Traceback" not in err
    if kind == "pipe":
        assert out.is_fifo() and not out.is_symlink()
    else:
        assert out.is_symlink() and os.readlink(out) == os.devnull
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend", "n.png", "out.png"]


def test_bake_batch_fails_an_asset_whose_output_is_a_named_pipe(tmp_path, capsys):
    """bake-batch --workers 0 --overwrite into a pattern naming a pipe: the asset fails, exit
    1, the pipe as it was (before: exit 0, the pipe replaced by the map)."""
    _write_image(tmp_path / "n.png", _normal_texels(RES))
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "maps" / "a_Plane.png"
    out.parent.mkdir()
    os.mkfifo(out)
    rc = commands.execute(["bake-batch", str(blend), "--output",
                           str(tmp_path / "maps" / "{file}_{object}.png"), "--resolution",
                           str(RES), "--samples", "1", "--workers", "0", "--overwrite",
                           "--manifest", str(tmp_path / "m.json")])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert f"output {str(out)!r} is not a regular file" in err, err
    assert out.is_fifo() and [p.name for p in out.parent.iterdir()] == ["a_Plane.png"]


@pytest.mark.tier("child")
def test_a_header_with_a_negative_attribute_size_is_not_walked_for_ever():
    """Noticed by rt57a: an attribute whose size field is negative (a damaged file) walked the
    header back to where it was, for ever (a farm task hung on one bad file). Now the header
    is not judged (None), at once; Blender's load refuses such a file."""
    name, kind = b"comments\0", b"string\0"
    # size -(len(name) + len(kind) + 4): the walk lands on this attribute's first byte again
    bad = name + kind + struct.pack("<i", -(len(name) + len(kind) + 4))
    data = b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + bad + b"\0" * 64
    done = subprocess.run([sys.executable, "-c", "import io, sys; from surfgrad_addon.addon."
                           "image_headers import cut_short; print(cut_short(io.BytesIO("
                           "sys.stdin.buffer.read())))"], input=data, capture_output=True,
                          timeout=20, cwd=Path(__file__).resolve().parents[1])
    assert done.returncode == 0 and done.stdout.strip() == b"None", done.stderr[-400:]
