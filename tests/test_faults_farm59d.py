"""Red team 59d: what a render farm or a pipeline meets (two tasks on one share, a cancel as a
task ends, names the farm's share folds), probed with the real commands (5.2 measured; the
tests run on every line).

1. A SIGTERM (a farm's cancel, a job's time limit) or Ctrl-C that reaches `python -m
   surfgrad_addon bake-batch` or `bake-normal-map` as the command ends: after its stop
   (interrupts.stoppable) was gone and before the process ended (Python's and Blender's exit,
   about 50 ms), the signal's default action ended it: exit -15 (143 in a shell), no line,
   though every map and the manifest were written; and Blender's session folder
   ($TMPDIR/blender_XXXXXX), which its exit removes, was left. Measured (5.2, one 32^2 asset,
   `bake-batch --workers 0`, SIGTERM sent 0 to 20 ms after the summary line, 6 runs each):
   0 ms: 4 of 6 died by the signal, 4 folders left; 20 ms: 6 of 6 died, 1 folder left; a farm
   node's /tmp gathers one per such task. Now a process whose command has ended ignores the
   stop signals (command_line.leave -> interrupts.ignore_at_exit) and exits with its
   command's code: 0 in 30 of 30 runs at 0 to 40 ms, nothing left. Pinned deterministically:
   the signal is sent from the process itself as Python shuts its threads down, before the
   exit handlers.

2. The Flamenco job type folded object names with JavaScript's toLowerCase where bake-batch
   folds with Python's casefold (output_names.output_key, list_tasks._name_key): 'Straße' and
   'STRASSE' (also 'STRAẞE' and 'strasse', 'ﬁx' and 'FIX', 'ſun' and 'SUN') stayed apart, so
   `{object}` in the output gave two tasks writing maps/Straße.png and maps/STRASSE.png, one
   file where Linux's case-insensitive folders (ext4, f2fs: full case folding, as
   casefold) or APFS hold the maps: the second task failed "exists" (an option the job does
   not have), and with `{uv}` in the pattern their manifests Straße-1001.json and
   STRASSE-1001.json were one file too. Now the job folds as casefold does (lower, upper,
   lower: the same classes as casefold over all of Unicode but for the dotless 'ı', which it
   puts with 'i', as NTFS's table does): refused on submission naming both objects; with
   {uv}, manifests apart.

3. The output folder removed or renamed while a batch ran (a TD's clean-up of a folder a farm
   job still writes, a share unmounted): where it went between a worker putting a map in place
   and the batch reading the map back for its hash, the FileNotFoundError ended the thread
   serving that worker with a raw traceback ("Exception in thread ... FileNotFoundError: ...
   maps/Obj1.png"); the asset was left with no status in the manifest and counted nowhere
   (8 assets, --workers 2: "6 baked, 0 skipped, 1 failed", exit 1); with --workers 0 the whole
   batch ended in the traceback. Now that asset fails (kind "output") naming the map, what
   happened and the fix; the others bake on (the folder made again), exit 1 (batch/run.py
   _read_back). A rerun bakes the missing maps (as before).

4. A batch killed with SIGKILL while its workers baked: a worker learns of it by its parent
   going (watch_parent: SIGTERM, its folder removed) or by a broken pipe on its next line
   (exit 141), and the second way left its empty surfgrad-worker-* folder in $TMPDIR: the
   folder's clean-up was registered inside the stop's block and gone by the time the stop
   ran. Measured (5.2, 8 assets, --workers 2, SIGKILL as the first map appeared): 7 of 8 runs
   left one; now 0 of 8 (worker_main.serve registers it outside). (Round 30b fixed the idle
   worker's case.)

Probed and fine (not pinned here): two `bake-normal-map` runs into one output at once
(different assets, no --overwrite, 3 rounds): one exit 0 with its own map, the other exit 2
"exists", no temporary file left; with --overwrite both exit 0, the later map stays (each
complete). Two `bake-batch --workers 2` runs of one list into one folder at once: the second
refused, exit 2, "in use by another bake-batch run"; with their own --manifest and
--overwrite both exit 0, every map whole. A worker SIGKILLed mid-batch: named, retried, exit 0,
every map baked. SIGINT/SIGTERM to bake-batch --workers 2 at its start, during the scan (50 ms,
0.5 s, 1 s after its workers started), during the bakes (after the 1st and 4th map) and as the
manifest is written: exit 130 / 143, one line, no worker left, no temporary file or session
folder left, nothing recorded before the first bake. A batch SIGKILLed mid-run (after the 1st
map, at the manifest's write) and run again: the rerun bakes the rest and takes the killed
run's maps as its own, exit 0, no temporary file left (round 44's pending record). The output
folder made immutable mid-run: each later asset fails naming the folder, exit 1 (the temporary
file of the bake under way cannot be removed from such a folder). An input .blend replaced
(renamed over) mid-run: its map is of the new file, recorded with the old file's hash, so the
next run bakes it again (never the reverse). A 5.2-saved .blend on 4.2: refused naming 5.2
and the fix; on 4.5 and 5.0: baked with the warning (4.5: the map 0.0 deg from 5.2's; a Menu Switch
is refused there: foreign_nodes.py).
"""

