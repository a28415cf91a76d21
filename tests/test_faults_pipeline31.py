"""Fault injection, red team 31b: what a farm or a terminal does to a running bake beyond
Ctrl-C and SIGTERM. SIGHUP (the terminal closed), SIGQUIT and SIGUSR1 (a scheduler's notice)
ended `bake-normal-map` and `bake-batch` at once: no line, Blender's session folder left, the
batch's unfinished assets unrecorded. A closed stdout (`| head`, a log collector gone) ended a
batch midway with a traceback from a pool thread. A resumed batch counted its skipped assets
as if each were the last ([1/1] ... done). The OpenJD task pasted its paths into bash, so a
folder named with `$HOME` in it was expanded and the maps went elsewhere with exit code 0."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon.batch import MANIFEST_NAME  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from support.child import ROOT  # noqa: E402

pytestmark = pytest.mark.tier("child")


class Child:
    """`python -m surfgrad_addon ARGS` in the background, its signals set as a terminal or a
    farm leaves them (`ignore`: inherited as ignored, as nohup does with SIGHUP). stderr, and
    stdout unless the test reads it from a pipe, go to files in `logs`."""

    def __init__(self, args, logs, env=None, ignore=(), stdout_pipe=False):
        full = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        full.update(PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1", **(env or {}))

        def dispositions():
            for s in (signal.SIGHUP, signal.SIGQUIT, signal.SIGUSR1, signal.SIGINT):
                signal.signal(s, signal.SIG_IGN if s in ignore else signal.SIG_DFL)
        logs.mkdir(exist_ok=True)
        self.logs = logs
        err = open(logs / "stderr.txt", "w")
        out = subprocess.PIPE if stdout_pipe else open(logs / "stdout.txt", "w")
        self.proc = subprocess.Popen([sys.executable, "-m", "surfgrad_addon", *map(str, args)],
                                     cwd=str(logs), env=full, stdout=out, stderr=err,
                                     text=True, preexec_fn=dispositions)
        err.close()
        if not stdout_pipe:
            out.close()

    def _log(self, name):
        path = self.logs / name
        return path.read_text(errors="replace") if path.exists() else ""

    @property
    def stdout(self):
        return self._log("stdout.txt")

    @property
    def stderr(self):
        return self._log("stderr.txt")

    def wait_for(self, text, timeout=120):
        t0 = time.monotonic()
        while text not in self.stdout:
            if self.proc.poll() is not None or time.monotonic() - t0 > timeout:
                self.proc.kill()
                raise AssertionError(f"no {text!r}:\n{self.stdout[-2000:]}{self.stderr[-2000:]}")
            time.sleep(0.05)

    def end(self, timeout=120):
        """The exit code (the child is killed if it runs past `timeout`)."""
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            raise


def _files(folder):
    return sorted(p.name for p in Path(folder).iterdir())


@pytest.fixture
def asset(tmp_path):
    return BA.write_asset(tmp_path / "in" / "a.blend", ("Rock",), tiles=(1001,), image_size=16)


@pytest.mark.parametrize("signum", [signal.SIGHUP, signal.SIGQUIT, signal.SIGUSR1])
def test_a_hangup_quit_or_scheduler_signal_stops_the_bake_cleanly(asset, tmp_path, signum):
    """Before: the process died of the signal (exit -1/-3/-10), no line, Blender's
    blender_XXXXXX folder left in TMPDIR."""
    out, temp = tmp_path / "out", tmp_path / "tmp"
    out.mkdir()
    temp.mkdir()
    run = Child(["bake-normal-map", "--blend", asset, "--object", "Rock", "--output",
                 out / "rock.png", "--resolution", "512", "--samples", "64"], tmp_path / "logs",
                 env={"TMPDIR": str(temp)})
    run.wait_for("[2/3] baking")
    time.sleep(0.5)                               # inside Cycles' bake
    run.proc.send_signal(signum)
    code = run.end(60)
    assert code == 128 + signum, (code, run.stderr[-2000:])
    assert run.stderr.strip().splitlines()[-1] == \
        f"surfgrad: interrupted by {signum.name}: stopped the bake; exit code {128 + signum}"
    assert "Traceback" not in run.stderr
    assert _files(out) == [] and _files(temp) == []


def test_a_hangup_inherited_as_ignored_leaves_the_bake_running(asset, tmp_path):
    """`nohup surfgrad ... &`: the terminal's SIGHUP must not stop the bake (the stop
    handlers keep an inherited ignore)."""
    out = tmp_path / "out"
    out.mkdir()
    run = Child(["bake-normal-map", "--blend", asset, "--object", "Rock", "--output",
                 out / "rock.png", "--resolution", "256", "--samples", "16"], tmp_path / "logs",
                 ignore=(signal.SIGHUP,))
    run.wait_for("[2/3] baking")
    run.proc.send_signal(signal.SIGHUP)
    assert run.end() == 0, run.stderr[-2000:]
    assert _files(out) == ["rock.png"]


def _batch(blends, out, extra=()):
    return ["bake-batch", *blends, "--output", out / "{file}_{object}.png", "--resolution",
            "256", "--samples", "64", "--workers", "1", *extra]


def test_a_hangup_stops_a_batch_which_a_rerun_resumes_with_a_readable_count(tmp_path):
    """Before: the batch died of SIGHUP with its unfinished assets unrecorded and its lock file
    left. And a rerun printed each skipped asset as [k/k] ... done (the total counted only the
    files planned so far)."""
    blends = [BA.write_asset(tmp_path / "in" / f"a{i}.blend", (f"R{i}",), tiles=(1001,),
                             image_size=16, seed=i) for i in range(3)]
    out = tmp_path / "maps"
    run = Child(_batch(blends, out), tmp_path / "logs")
    run.wait_for("] baked a0.blend:R0")
    run.proc.send_signal(signal.SIGHUP)
    code = run.end(60)
    assert code == 129, run.stderr[-2000:]
    assert run.stderr.strip().splitlines()[-1] == \
        "surfgrad: interrupted by SIGHUP: stopped the batch; exit code 129"
    m = json.loads((out / MANIFEST_NAME).read_text())
    status = {e["object"]: e["status"] for e in m["assets"].values()}
    assert status["R0"] == "baked" and set(status.values()) <= {"baked", "interrupted"}
    assert "interrupted" in status.values(), status
    assert _files(out) == sorted([MANIFEST_NAME] + [f"a{i}_R{i}.png" for i, s in
                                                    enumerate(status.values()) if s == "baked"])
    rerun = Child(_batch(blends, out), tmp_path / "logs")
    assert rerun.end(300) == 0, rerun.stderr[-2000:]
    lines = [line for line in rerun.stdout.splitlines() if line.startswith("[") and "/" in
             line.split("]")[0]]
    assert lines[0].startswith("[1/3] skipped a0.blend:R0 "), lines
    assert [line.split("]")[0] for line in lines] == ["[1/3", "[2/3", "[3/3"]
    assert [line.split()[1] for line in lines].count("baked") == list(status.values()).count(
        "interrupted")
    assert sum(line.endswith(", done") for line in lines) == 1 and lines[-1].endswith(", done")


def test_a_batch_whose_output_is_closed_stops_cleanly_and_records_what_is_left(tmp_path):
    """`bake-batch ... | head -2`: before, the next progress line raised BrokenPipeError in a
    pool thread (a traceback), the batch ended with the rest unbaked and unrecorded."""
    blends = [BA.write_asset(tmp_path / "in" / f"a{i}.blend", (f"R{i}",), tiles=(1001,),
                             image_size=16, seed=i) for i in range(3)]
    out = tmp_path / "maps"
    run = Child(_batch(blends, out), tmp_path / "logs", stdout_pipe=True)
    seen = ""
    while "] baked a0.blend:R0" not in seen:
        line = run.proc.stdout.readline()
        assert line, run.stderr[-2000:]
        seen += line
    run.proc.stdout.close()                       # the reader goes, as `head` does
    code = run.end(120)
    assert code == 141, run.stderr[-3000:]
    assert "Traceback" not in run.stderr and "BrokenPipeError" not in run.stderr, run.stderr
    assert run.stderr.strip().splitlines()[-1] == \
        "surfgrad: interrupted by SIGPIPE (the program reading its output ended): stopped " \
        "the batch; exit code 141"
    # R1's progress line is the first write that fails: R1 is baked (and kept), R2 is not.
    m = json.loads((out / MANIFEST_NAME).read_text())
    status = {e["object"]: e["status"] for e in m["assets"].values()}
    assert status == {"R0": "baked", "R1": "baked", "R2": "interrupted"}, status
    assert _files(out) == sorted([MANIFEST_NAME, "a0_R0.png", "a1_R1.png"])


def test_a_bake_whose_output_is_closed_stops_cleanly_and_writes_no_map(tmp_path):
    """`bake-normal-map ... | true`: the reader is gone before the bake's first line. Before,
    a BrokenPipeError traceback, exit 1 (the bake's own stoppable block had ended when the
    error reached the command line)."""
    blend = BA.write_asset(tmp_path / "in" / "a.blend", ("R0",), tiles=(1001,), image_size=16,
                           seed=1)
    out = tmp_path / "n.png"
    run = Child(["bake-normal-map", "--blend", blend, "--object", "R0", "--output", out,
                 "--resolution", "16"], tmp_path / "logs", stdout_pipe=True)
    run.proc.stdout.close()
    code = run.end(120)
    assert code == 141, run.stderr[-3000:]
    assert "Traceback" not in run.stderr, run.stderr
    assert run.stderr.strip().splitlines()[-1] == \
        "surfgrad: interrupted by SIGPIPE (the program reading its output ended): stopped " \
        "the bake; exit code 141"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in", "logs"]


DEAD_WORKER = """
import subprocess, sys
sys.path.insert(0, sys.argv[1])
from surfgrad_addon.addon import interrupts
with interrupts.stoppable("the batch"):
    worker = subprocess.Popen([sys.executable, "-c", "pass"], stdin=subprocess.PIPE, text=True)
    worker.wait()
    try:                                    # what Worker.call does with its next request
        worker.stdin.write("x" * 100000 + "\\n")
        worker.stdin.flush()
    except (BrokenPipeError, OSError) as err:
        print("the write failed:", type(err).__name__)
    print("the batch goes on")
