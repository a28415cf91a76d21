"""Red team 59g: a hostile review of round 59's merges (rt59a-d), measured on 5.2.

1. `blender ... --python surfgrad_addon/blender_cli.py -- compare ...` (and bake_normal_map.py)
   called command_line.leave whatever Blender did next, and leave now ignores SIGINT,
   SIGTERM, SIGHUP, SIGQUIT, SIGUSR1/2 and SIGXCPU for the rest of the process (rt59d,
   interrupts.ignore_at_exit). Blender goes on after a --python script that returns: with its
   UI (no -b: the compare run to look at the file afterwards) or with the arguments that
   follow the script (`--python blender_cli.py --render-frame 1 -- compare ...`, a render, or
   a second `--python` script). That Blender could then not be stopped by Ctrl-C, a closed
   terminal, `kill` or a farm's cancel (SIGTERM): measured with the bpy module standing in for
   Blender, after the script SIGTERM's handler was SIG_IGN (and SIGINT's, SIGHUP's) with a
   `--render-frame 1` after the script, and a SIGTERM sent to the process then did nothing
   (it went on, exit 0). Now the scripts call leave only where Blender exits next (a
   non-zero code, which sys.exit passes on, or -b with nothing but `--python-exit-code N`
   between the script and `--`: command_line.blender_exits_next); elsewhere the signals are
   as they were and the SIGTERM ends it (exit -15). rt59d's case (the script last, -b) keeps
   the signals ignored.

Probed and fine (not pinned here): leave's other callers (python -m surfgrad_addon, the
harness's __main__, `blender -c surfgrad`, the batch worker) all end next, and the api, the
add-on's UI and pytest never call it. batch/run._read_back hashes each map once where the
files record hashed it before (on_pending's hash of the temporary file was there already): no
second read added. The tile refusal with faces beyond the UDIM range names both fixes (ask for
tiles that hold UVs; move the faces or --allow-partial), each needed. sparse_warning reaches
stdout and the report JSON ("warnings"); a UDIM compare sums the tiles' texels.
method_scene._reach_along: an Array modifier hidden in the viewport (shown in renders) sizes
the projector to one copy (1.4 m against the render's 18 m) and centres it there, as for the
single object, so its boundary and outside still lie on the surface.
"""

import json
import signal
import sys

import pytest

from support.child import run_python
from surfgrad_addon.addon import command_line as CL

pytestmark = pytest.mark.tier("child")

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "surfgrad_addon" / "blender_cli.py")


@pytest.mark.parametrize("argv, background, ends", [
    (["blender", "-b", "f.blend", "--python", SCRIPT, "--", "compare"], True, True),
    (["blender", "-b", "f.blend", "--python-exit-code", "1", "-P", SCRIPT, "--", "x"], True,
     True),
    (["blender", "-b", "f.blend", "--python", SCRIPT, "--python-exit-code", "1", "--", "x"],
     True, True),
    (["blender", "-b", "f.blend", "--python", SCRIPT], True, True),
    (["blender", "-b", "f.blend", "--python", "other.py", "--", "x"], True, False),
    # Blender goes on: its UI, or arguments after the script
    (["blender", "f.blend", "--python", SCRIPT, "--", "compare"], False, False),
    (["blender", "-b", "f.blend", "--python", SCRIPT, "--render-frame", "1", "--", "c"], True,
     False),
    (["blender", "-b", "f.blend", "--python", SCRIPT, "--python", "post.py", "--", "c"], True,
     False),
])
def test_blender_exits_next(argv, background, ends):
    assert CL.blender_exits_next(argv, background, SCRIPT) is ends


def _run_script(tmp_path, between):
    """blender_cli.py's compare run as Blender runs a --python script (the bpy module standing
    in for it), `between` the arguments between the script and `--`; then the process goes on
    as Blender would and sends itself SIGTERM. Returns (CompletedProcess, SIGTERM's handler
    after the script)."""
    blend = tmp_path / "scene.blend"
    code = ("import bpy, sys, runpy, signal, os, time\n"
            "from surfgrad_addon.harness import scenes as test_scenes\n"
            "test_scenes.new_scene(['Plane'])\n"
            f"bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})\n"
            f"sys.argv = ['blender', '-b', {str(blend)!r}, '--python', {SCRIPT!r}, "
            f"*{between!r}, '--', 'compare', '--object', 'Plane', '--method', 'normal-map', "
            f"'--resolution', '16', '--json', {str(tmp_path / 'r.json')!r}]\n"
            f"runpy.run_path({SCRIPT!r})\n"
            "print('HANDLER', signal.getsignal(signal.SIGTERM) == signal.SIG_IGN, flush=True)\n"
            "os.kill(os.getpid(), signal.SIGTERM)\n"
            "time.sleep(2)\n"
            "print('WENT ON', flush=True)\n")
    out = run_python(["-c", code], cwd=tmp_path)
    return out, json.loads((tmp_path / "r.json").read_text())


def test_blender_going_on_after_the_script_can_still_be_stopped(tmp_path):
    out, report = _run_script(tmp_path, ["--render-frame", "1"])
    assert report["object"] == "Plane"                # the command ran
    assert "HANDLER False" in out.stdout, out.stdout[-2000:] + out.stderr[-2000:]
    assert "WENT ON" not in out.stdout
    assert out.returncode == -signal.SIGTERM, (out.returncode, out.stderr[-2000:])


def test_blender_exiting_after_the_script_ignores_a_late_stop(tmp_path):
    """rt59d's case kept: the script last under -b, Blender exits next."""
    out, report = _run_script(tmp_path, [])
    assert "HANDLER True" in out.stdout, out.stdout[-2000:] + out.stderr[-2000:]
    assert "WENT ON" in out.stdout and out.returncode == 0