import hashlib
import json
import os
import signal
import unicodedata

import pytest

from support.child import run_python
from support.flamenco import compile_job

pytestmark = pytest.mark.tier("child")

SIZE = 32


# 1. A stop signal as the command ends -----------------------------------------------------

# The farm's cancel as the command ends: sent by the process itself once the command has
# returned, when Python shuts its threads down (before the exit handlers, Blender's among them).
CANCEL_AT_EXIT = (
    "import os, runpy, signal, sys, threading\n"
    "threading._register_atexit(lambda: os.kill(os.getpid(), signal.SIG{sig}))\n"
    "sys.argv = ['surfgrad_addon', *sys.argv[1:]]\n"
    "runpy.run_module('surfgrad_addon', run_name='__main__', alter_sys=True)\n")


@pytest.fixture(scope="module")
def rock(tmp_path_factory):
    pytest.importorskip("bpy")
    folder = tmp_path_factory.mktemp("in")
    out = run_python(["-c", "import sys; from surfgrad_addon.harness import batch_assets as BA;"
                      f"BA.write_asset(sys.argv[1], ('Rock',), tiles=(1001,), image_size={SIZE})",
                      folder / "rock.blend"])
    assert out.returncode == 0, out.stderr
    return folder / "rock.blend"


@pytest.mark.parametrize("sig", ["TERM", "INT"])
@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch"])
def test_a_stop_signal_as_the_command_ends_leaves_its_exit_code_and_no_folder(
        rock, tmp_path, command, sig):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    maps = tmp_path / "maps"
    maps.mkdir()
    args = (["--blend", rock, "--object", "Rock", "--output", maps / "Rock.png"]
            if command == "bake-normal-map" else
            [rock, "--output", maps / "{object}.png", "--workers", "0"])
    out = run_python(["-c", CANCEL_AT_EXIT.format(sig=sig), command, *args,
                      "--resolution", SIZE, "--samples", 1],
                     env={"TMPDIR": str(tmp)}, timeout=240)
    # The command had ended: its map (and manifest) written.
    assert (maps / "Rock.png").is_file(), out.stderr
    assert out.returncode == 0, (out.returncode, out.stderr[-600:])
    assert sorted(os.listdir(tmp)) == [], "Blender's session folder left"
    assert "Traceback" not in out.stderr
    if command == "bake-batch":
        assert (maps / "surfgrad-bake-manifest.json").is_file()
    assert sorted(p.name for p in maps.iterdir() if p.name.startswith(".")) == []


def test_the_signals_are_ignored_only_where_the_process_ends_next():
    """leave() is for a process that exits next; a command that has not ended still stops."""
    out = run_python(["-c",
                      "import os, signal\n"
                      "from surfgrad_addon.addon import command_line as CL\n"
                      "assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL\n"
                      "assert CL.leave(3) == 3\n"
                      "os.kill(os.getpid(), signal.SIGTERM)\n"
                      "os.kill(os.getpid(), signal.SIGINT)\n"
                      "print('went on')\n"
                      "raise SystemExit(3)\n"])
    assert (out.returncode, out.stdout) == (3, "went on\n"), (out.returncode, out.stderr)
    out = run_python(["-c", "import os, signal; os.kill(os.getpid(), signal.SIGTERM)"])
    assert out.returncode == -signal.SIGTERM, "control: without leave() the signal ends it"