"""


def test_a_write_to_a_worker_that_died_does_not_stop_the_batch(tmp_path):
    """A pipe to a worker that died breaks too: the batch must see it as the worker's death
    (Worker.call returns None and the asset is retried), not as its own output closed. With
    SIGPIPE caught as a stop signal, this write ended the process with 141 and 'the program
    reading its output ended'."""
    done = subprocess.run([sys.executable, "-c", DEAD_WORKER, str(ROOT)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["the write failed: BrokenPipeError",
                                        "the batch goes on"], done.stdout + done.stderr


def test_openjd_task_takes_paths_with_shell_characters_as_they_are(tmp_path):
    """Before: the task script had the paths pasted into it, so bash expanded `$HOME` in a
    folder name (the maps went to '.../maps /root ...', exit 0) and a '"' broke the script."""
    from test_farm import _openjd, _openjd_run
    openjd = _openjd()
    BA.write_asset(tmp_path / "in" / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    lst = tmp_path / "assets.txt"
    lst.write_text("in/a.blend\n")
    folder = tmp_path / 'maps $HOME "q" `x` ü'
    res = _openjd_run(openjd, tmp_path, lst, "0", folder)      # tiles 1001-1002
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    made = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*.*")
                  if p.suffix in (".png", ".json"))
    assert made == [f"{folder.name}/a_Rock.1001.png"] + [
        f"{folder.name}/manifests/asset-0-tile-{t}.json" for t in (1001, 1002)]

def _blender_opening_a_file():
    """Every documented command line in which Blender itself opens a .blend before our script
    runs (`blender -b FILE ... --python SCRIPT`), as (where, the line with its continuation)."""
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
             *sorted((ROOT / "surfgrad_addon").rglob("*.py")), ROOT / "run.sh"]
    for path in files:
        if not path.is_file():
            continue
        lines = path.read_text(errors="replace").splitlines()
        for n, line in enumerate(lines):
            if "blender -b " in line and "--factory-startup" not in line:
                whole = line + " " + (lines[n + 1] if n + 1 < len(lines) else "")
                if "--python" in whole:
                    yield f"{path.relative_to(ROOT)}:{n + 1}", line


@pytest.mark.tier("blender")
def test_every_documented_blender_b_line_keeps_the_files_scripts_off():
    """`blender -b scene.blend --python bake_normal_map.py`: Blender opens the file before our
    script can, honouring the user's Auto Run preference, so the file's registered text blocks
    and Python drivers ran. Before: none of the seven documented lines had --disable-autoexec."""
    lines = list(_blender_opening_a_file())
    where = {w.split(":")[0] for w, _ in lines}
    assert {"docs/pipelines.md", "docs/proof.md", "surfgrad_addon/bake_normal_map.py",
            "surfgrad_addon/blender_cli.py"} <= where, where
    for w, line in lines:
        after_b = line[line.index("blender -b ") + len("blender -b "):].split()
        # before the file: Blender applies its options in order
        assert after_b[0] == "--disable-autoexec", f"{w}: {line.strip()}"


def _bake_here(capsys, blend, output):
    """bake-normal-map of object Rock in this process at 16^2: (exit code, stderr)."""
    from surfgrad_addon.addon import commands
    output.parent.mkdir(exist_ok=True)
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(output), "--resolution", "16"])
    return rc, capsys.readouterr().err


