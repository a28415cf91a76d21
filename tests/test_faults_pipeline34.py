"""Fault injection, red team 34b: what a pipeline meets that earlier rounds left.

An address-space limit (`ulimit -v`, SGE's h_vmem) below what `compare` and `compare-all`
need: the bake's own check (addon/memory_limit.py) was not made for them, so they crashed
inside Blender with no line (exit 139) or ended in a raw MemoryError or OpenBLAS traceback
(exit 1). A limit too low to load Blender at all crashed every command before any check ran
(or hung on 4.2). And the extension's own route (`blender -c surfgrad`, commands.execute)
started with its standard streams closed."""

import os
import subprocess
import sys

import pytest

pytest.importorskip("bpy")

pytestmark = pytest.mark.tier("child")

GB = 1024 ** 3


def _env(tmp_path):
    from support.child import ROOT
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(ROOT), TMPDIR=str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir(exist_ok=True)
    return env


def _address_space(limit_bytes):
    """preexec: a soft and hard address-space limit for the child (`ulimit -v`)."""
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))
    return limit


def _command(args, tmp_path, limit_bytes):
    """`python -m surfgrad_addon ARGS` under that limit: the finished CompletedProcess."""
    return subprocess.run([sys.executable, "-m", "surfgrad_addon", *map(str, args)],
                          cwd=str(tmp_path), env=_env(tmp_path), timeout=300,
                          preexec_fn=_address_space(limit_bytes), stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)


@pytest.fixture
def rock(tmp_path):
    from surfgrad_addon.harness import batch_assets as BA
    return BA.write_asset(tmp_path / "rock.blend", ("Rock",), tiles=(1001,), image_size=16)


LIMIT_TEXT = ("(`ulimit -v`, or the job's memory limit such as SGE's h_vmem), where Blender's "
              "bake would crash: raise the limit or compare at a lower --resolution")


@pytest.mark.parametrize("command", ["compare", "compare-all"])
def test_a_compare_that_cannot_fit_the_address_space_limit_is_refused(rock, tmp_path, command):
    """`ulimit -v` of 3 GB and an 8192^2 compare: its bake (pieces of 2048^2, 180 bytes a
    texel), the read-back and reference images (20 bytes a texel at least, 26 measured) and
    the bake's threads (128 MB) need at least 2.1 GB beside the 1.6 GB a started compare
    holds. Before (5.2): a segmentation fault inside Blender (exit 139, no line), or at 2 to
    2.5 GB a raw MemoryError / OpenBLAS traceback (exit 1); compare-all the same on its first
    case. Now refused before the bake, exit 2, one line, nothing written."""
    out = tmp_path / "out"
    if command == "compare":
        args = ["compare", "--blend", rock, "--object", "Rock", "--method", "normal-map",
                "--resolution", "8192", "--json", out / "c.json"]
    else:
        args = ["compare-all", "--out", out, "--resolution", "8192", "--workers", "1"]
    done = _command(args, tmp_path, 3 * GB)
    assert done.returncode == 2, done.stderr[-2000:]
    line = done.stderr.strip().splitlines()[-1]
    assert line.startswith("surfgrad: error: a 8192x8192 compare of 1 tile(s) needs at least "
                           "2.1 GB of memory beyond the "), line
    assert line.endswith(f"more than its address-space limit of 3.0 GB {LIMIT_TEXT}"), line
    assert "Traceback" not in done.stderr
    assert not out.exists() and list((tmp_path / "tmp").iterdir()) == []


@pytest.mark.parametrize("limit_gb", [0.95, 1.4])
def test_a_limit_too_low_to_load_blender_is_refused_with_one_line(rock, tmp_path, limit_gb):
    """`ulimit -v` of 0.95 GB: before, `import bpy` failed to map a library (ImportError
    traceback, exit 1); 1.4 GB: it segfaulted while loading (exit 139, no line; on 4.2 the
    process spun for good in OpenBLAS's retries, and SIGTERM did not end it). Now refused
    before Blender's module loads: exit 2, one line naming the limit and the fix."""
    out = tmp_path / "out"
    out.mkdir()
    done = _command(["bake-normal-map", "--blend", rock, "--object", "Rock", "--output",
                     out / "n.png", "--resolution", "64"], tmp_path, int(limit_gb * GB))
    assert done.returncode == 2, done.stderr[-2000:]
    assert done.stderr.strip().splitlines() == [
        f"surfgrad: error: the address-space limit of {limit_gb:.2f} GB (`ulimit -v`, or the "
        f"job's memory limit such as SGE's h_vmem) is below the 1.5 GB that loading Blender "
        f"and a .blend takes before anything is baked, where Blender would crash: raise the "
        f"limit"]
    assert list(out.iterdir()) == []


