"""Red team 58a: a skeptical review of what was merged into main since a0230c3 (rt56c, rt57a,
rt57b, rt57c, rt57d and the coordinator's changes).

1. bpy that is there but will not load. rt57a refused a Python without bpy with the fix
   (command_line._no_bpy_problem asks importlib's find_spec), but a bpy wheel that is
   installed and cannot load (a system library it links missing, as on a bare CUDA container
   or farm node: tools/gpu_bundle.sh notes an H100 image with libX11 alone; "ImportError:
   libXi.so.6: cannot open shared object file") passed that check and then ended in a raw
   ImportError traceback out of interrupts._load_blender, exit 1, for bake-normal-map,
   bake-batch, compare and compare-all alike (measured on 5.2 with a bpy that raises that
   ImportError: 4 of 4 commands, exit 1, "Traceback" on stderr). Now each says in one line
   that it could not load bpy, the loader's words (the library named) and the fix, exit 2
   (BAD_REQUEST, as for no bpy at all), nothing written (command_line._unloadable).
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from surfgrad_addon.addon import exit_codes

pytestmark = pytest.mark.tier("child")

ROOT = Path(__file__).resolve().parents[1]


# Finding 1: bpy there, but it will not load ---------------------------------------------------

_BROKEN_BPY = ('raise ImportError("libXi.so.6: cannot open shared object file: No such file '
               'or directory", name="bpy")\n')


def _args(command, tmp_path):
    blend = str(tmp_path / "a.blend")
    return {"bake-normal-map": ["--blend", blend, "--object", "Plane", "--output",
                                str(tmp_path / "n.png")],
            "bake-batch": [blend, "--output", str(tmp_path / "maps" / "{object}.png")],
            "compare": ["--blend", blend, "--object", "Plane", "--method", "normal-map",
                        "--json", str(tmp_path / "r.json")],
            "compare-all": ["--out", str(tmp_path / "all")]}[command]


@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch", "compare", "compare-all"])
def test_a_bpy_that_will_not_load_is_told_so_not_a_traceback(command, tmp_path):
    broken = tmp_path / "site" / "bpy"
    broken.mkdir(parents=True)
    (broken / "__init__.py").write_text(_BROKEN_BPY)
    work = tmp_path / "work"
    work.mkdir()
    (work / "a.blend").write_bytes(b"BLENDER")
    # (a package first on the path: it stands in for the installed wheel, found by find_spec)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path / "site"), str(ROOT)])}
    run = subprocess.run([sys.executable, "-m", "surfgrad_addon", command,
                          *_args(command, work)], cwd=work, env=env, capture_output=True,
                         text=True, timeout=120)
    # Before: exit 1, a raw "Traceback ... ImportError: libXi.so.6: ..." on stderr.
    assert run.returncode == exit_codes.BAD_REQUEST == 2, (run.returncode, run.stderr)
    assert "Traceback" not in run.stderr + run.stdout, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert line.startswith(f"surfgrad: error: {command} could not load Blender's Python "
                           f"module bpy on this Python ("), line
    assert "libXi.so.6: cannot open shared object file" in line, line
    assert "install what it names" in line and "bpy wheel" in line, line
    # The extension's own commands can run inside Blender; the harness's cannot.
    assert ("blender -c surfgrad" in line) == command.startswith("bake-"), line
    assert sorted(p.name for p in work.iterdir()) == ["a.blend"]