@pytest.mark.tier("bake")
def test_a_compressed_blend_from_a_newer_line_is_opened_with_a_warning(tmp_path, capsys,
                                                                       monkeypatch):
    """A 5.2 file saved compressed (zstd: the header is not readable without zstd) opened on
    4.5 or 5.0: before, no surfgrad warning (Blender's went to stdout), exit 0. Probed for
    real with 4.5.15; here the running line is taken as one line older than this one, and the
    version comes from the file Blender loaded."""
    from surfgrad_addon.addon import open_blend
    plain = BA.write_asset(tmp_path / "p.blend", ("Rock",), tiles=(1001,), image_size=16)
    bpy.ops.wm.open_mainfile(filepath=str(plain), use_scripts=False)
    blend = tmp_path / "c.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=True)
    assert blend.read_bytes()[:4] == b"\x28\xb5\x2f\xfd"          # a zstd frame
    assert open_blend.saved_by(blend.read_bytes()[:17]) is None    # the header says nothing
    major, minor = bpy.app.version[:2]
    older = (major, minor - 1) if minor else (major - 1, 5)
    monkeypatch.setattr(open_blend, "running_line", lambda: older, raising=False)
    rc, err = _bake_here(capsys, blend, tmp_path / "out" / "n.png")
    assert rc == 0, err
    assert (f"surfgrad: warning: .blend file {str(blend)!r} was saved by Blender "
            f"{major}.{minor}, newer than this Blender ({older[0]}.{older[1]}): what that line "
            f"added to the file may be lost") in err


