"""Red team 43a: leftovers of round 42b on the pipeline side.

1. A compare-all worker killed by a signal (the out-of-memory killer's SIGKILL) failed the run
   as "compare-all worker 1 failed (exit -9): no output", and a batch's worker as "the worker
   process died (exit code -9)": neither named the signal nor what to do. Now both say
   "killed by SIGKILL, most likely the out-of-memory killer ..." with the fix.
2. Blender 5's path templates in bake-normal-map's --output ('{blend_name}_nrm.png'): the
   bake wrote a file named '{blend_name}_nrm.png', exit 0, where bake-batch refuses an
   unknown '{token}'. Now refused too, exit 2, naming the token and the fix, before anything
   runs.
3. The manifest's temporary file was `.NAME.part<pid>`: two farm tasks in containers (one
   process id) writing one manifest on a share whose locks do not reach across machines
   wrote one temporary file, each renaming the other's over the manifest. Now it carries the
   process's token, as the bake's temporary files do (interrupts.partial_path).
4. The UDIM refusals said faces lie "outside the UDIM range (u 0..10, v >= 0)", so a face at
   v = 100.5 (beyond tile 2000) was refused for lying where the message says is inside. Now
   "u 0..10, v 0..100", from one place (reference.tiles.UDIM_SPAN).
5. A SIGTERM while `python -m surfgrad_addon` loads its modules (before the command's stop is
   in place) ended the process by the signal, exit 143, no line. Now it is held with Ctrl-C
   while they load and then said in one line, exit 143, nothing run.
"""

import os
import re
import signal

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes, interrupts  # noqa: E402
from surfgrad_addon.addon.batch import manifest  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from surfgrad_addon.harness import compare_all as CA  # noqa: E402
from support.child import run_python  # noqa: E402

pytestmark = pytest.mark.tier("blender")


@pytest.mark.tier("numpy")
def test_a_worker_killed_by_a_signal_is_named_with_the_fix():
    """Popen's return code of a process ended by signal n is -n."""
    killed = str(CA.worker_failure(1, -int(signal.SIGKILL), ""))
    assert "exit -9" not in killed and "no output" not in killed
    for words in ("compare-all worker 1 failed", "killed by SIGKILL", "out-of-memory killer",
                  "--workers", "--resolution"):
        assert words in killed, (words, killed)
    assert "killed by SIGTERM" in str(CA.worker_failure(2, -int(signal.SIGTERM), ""))
    failed = str(CA.worker_failure(1, 1, "Traceback ...\nFileNotFoundError: 'x.png'\n"))
    assert failed == "compare-all worker 1 failed (exit 1): FileNotFoundError: 'x.png'"


def test_a_brace_token_in_a_single_bake_output_is_refused_as_the_batch_does(tmp_path,
                                                                             capsys):
    """Before: bake-normal-map wrote maps/{blend_name}_nrm.png, exit 0."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    maps = tmp_path / "maps"
    maps.mkdir()
    for command in (["bake-normal-map", "--blend", str(blend), "--object", "Rock"],
                    ["bake-batch", str(blend), "--workers", "0"]):
        rc = commands.execute([*command, "--output", str(maps / "{blend_name}_nrm.png"),
                               "--resolution", "16"])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAD_REQUEST, (command[0], err)
        assert "{blend_name}" in err and "{file}" in err, (command[0], err)
        assert "Traceback" not in err
        assert os.listdir(maps) == [], command[0]


@pytest.mark.tier("numpy")
def test_the_manifest_temporary_file_is_this_process_own(tmp_path):
    """Files beside the manifest of another task under this process's id: the name the
    manifest's write used before (`.NAME.part<pid>`) and today's with another token. Before:
    the write went into the first and renamed it over the manifest (another task's file under
    way, gone). Now both are left as they were."""
    path = tmp_path / "m.json"
    other = "0123abcd" if interrupts.PART_TOKEN != "0123abcd" else "89abcdef"
    theirs = {tmp_path / f".m.json.part{os.getpid()}": b"another task's manifest",
              tmp_path / f".m.part{os.getpid()}-{other}.json": b"another task's, too"}
    for p, data in theirs.items():
        p.write_bytes(data)
    manifest.write(path, {"assets": {}})
    for p, data in theirs.items():
        assert p.is_file() and p.read_bytes() == data, p.name
    assert sorted(f.name for f in tmp_path.iterdir()) == sorted(["m.json", *(p.name for p in
                                                                                theirs)])


def test_the_udim_refusal_says_where_the_tiles_end(tmp_path, capsys):
    """A quad at u 1..2, v 100..101 (tile 2002 would be there; Blender's last is 2000) beside
    one in tile 1001: refused by bake-normal-map and bake-batch. The range the message gives
    must leave that quad out."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001, 2002), image_size=16)
    maps = tmp_path / "maps"
    maps.mkdir()
    for command in (["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                     "--output", str(maps / "Rock.<UDIM>.png")],
                    ["bake-batch", str(blend), "--workers", "0", "--output",
                     str(maps / "{object}.<UDIM>.png")]):
        rc = commands.execute([*command, "--resolution", "16"])
        err = capsys.readouterr().err
        assert rc == {"bake-normal-map": 2, "bake-batch": 1}[command[0]], (command[0], rc, err)
        assert "1 face(s) of UV map 'UVMap'" in err and "outside the UDIM range" in err, err
        span = re.search(r"\(u 0\.\.(\d+), v 0\.\.(\d+)\)", err)
        assert span, (command[0], err)
        assert (int(span[1]), int(span[2])) == (10, 100)
        assert [f for f in os.listdir(maps) if f.endswith(".png")] == [], command[0]


@pytest.mark.tier("child")
def test_a_sigterm_before_the_command_began_says_so(tmp_path):
    """A SIGTERM pending when the command's modules load (the child starts with it blocked
    and pending, as one arriving during the imports is once they are held). Before: SIGTERM
    stayed blocked and `--help` ran to its end, exit 0 (and one arriving while nothing held it
    ended the process with no line). Now one line, exit 143, nothing run."""
    res = run_python(["-c", "import os, signal, sys\n"
                            "signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})\n"
                            "os.kill(os.getpid(), signal.SIGTERM)\n"
                            "os.execv(sys.executable, [sys.executable, '-m', 'surfgrad_addon', "
                            "'--help'])\n"], cwd=tmp_path, timeout=120)
    assert res.returncode == exit_codes.TERMINATED, (res.returncode, res.stderr[-2000:])
    assert res.stderr.strip().splitlines() == [
        "surfgrad: terminated by SIGTERM before the command began: nothing was done; "
        "exit code 143"]
    assert res.stdout == ""