# 2. The Flamenco job's names, folded as bake-batch and the share fold them ----------------

def _job(objects, pattern="/p/maps/{object}.png"):
    return compile_job({"objects": ",".join(objects), "tiles": "1001",
                        "blendfile": "/p/a.blend", "output_pattern": pattern,
                        "manifest_dir": "/p/m"})


def _fold(name):
    """As Python (bake-batch) and full case folding (ext4/f2fs casefold folders) take it."""
    return unicodedata.normalize("NFC", name).casefold()


@pytest.mark.parametrize("a, b", [("Straße", "STRASSE"), ("STRA\u1e9eE", "strasse"),
                                  ("\ufb01x", "FIX"), ("\u017fun", "SUN")])
def test_flamenco_refuses_objects_one_file_under_full_case_folding(a, b):
    assert a.lower() != b.lower() and _fold(a) == _fold(b)      # (what toLowerCase missed)
    job = _job([a, b])
    assert "tasks" not in job, job
    assert f"names one file for objects '{a}' and '{b}'" in job["error"], job
    assert "rename one of them" in job["error"]
    assert "tasks" in _job(["Straße", "Strase"]), "control: names apart under casefold too"


def _manifests(job):
    return [next(a for a in t["commands"][0]["parameters"]["args"] if a.endswith(".json"))
            for t in job["tasks"]]


def test_flamenco_manifests_are_apart_under_full_case_folding():
    """With {uv} (maps may be apart) each task gets a manifest that no case-folding file
    system takes for another's: every letter of Latin-1, Latin Extended-A/B, Greek and
    Cyrillic and the ligatures, with its upper case and its casefold, as object names."""
    letters = [chr(c) for r in ((0xC0, 0x250), (0x370, 0x400), (0x400, 0x460), (0xFB00, 0xFB07),
                                (0x1E9E, 0x1E9F))
               for c in range(*r) if unicodedata.category(chr(c)).startswith("L")]
    names = sorted({f"n{x}" for c in letters for x in (c, c.upper(), c.casefold())})
    job = _job(names, "/p/maps/{object}_{uv}.png")
    manifests = _manifests(job)
    assert len(manifests) == len(names) > 600
    keys = {}
    for m in manifests:
        keys.setdefault(_fold(m), []).append(m)
    assert [v for v in keys.values() if len(v) > 1] == []
    # Two names one casefold apart, such as the first finding's
    ms = _manifests(_job(["Straße", "STRASSE"], "/p/maps/{object}_{uv}.png"))
    assert ms == ["/p/m/Straße-1001.json", "/p/m/STRASSE_2-1001.json"], ms


# 3. The output folder removed while a batch runs ---------------------------------------------

# A batch of two assets (--workers 0) whose output folder is renamed away (a TD's clean-up, a
# share unmounted) right after the first bake put its map in place: between the bake and the
# batch reading the map back. Prints the exit code and the manifest as JSON lines.
FOLDER_GONE = """
import json, os, sys
from surfgrad_addon.addon import commands
from surfgrad_addon.addon.batch import workers
real, moved = workers.run_request, []

def run_request(req, **kw):
    reply = real(req, **kw)
    if req["op"] == "bake" and reply.get("status") == "ok" and not moved:
        os.rename(sys.argv[2], sys.argv[2] + ".gone")
        moved.append(req["object"])
    return reply

workers.run_request = run_request
code = commands.execute(["bake-batch", *sys.argv[3:], "--output", sys.argv[2] + "/{object}.png",
                         "--resolution", "%d", "--samples", "1", "--workers", "0"])
print(json.dumps({"code": code, "moved": moved}))
print(json.dumps(json.load(open(os.path.join(sys.argv[2], "surfgrad-bake-manifest.json")))))
""" % SIZE