def _linked_material_scene(tmp_path, override):
    """scene.blend: object Rock whose material is Rock_SG linked from lib.blend (relative
    path), or a library override of it."""
    lib = BA.write_asset(tmp_path / "lib.blend", ("Rock",), tiles=(1001,), image_size=16)
    scene = BA.write_asset(tmp_path / "scene.blend", ("Rock",), tiles=(1001,), image_size=16)
    bpy.ops.wm.open_mainfile(filepath=str(scene), use_scripts=False)
    with bpy.data.libraries.load(str(lib), link=True, relative=True) as (_src, dst):
        dst.materials = ["Rock_SG"]
    mat = dst.materials[0]
    if override:
        mat = mat.override_create(remap_local_usages=True)
    bpy.data.objects["Rock"].data.materials[0] = mat
    bpy.ops.wm.save_as_mainfile(filepath=str(scene), compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return scene


def _slots_state():
    """What the open file's object Rock holds: each slot's link, its material (name, library
    path) and the mesh's; and every material of the file."""
    obj = bpy.data.objects["Rock"]

    def named(mat):
        return None if mat is None else (mat.name, mat.library and mat.library.filepath)
    return ([(s.link, named(s.material)) for s in obj.material_slots],
            [named(m) for m in obj.data.materials],
            sorted((m.name, bool(m.library), m.users) for m in bpy.data.materials))


@pytest.mark.tier("bake")
def test_a_material_linked_from_a_library_bakes_as_the_local_one(tmp_path, capsys,
                                                                 monkeypatch):
    """Before: exit 2, `material 'Rock_SG' is linked from library '//lib.blend': Cycles bakes
    into an Image Texture node of each material, which a linked material does not take ...;
    make it local ...` (and before that, exit 1: Blender cancelled the bake). Now the bake
    goes through a temporary local copy: the same bytes as the material made local, as the
    library's own file and as a library override give; the .blend on disk is unchanged, and
    in a live session the slots and the file's materials are as before, after a bake (slot on
    the mesh or on the object) and after a failed one."""
    from surfgrad_addon.addon import exit_codes, normal_bake as NB
    scene = _linked_material_scene(tmp_path, override=False)
    before = scene.read_bytes()
    out = tmp_path / "out"
    rc, err = _bake_here(capsys, scene, out / "n.png")
    assert rc == 0, err
    assert scene.read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == ["n.png"]
    # The same material made local, in a file of its own.
    bpy.ops.wm.open_mainfile(filepath=str(scene), use_scripts=False)
    linked = bpy.data.objects["Rock"].data.materials[0]
    assert linked.library is not None
    local = linked.make_local()
    bpy.data.objects["Rock"].data.materials[0] = local
    assert bpy.data.objects["Rock"].data.materials[0].library is None
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "local.blend"), compress=False)
    rc_local, err_local = _bake_here(capsys, tmp_path / "local.blend", out / "local.png")
    rc_lib, err_lib = _bake_here(capsys, tmp_path / "lib.blend", out / "lib.png")
    assert (rc_local, rc_lib) == (0, 0), err_local + err_lib
    assert (out / "n.png").read_bytes() == (out / "local.png").read_bytes() == \
        (out / "lib.png").read_bytes()
    # A library override bakes as before: the same map.
    over = _linked_material_scene(tmp_path / "o", override=True)
    rc, err = _bake_here(capsys, over, out / "over.png")
    assert rc == 0, err
    assert (out / "over.png").read_bytes() == (out / "lib.png").read_bytes()
    # A live session: the slot on the mesh, then on the object; then a bake that fails.
    bpy.ops.wm.open_mainfile(filepath=str(scene), use_scripts=False)
    obj = bpy.data.objects["Rock"]
    state = _slots_state()
    assert state[0][0][1] == ("Rock_SG", "//lib.blend")
    quiet = dict(resolution=16, log=lambda *a: None)
    NB.bake_normal_map(obj, out / "live.png", **quiet)
    assert _slots_state() == state
    assert (out / "live.png").read_bytes() == (out / "lib.png").read_bytes()
    linked = obj.data.materials[0]
    obj.data.materials[0] = None
    obj.material_slots[0].link = "OBJECT"
    obj.material_slots[0].material = linked
    state = _slots_state()
    assert state[0] == [("OBJECT", ("Rock_SG", "//lib.blend"))] and state[1] == [None]
    NB.bake_normal_map(obj, out / "object_slot.png", **quiet)
    assert _slots_state() == state
    assert (out / "object_slot.png").read_bytes() == (out / "lib.png").read_bytes()

    def full_disk(*_):
        raise exit_codes.MapNotWritten("the disk is full")
    monkeypatch.setattr(NB, "_check_written", full_disk)
    with pytest.raises(exit_codes.MapNotWritten):
        NB.bake_normal_map(obj, out / "failed.png", **quiet)
    assert _slots_state() == state and not (out / "failed.png").exists()