@pytest.mark.tier("numpy")
def test_the_bakes_threads_are_counted_against_the_limit(monkeypatch):
    """A 64^2 bake needs 0.7 MB for its texels, but Cycles' threads took more than 134 MB of
    address space (5.2.3; 257 MB on 5.0.1): with 100 MB of room left it passed the check and
    segfaulted in the bake (exit 139, no line). Now 128 MB are counted for any bake."""
    import resource
    from surfgrad_addon.addon import memory_limit as ML
    mb = 1024 ** 2
    monkeypatch.setattr(resource, "getrlimit", lambda _: (2 * GB, resource.RLIM_INFINITY))
    monkeypatch.setattr(ML, "machine_memory", lambda: None)
    monkeypatch.setattr(ML, "address_space_in_use", lambda: 2 * GB - 100 * mb)
    assert ML.bake_memory_problem(64, 1).startswith(
        "a 64x64 bake of 1 tile(s) needs at least 0.1 GB of memory beyond the 1.9 GB this "
        "process uses, more than its address-space limit of 2.0 GB")
    monkeypatch.setattr(ML, "address_space_in_use", lambda: 2 * GB - 130 * mb)
    assert ML.bake_memory_problem(64, 1) is None            # 128.7 MB: fits


@pytest.mark.tier("blender")
def test_a_start_limit_leaves_commands_that_do_not_load_blender_alone():
    """bench-reference runs without bpy: the start floor is not its business."""
    from surfgrad_addon.harness import cli
    (row,) = [c for c in cli.SUBCOMMANDS if c.name == "bench-reference"]
    assert not row.loads_blender
    assert all(c.loads_blender for c in cli.SUBCOMMANDS if c.name.startswith(("bake", "compare")))


# The extension's command route with closed standard streams -------------------------------------

EXECUTE = """
import sys
import bpy
from surfgrad_addon.addon import commands
sys.exit(commands._execute_and_leave(sys.argv[1:]))
"""


def _closed(fds):
    def close():
        for fd in fds:
            os.close(fd)
    return close