@pytest.fixture(scope="module")
def two_assets(tmp_path_factory):
    pytest.importorskip("bpy")
    folder = tmp_path_factory.mktemp("two")
    out = run_python(["-c", "import sys; from surfgrad_addon.harness import batch_assets as BA\n"
                      "for i, name in enumerate(('Rock', 'Tree')):\n"
                      "    BA.write_asset(f'{sys.argv[1]}/{name.lower()}.blend', (name,),"
                      f" tiles=(1001,), image_size={SIZE}, seed=i)", folder])
    assert out.returncode == 0, out.stderr
    return folder / "rock.blend", folder / "tree.blend"


def test_a_map_gone_after_its_bake_fails_its_asset_by_name(two_assets, tmp_path):
    maps = tmp_path / "maps"
    out = run_python(["-c", FOLDER_GONE, "x", maps, *two_assets], timeout=240)
    assert "Traceback" not in out.stderr, out.stderr[-2000:]
    lines = out.stdout.strip().splitlines()
    ran, manifest = json.loads(lines[-2]), json.loads(lines[-1])
    gone = ran["moved"][0]
    other = ({"Rock", "Tree"} - {gone}).pop()
    assert ran["code"] == 1, (ran, out.stderr[-1500:])
    # The map that was put in place and then went: failed, naming it and the fix.
    (failed,) = [e for e in manifest["assets"].values() if e["object"] == gone]
    assert failed["status"] == "failed", failed
    assert (f"the map {maps / gone}.png was baked and put in place, then could not be read "
            "back (No such file or directory)") in failed["error"]
    assert "run the batch again" in failed["error"] and failed["error"] in out.stderr
    assert "files" not in failed or failed["files"] == {}
    # The other asset baked into the folder made again, recorded with its map's hash.
    (baked,) = [e for e in manifest["assets"].values() if e["object"] == other]
    assert baked["status"] == "baked", baked
    assert baked["files"]["1001"]["sha256"] == hashlib.sha256(
        (maps / f"{other}.png").read_bytes()).hexdigest()
    assert (maps.parent / "maps.gone" / f"{gone}.png").is_file()
    assert "1 baked, 0 skipped, 1 failed" in out.stdout + out.stderr


# 4. A busy worker whose batch went ----------------------------------------------------------

# A worker as the batch starts one (its own surfgrad-worker-* TMPDIR), whose reader goes (the
# batch killed with SIGKILL: its end of the worker's output closes) while it has a request:
# its next line meets a broken pipe. The batch stays alive here, so the worker's watch of its
# parent (the other way it learns of a killed batch) does not fire first.
READER_GONE = """
import json, os, subprocess, sys, tempfile
from surfgrad_addon.addon.batch import workers
from surfgrad_addon.addon.batch.worker_main import OWN_TEMPDIR, TEMPDIR_PREFIX
folder = tempfile.mkdtemp(prefix=TEMPDIR_PREFIX, dir=sys.argv[1])
env = dict(os.environ, TMPDIR=folder, TEMP=folder, TMP=folder, **{OWN_TEMPDIR: folder})
p = subprocess.Popen(workers.worker_command(), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                     stderr=subprocess.STDOUT, text=True, env=env)
for line in p.stdout:
    if '"ready"' in line:
        break
p.stdout.close()
p.stdin.write(json.dumps({"op": "scan", "file": sys.argv[2], "blend": sys.argv[2],
                          "timeout": 120, "objects": [], "collections": []}) + "\\n")
p.stdin.flush()
print(json.dumps({"code": p.wait(120), "left": os.path.exists(folder)}))
"""


def test_a_worker_whose_reader_went_removes_its_temp_folder(rock, tmp_path):
    """Before: exit 141 and its empty surfgrad-worker-* folder stayed in $TMPDIR (a batch
    SIGKILLed while 2 workers baked: 7 of 8 runs left one); Blender's folder in it went."""
    out = run_python(["-c", READER_GONE, tmp_path, rock], timeout=240)
    assert out.returncode == 0, out.stderr[-1500:]
    ran = json.loads(out.stdout.strip().splitlines()[-1])
    assert ran["code"] == 141, ran                  # as a SIGPIPE would (interrupts.py)
    assert ran["left"] is False, ran
    assert sorted(os.listdir(tmp_path)) == []