@pytest.mark.tier("bake")
def test_bake_batch_and_compare_take_a_linked_material(tmp_path, capsys):
    """Before: bake-batch refused the asset (exit 2, the same 'linked from library' line).
    Its map is the library's own; compare (which bakes its own material) runs too; the .blend
    on disk is unchanged."""
    from surfgrad_addon.addon import commands
    from surfgrad_addon.harness.cli import main
    scene = _linked_material_scene(tmp_path, override=False)
    before = scene.read_bytes()
    out = tmp_path / "out"
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(scene), "--output", str(out / "{object}.png"),
                           "--resolution", "16", "--workers", "0"])
    assert rc == 0, capsys.readouterr().err
    rc_lib, err_lib = _bake_here(capsys, tmp_path / "lib.blend", out / "lib.png")
    assert rc_lib == 0, err_lib
    assert (out / "Rock.png").read_bytes() == (out / "lib.png").read_bytes()
    code = main(["compare", "--blend", str(scene), "--object", "Rock", "--method",
                 "normal-map", "--resolution", "16", "--json", str(out / "c.json")])
    assert code == 0, capsys.readouterr().err
    assert json.loads((out / "c.json").read_text())["texels_compared"] > 100
    assert scene.read_bytes() == before


@pytest.mark.tier("blender")
@pytest.mark.parametrize("too_long", ["folder_name", "path"])
def test_a_batch_output_folder_too_long_for_the_file_system_is_one_line(tmp_path, capsys,
                                                                         too_long):
    """Before: an OSError traceback ([Errno 36] File name too long, from Path.exists in the
    folder check), exit 1. A folder name past NAME_MAX (255 bytes) made by {file}_{object}
    from a 240-character object name (5.x names take 255), or a pattern past PATH_MAX."""
    from surfgrad_addon.addon import commands, exit_codes
    name = "R" * 240 if bpy.app.version >= (5, 0, 0) else "R" * 60
    blend = BA.write_asset(tmp_path / "a.blend", (name,), tiles=(1001,), image_size=16)
    if too_long == "folder_name":
        # 'a_' + the name + '_UVMap_' + padding: 262 bytes, one folder name
        folder = tmp_path / "maps" / ("{file}_{object}_{uv}_" + "m" * (262 - len(name) - 9))
    else:
        folder = tmp_path.joinpath(*["d" * 200] * 22)
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(blend), "--output", str(folder / "n.png"),
                           "--manifest", str(tmp_path / "m.json"), "--resolution", "16",
                           "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err[-3000:]
    assert "Traceback" not in err
    line = err.strip().splitlines()
    assert line[-1] == "(nothing was baked)"
    assert line[-2].startswith("surfgrad: error: output folder '") and line[-2].endswith(
        "cannot be used (File name too long): give a shorter folder path (most file systems "
        "take 255 bytes a name, 4096 a path)"), line[-2]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend"]