@pytest.mark.parametrize("fds", [[1], [2], [0, 1, 2]])
def test_blender_c_surfgrad_with_closed_streams_bakes_and_refuses_as_usual(rock, tmp_path, fds):
    """`blender -c surfgrad ... >&-` (and `2>&-`, `<&-`), run as Blender's -c runs it
    (commands' handler in a process that loaded bpy first): the map is written whole, the
    same bytes as with the streams open, and a bad request still gives exit 2."""
    out = tmp_path / "out"
    out.mkdir()
    base = ["bake-normal-map", "--blend", rock, "--resolution", "32"]

    def run(args, **streams):
        return subprocess.run([sys.executable, "-c", EXECUTE, *map(str, args)],
                              cwd=str(tmp_path), env=_env(tmp_path), timeout=300, **streams)
    closed = dict(preexec_fn=_closed(fds), stdout=None if 1 in fds else subprocess.DEVNULL,
                  stderr=None if 2 in fds else subprocess.PIPE)
    assert run(base + ["--object", "Rock", "--output", out / "closed.png"],
               **closed).returncode == 0
    assert run(base + ["--object", "Rock", "--output", out / "open.png"],
               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode == 0
    assert (out / "closed.png").read_bytes() == (out / "open.png").read_bytes()
    bad = run(base + ["--object", "Nope", "--output", out / "x.png"], **closed)
    assert bad.returncode == 2
    if 2 not in fds:
        assert b"surfgrad: error: no object named 'Nope'" in bad.stderr
    assert sorted(p.name for p in out.iterdir()) == ["closed.png", "open.png"]


# Two compares writing the same report ------------------------------------------------------------

@pytest.mark.tier("bake")
@pytest.mark.parametrize("appears", [("c.json", "c_error.png"), ("c_error.png",)])
def test_a_report_that_appears_while_compare_runs_is_left_and_this_one_fails(rock, tmp_path,
                                                                              monkeypatch,
                                                                              capsys, appears):
    """Two compares started at once with the same --json (no --overwrite): both pass the
    check, the first writes its pair. Before (two processes on 5.2): the second replaced the
    first's JSON, met its heat map, then removed both as its own, exit 1 saying "the disk may
    be full"; the first had exited 0 and its report was gone. Now the second fails naming the
    file that appeared, leaves the first's files as they are and writes nothing. (The other
    compare is played by writing its files while this one bakes.)"""
    from surfgrad_addon.harness import cli
    from surfgrad_addon.harness import compare as C
    out = tmp_path / "out"
    out.mkdir()
    real = C.compare

    def the_other_compare_writes_first(*args, **kwargs):
        result = real(*args, **kwargs)
        for name in appears:
            (out / name).write_bytes(b"the other compare's " + name.encode())
        return result
    monkeypatch.setattr(C, "compare", the_other_compare_writes_first)
    capsys.readouterr()
    rc = cli.main(["compare", "--blend", str(rock), "--object", "Rock", "--method",
                   "normal-map", "--resolution", "16", "--json", str(out / "c.json")])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert err.strip().splitlines()[-1] == (
        f"surfgrad: error: {str(out / appears[0])!r} appeared while this compare ran (another "
        f"compare writing the same report?) and is left as it is: give another --json, or "
        f"pass --overwrite")
    assert sorted(p.name for p in out.iterdir()) == sorted(appears)
    for name in appears:
        assert (out / name).read_bytes() == b"the other compare's " + name.encode()


# An output that is the input ----------------------------------------------------------------------

@pytest.mark.tier("blender")
@pytest.mark.parametrize("clash", ["json is the blend", "heat map is the image"])
def test_a_compare_output_that_is_its_input_is_refused_even_with_overwrite(rock, tmp_path,
                                                                            capsys, clash):
    """`compare --blend r.blend --json r.blend --overwrite` (a slip of tab completion).
    Before: exit 0, the .blend replaced by the JSON report (its first bytes `{`). Likewise a
    --json whose heat map (NAME_error.png) is the --image it reads. Now refused, exit 2,
    both files as they were."""
    import numpy as np
    from surfgrad_addon.harness import cli
    from surfgrad_addon.harness.pictures import write_png
    image = tmp_path / "n_error.png"            # a flat tangent-space normal map
    write_png(image, np.full((16, 16, 3), (0.5, 0.5, 1.0)))
    json_out = rock if clash == "json is the blend" else tmp_path / "n.json"
    before = {p: p.read_bytes() for p in (rock, image)}
    capsys.readouterr()
    rc = cli.main(["compare", "--blend", str(rock), "--object", "Rock", "--method",
                   "normal-map", "--resolution", "16", "--json", str(json_out), "--overwrite"]
                  + (["--image", str(image)] if clash == "heat map is the image" else []))
    err = capsys.readouterr().err
    assert rc == 2, err
    clashed = rock if clash == "json is the blend" else image
    assert err.strip().splitlines() == [
        f"surfgrad: error: output {str(clashed)!r} is the file {str(clashed)!r} this compare "
        f"reads; give another --json"]
    assert {p: p.read_bytes() for p in (rock, image)} == before
    assert not (tmp_path / "n.json").exists() and not (tmp_path / "rock_error.png").exists()


# Names that are not UTF-8 -------------------------------------------------------------------------

LATIN1 = b"R\xf6ck".decode("utf-8", "surrogateescape")      # 'Röck' typed in a Latin-1 terminal
NOT_UTF8 = ("is not UTF-8 text (a terminal or file in another encoding, such as Latin-1?): "
            "Blender's names are UTF-8; give the name in UTF-8")


@pytest.mark.tier("blender")
@pytest.mark.parametrize("route,option", [("python -m", "--object"), ("blender -c", "--object"),
                                          ("compare", "--object"), ("blender -c", "--uv-map"),
                                          ("bake-batch", "--objects")])
def test_a_name_that_is_not_utf8_is_refused_with_one_line(rock, tmp_path, capsys, route,
                                                          option):
    """`--object $'R\\xf6ck'` (Python hands the byte over as a surrogate, as it does for
    every argument). Before: `bpy.data.objects.get` raised a SystemError traceback, exit 1
    (bake-normal-map, compare; `blender -c surfgrad` alike). Now exit 2, one line naming
    the option, the bytes and the fix, nothing written."""
    from surfgrad_addon.addon import commands
    from surfgrad_addon.harness import cli
    out = tmp_path / "out"
    out.mkdir()
    if route == "compare":
        argv = ["compare", "--blend", str(rock), "--method", "normal-map", "--json",
                str(out / "c.json"), "--object", LATIN1]
    elif route == "bake-batch":
        argv = ["bake-batch", str(rock), "--output", str(out / "{object}.png"), "--workers",
                "0", "--objects", "Rock", LATIN1]
    else:
        argv = ["bake-normal-map", "--blend", str(rock), "--output", str(out / "n.png"),
                "--object", "Rock", "--uv-map", LATIN1] if option == "--uv-map" else \
            ["bake-normal-map", "--blend", str(rock), "--output", str(out / "n.png"),
             "--object", LATIN1]
    capsys.readouterr()
    rc = (commands.execute if route == "blender -c" else cli.main)(argv)
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.strip().splitlines() == [f"surfgrad: error: {option} 'R\\xf6ck' {NOT_UTF8}"]
    assert list(out.iterdir()) == []


@pytest.mark.tier("bake")
def test_a_batch_entry_naming_an_object_not_in_utf8_fails_that_asset_alone(rock, tmp_path,
                                                                           capsys):
    """`bake-batch rock.blend:$'R\\xf6ck' rock.blend:Rock`: before, the file's scan raised
    the SystemError and every asset of the file failed with it ('could not read rock.blend:
    SystemError: ...'). Now that entry fails with the line, Rock is baked."""
    import json
    from surfgrad_addon.harness import cli
    out = tmp_path / "out"
    rc = cli.main(["bake-batch", f"{rock}:{LATIN1}", f"{rock}:Rock", "--output",
                   str(out / "{object}.png"), "--workers", "0", "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert f"object 'R\\xf6ck' {NOT_UTF8}" in err
    manifest = json.loads((out / "surfgrad-bake-manifest.json").read_text())["assets"]
    status = {a.get("object"): a["status"] for a in manifest.values()}
    assert status == {"Rock": "baked", LATIN1: "failed"}, status
    assert sorted(p.name for p in out.iterdir()) == ["Rock.png", "surfgrad-bake-manifest.json"]


# compare-all's tables on a full disk ----------------------------------------------------------

@pytest.mark.tier("bake")
@pytest.mark.parametrize("fails", ["compare.json", "heat map"])
def test_compare_all_on_a_full_disk_leaves_nothing_and_says_one_line(tmp_path, monkeypatch,
                                                                     fails):
    """The disk fills (or `ulimit -f`) as compare-all writes compare.json, or a heat map.
    Before (`ulimit -f 1`, 5.2): a raw `OSError: [Errno 27] File too large` traceback, exit
    1, and a compare.json cut off at 1024 bytes left beside 40 heat maps. Now exit 1 (a
    BakeFailed: one line), nothing left in the output folder, which it made."""
    import errno
    from pathlib import Path
    from surfgrad_addon.addon.exit_codes import BakeFailed
    from surfgrad_addon.harness import compare_all as CA
    out = tmp_path / "deep" / "out"
    full = OSError(errno.ENOSPC, "No space left on device")
    if fails == "compare.json":
        real = Path.write_text

        def write_text(self, text, *args, **kwargs):
            if self.name == "compare.json":
                real(self, text[:1024], *args, **kwargs)        # what the disk took
                raise full
            return real(self, text, *args, **kwargs)
        monkeypatch.setattr(Path, "write_text", write_text)
    else:
        monkeypatch.setattr(CA, "write_heat_map", lambda *a, **k: (_ for _ in ()).throw(full))
    with pytest.raises(BakeFailed) as caught:
        CA.run_all(out, resolution=16, log=lambda *_: None, workers=1, methods=["normal-map"])
    assert str(caught.value) == (
        f"could not write the tables and heat maps in {str(out)!r} ([Errno 28] No space left "
        f"on device): free space there (the disk may be full) or check the folder's "
        f"permissions, and compare again")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.tier("bake")
def test_a_second_compare_all_into_the_same_folder_is_refused(tmp_path):
    """Two compare-alls given one --out. Before (two processes on 5.2, 16^2 and 32^2, the
    second started 8 s later): both exited 0; the tables left were the second's (the
    first's replaced without --overwrite) and the heat maps a mix of the two runs. Now the
    second is refused while the first holds the folder (a lock beside compare.json, as
    bake-batch's manifest has; here held by hand), exit 2, nothing written; and a run that
    ends lets go of it."""
    import fcntl
    from surfgrad_addon.harness import compare_all as CA
    from surfgrad_addon.harness.compare import CompareError
    out = tmp_path / "out"
    out.mkdir()
    lock = out / ".compare.json.lock"
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)        # the first run, still running
    try:
        with pytest.raises(CompareError) as caught:
            CA.run_all(out, resolution=16, log=lambda *_: None, workers=1,
                       methods=["normal-map"])
    finally:
        os.close(fd)
    assert str(caught.value) == (
        f"{str(out)!r} is in use by another compare-all run (it holds {str(lock)!r}): wait "
        f"for that run to end, or give this one another --out")
    assert sorted(p.name for p in out.iterdir()) == [".compare.json.lock"]
    lock.unlink()
    reports = CA.run_all(out, resolution=16, log=lambda *_: None, workers=1,
                         methods=["normal-map"])
    assert len(reports) == len(list((out / "heat").glob("*.png"))) > 0
    assert sorted(p.name for p in out.iterdir()) == ["compare.json", "compare.md", "heat"]