@pytest.mark.tier("blender")
def test_two_files_of_one_name_on_one_output_are_named_by_their_paths(tmp_path, capsys):
    """a/x.blend and b/x.blend, both with object Rock, into {file}_{object}.png. Before: refused
    as `x.blend:Rock and x.blend:Rock would both write ...: make the output pattern tell them
    apart ({file}, {object}, {uv})`: neither file named, and no token can tell them apart."""
    from surfgrad_addon.addon import commands, exit_codes
    a = BA.write_asset(tmp_path / "a" / "x.blend", ("Rock",), tiles=(1001,), image_size=16)
    b = BA.write_asset(tmp_path / "b" / "x.blend", ("Rock",), tiles=(1001,), image_size=16)
    out = tmp_path / "out"
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(a), str(b), "--output",
                           str(out / "{file}_{object}.png"), "--resolution", "16",
                           "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert err.strip().splitlines()[-2:] == [
        f"surfgrad: error: {b}:Rock and {a}:Rock would both write {out / 'x_Rock.png'}: no "
        f"output token can tell them apart (one file name, two folders); bake them in two "
        f"runs with their own output folders, or rename one", "(nothing was baked)"]
    assert not out.exists()


@pytest.mark.tier("bake")
def test_an_object_named_dot_dot_stays_in_the_output_folder(tmp_path, capsys):
    """`maps/{object}/n.png` with an object named '..' (a name Blender takes). Before: the map
    was written at '<tmp>/n.png', beside `maps`, exit 0."""
    from surfgrad_addon.addon import commands
    blend = BA.write_asset(tmp_path / "in" / "a.blend", ("..",), tiles=(1001,), image_size=16)
    root = tmp_path / "out"
    rc = commands.execute(["bake-batch", str(blend), "--output",
                           str(root / "maps" / "{object}" / "n.png"), "--resolution", "16",
                           "--workers", "0"])
    assert rc == 0, capsys.readouterr().err
    assert sorted(str(p.relative_to(root)) for p in root.rglob("*.png")) == ["maps/__/n.png"]


def _rock_and_rock(tmp_path):
    return BA.write_asset(tmp_path / "in" / "x.blend", ("Rock", "rock"), tiles=(1001,),
                          image_size=16)


@pytest.mark.tier("bake")
def test_outputs_one_only_in_case_are_refused_where_the_file_system_ignores_case(
        tmp_path, capsys, monkeypatch):
    """Objects Rock and rock into maps/{object}.png: on a file system that ignores case (macOS,
    Windows, SMB) the second map replaced the first with exit 0. Such a file system is faked
    here (this one keeps case: the probe says so, below)."""
    from surfgrad_addon.addon import commands, exit_codes
    from surfgrad_addon.addon.batch import output_names
    blend = _rock_and_rock(tmp_path)
    out = tmp_path / "maps"
    monkeypatch.setattr(output_names, "ignores_case", lambda folder: True)
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(blend), "--output", str(out / "{object}.png"),
                           "--resolution", "16", "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert err.strip().splitlines()[-2:] == [
        f"surfgrad: error: x.blend:rock and x.blend:Rock would write {out / 'rock.png'} and "
        f"{out / 'Rock.png'}, one file on this file system (it ignores case): the second map "
        f"would replace the first; rename one, or make the output pattern tell them apart",
        "(nothing was baked)"]
    assert not out.exists()


@pytest.mark.tier("bake")
def test_a_file_system_that_keeps_case_bakes_both_and_the_probe_leaves_nothing(tmp_path,
                                                                             capsys):
    from surfgrad_addon.addon import commands
    from surfgrad_addon.addon.batch import output_names
    blend = _rock_and_rock(tmp_path)
    out = tmp_path / "maps"
    probe_in = tmp_path / "probe"
    probe_in.mkdir()
    assert output_names.ignores_case(str(probe_in / "not" / "yet")) is False
    assert list(probe_in.iterdir()) == []
    rc = commands.execute(["bake-batch", str(blend), "--output", str(out / "{object}.png"),
                           "--resolution", "16", "--workers", "0"])
    assert rc == 0, capsys.readouterr().err
    assert {"Rock.png", "rock.png"} <= set(_files(out))
