"""run.sh, the README's two commands, on a machine that is not ours: venvs half made, pip
failing, LINES picked badly, Ctrl-C in the middle. run.sh runs in a sandbox (a copy of it, the
real tools/lines_summary.py) with stub interpreters in place of Python and the venvs, so nothing
is installed and each run takes a fraction of a second. Red team 38a; SIGTERM to bash alone
and the terminal's LINES, red team 39b."""

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.tier("child")

ROOT = Path(__file__).resolve().parents[1]
VENVS = {"5.2": ".venv", "5.0": ".venv-bpy50"}

# A venv's python: logs its arguments; pip's exit status comes from pip-rc, and an install
# that succeeds puts the requirements' bpy pin in bpy-version (unless pip-keeps-bpy exists),
# which the metadata query prints; `import pip` works only where pip-ok exists, pytest runs
# pytest.py where there is one; anything else (the summary) goes to the real interpreter.
_VENV_PYTHON = """#!/bin/bash
here=$(cd "$(dirname "$0")/.." && pwd)
echo "$*" >> "$here/calls.log"
case "$1 $2" in
  "-c import pip") [ -e "$here/pip-ok" ]; exit ;;
  "-c "*version_info*) exit 0 ;;
  "-c "*importlib.metadata*) cat "$here/bpy-version" 2>/dev/null; exit ;;
  "-m pip") [ -e "$here/pip.py" ] && exec {real} "$here/pip.py"
            rc=$(cat "$here/pip-rc" 2>/dev/null || echo 0)
            [ "$rc$5" = 0-r ] && [ ! -e "$here/pip-keeps-bpy" ] &&
              sed -n 's/^bpy==\\([^ #]*\\).*/\\1/p' "$6" > "$here/bpy-version"
            exit "$rc" ;;
  "-m pytest") [ -e "$here/pytest.py" ] && exec {real} "$here/pytest.py"; exit 0 ;;
esac
exec {real} "$@"
"""

# The base Python (PYTHON / PYTHON311): passes the version check and makes stub venvs (or,
# where venv-fails exists, half of one and fails, as Debian's Python without python3-venv).
_BASE_PYTHON = """#!/bin/bash
echo "$*" >> "$(dirname "$0")/base.log"
case "$1 $2" in
  "-c "*) exit 0 ;;
  "-m venv") mkdir -p "$3/bin" && cp "$(dirname "$0")/venv-python" "$3/bin/python" &&
             [ ! -e "$(dirname "$0")/venv-fails" ] && touch "$3/pip-ok" ;;
esac
"""


@pytest.fixture
def sandbox(tmp_path):
    box = tmp_path / "check out"                      # a space in the checkout's path
    (box / "tools").mkdir(parents=True)
    shutil.copy(ROOT / "run.sh", box)
    shutil.copy(ROOT / "tools" / "lines_summary.py", box / "tools")
    for name in ("install_eevee_deps.sh", "install_chromium.sh"):
        (box / "tools" / name).write_text("exit 0\n")
    for line, pin in (("", "5.2.3"), ("-5.0", "5.0.1"), ("-4.5", "4.5.15"), ("-4.2", "4.2.23")):
        (box / f"requirements{line}.txt").write_text(f"bpy=={pin}    # a comment\npytest\n")
    stubs = tmp_path / "stubs"
    stubs.mkdir()
    (stubs / "venv-python").write_text(_VENV_PYTHON.format(real=sys.executable))
    (stubs / "python").write_text(_BASE_PYTHON)
    for f in stubs.iterdir():
        f.chmod(0o755)
    return box


PINS = {"5.2": "5.2.3", "5.0": "5.0.1"}
REQS = {"5.2": "requirements.txt", "5.0": "requirements-5.0.txt"}


def _venv(box, line, stamp_of=None):
    """A finished stub venv for `line` with its pinned bpy, its stamp that of `stamp_of` (a
    requirements text; by default the sandbox's requirements file of that line)."""
    venv = box / VENVS[line]
    (venv / "bin").mkdir(parents=True)
    shutil.copy(box.parent / "stubs" / "venv-python", venv / "bin" / "python")
    (venv / "pip-ok").touch()
    (venv / "bpy-version").write_text(PINS[line] + "\n")
    text = stamp_of if stamp_of is not None else (box / REQS[line]).read_text()
    (venv / ".requirements.sha256").write_text(hashlib.sha256(text.encode()).hexdigest())
    return venv


def _run(box, *args, lines=None, env_more=None, **popen):
    env = {**os.environ, "PYTHON": str(box.parent / "stubs" / "python"),
           "PYTHON311": str(box.parent / "stubs" / "python"),
           "PYENV_ROOT": str(box.parent / "no-pyenv")}
    env.pop("LINES", None)
    env.pop("SURFGRAD_LINES", None)
    if lines is not None:
        env["LINES"] = lines
    env.update(env_more or {})
    return subprocess.Popen(["bash", str(box / "run.sh"), *args], cwd=box.parent, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **popen)


def _done(box, *args, lines=None, env_more=None):
    proc = _run(box, *args, lines=lines, env_more=env_more)
    out, _ = proc.communicate(timeout=60)
    return proc.returncode, out


def _calls(venv):
    log = venv / "calls.log"
    return log.read_text().splitlines() if log.exists() else []


def test_a_failed_install_fails_the_command_and_is_retried(sandbox):
    """Before: pip's failure was ignored (set -e does not hold in $(...)), the new stamp was
    written and the suite ran against the bpy the venv already had: exit 0, and every later run
    skipped the install."""
    venv = _venv(sandbox, "5.2", stamp_of="bpy==old\n")
    (venv / "pip-rc").write_text("1")
    stamp = (venv / ".requirements.sha256").read_text()
    for args in (("test",), ("main",)):
        rc, out = _done(sandbox, *args, lines="5.2")
        assert rc != 0, out
        assert "installing requirements.txt into .venv failed" in out, out
    assert not any("pytest" in c or "demo" in c for c in _calls(venv)), _calls(venv)
    assert (venv / ".requirements.sha256").read_text() == stamp
    assert _calls(venv).count("-m pip install --quiet -r requirements.txt") == 2  # retried


def test_an_unfinished_venv_is_made_anew(sandbox):
    """`python -m venv` interrupted before pip was in: before, the venv was reused, its pip
    install failed on every run (and, the failure ignored, the suite ran without bpy)."""
    venv = _venv(sandbox, "5.2")
    (venv / "pip-ok").unlink()
    rc, out = _done(sandbox, "test", lines="5.2")
    assert rc == 0, out
    assert ".venv is unfinished" in out, out
    base = (sandbox.parent / "stubs" / "base.log").read_text().splitlines()
    assert base[-1] == "-m venv .venv", base
    assert (venv / "pip-ok").exists() and (venv / ".requirements.sha256").exists()
    assert _calls(venv)[-2:] == ["-m pytest", "tools/lines_summary.py out/lines 5.2"]


@pytest.mark.parametrize("lines", ["5.2 4.3", " ", "5.2,5.0"])
def test_lines_are_checked_before_any_line_runs(sandbox, lines):
    """Before: an unknown line was refused only when the loop reached it (after the lines
    before it had run their whole suite), and LINES=" " ran nothing and exited 0."""
    venv = _venv(sandbox, "5.2")
    rc, out = _done(sandbox, "test", lines=lines)
    assert rc == 2, out
    assert "LINES" in out and "5.2 5.0 4.5 4.2" in out, out
    assert _calls(venv) == []
    assert not (sandbox / "out").exists()


def test_a_line_asked_twice_runs_once_and_the_summary_needs_no_main_venv(sandbox):
    """LINES=5.0 on a machine without the 5.2 venv: before, the summary was run with
    .venv/bin/python, which did not exist: exit 1 after the line passed."""
    venv = _venv(sandbox, "5.0")
    rc, out = _done(sandbox, "test", "-k", "a b", lines="5.0 5.0")
    assert rc == 0, out
    assert [c for c in _calls(venv) if "pytest" in c] == ["-m pytest -k a b"]
    assert "lines: 1 passed, 0 failed" in out, out
    assert not (sandbox / ".venv").exists()


def _as_in_a_terminal():
    """A terminal's Ctrl-C reaches a command whose SIGINT is not ignored; a suite started in
    the background of a non-interactive shell inherits it ignored, which bash cannot undo."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGQUIT, signal.SIG_DFL)


def _interrupt_when_started(proc, started):
    """Ctrl-C in a terminal: SIGINT to the command's process group once `started` exists."""
    try:
        for _ in range(400):
            if started.exists():
                break
            time.sleep(0.05)
        assert started.exists()
        os.killpg(proc.pid, signal.SIGINT)
        out, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    return out


_SLEEPER = ("import pathlib, sys, time\n"
            "pathlib.Path({started!r}).touch()\n"
            "try:\n    time.sleep(60)\nexcept KeyboardInterrupt:\n    sys.exit({rc})\n")


def test_ctrl_c_during_an_install_stops_it(sandbox):
    """pip ends on Ctrl-C with exit 1; the failed pip upgrade is not fatal (offline), so before
    the install of the requirements started next, and the lines after it."""
    first = _venv(sandbox, "5.2", stamp_of="bpy==old\n")
    second = _venv(sandbox, "5.0")
    started = sandbox / "started"
    (first / "pip.py").write_text(_SLEEPER.format(started=str(started), rc=1))
    proc = _run(sandbox, "test", lines="5.2 5.0", start_new_session=True,
                preexec_fn=_as_in_a_terminal)
    out = _interrupt_when_started(proc, started)
    assert proc.returncode == 130, out
    assert "interrupted" in out, out
    assert [c for c in _calls(first) if c.startswith("-m pip")] == [
        "-m pip install --quiet --upgrade pip"]
    assert _calls(second) == [], out


def test_ctrl_c_stops_the_lines_that_follow(sandbox):
    """pytest ends on Ctrl-C with exit 2, not by the signal, so bash went on to the next line:
    before, each Ctrl-C stopped one line and the next one started. The last run's summary is
    not left to look like this run's."""
    first = _venv(sandbox, "5.2")
    second = _venv(sandbox, "5.0")
    started = sandbox / "started"
    (sandbox / "out" / "lines").mkdir(parents=True)
    (sandbox / "out" / "lines" / "summary.md").write_text("| 5.2 | 5.2.3 | passed | 600 |\n")
    (first / "pytest.py").write_text(_SLEEPER.format(started=str(started), rc=2))
    proc = _run(sandbox, "test", lines="5.2 5.0", start_new_session=True,
                preexec_fn=_as_in_a_terminal)
    out = _interrupt_when_started(proc, started)
    assert proc.returncode == 130, out
    assert "interrupted" in out, out
    assert _calls(second) == [], out
    assert list((sandbox / "out" / "lines").iterdir()) == []


def test_no_interpreter_found_is_one_message_and_no_venv(sandbox):
    """PYTHON at a Python of another version, none of 3.13 on PATH or under pyenv. Before:
    the failure was ignored inside $(...), `"" -m venv .venv` and pip ran, then exec of a
    missing .venv/bin/python: exit 127 after five 'not found' errors. PYTHON is also named when
    it is passed over."""
    tools = sandbox.parent / "path"
    tools.mkdir()
    for name in ("bash", "sha256sum", "cut", "cat", "grep", "rm", "mkdir", "dirname"):
        (tools / name).symlink_to(shutil.which(name))
    wrong = sandbox.parent / "stubs" / "python3.11"
    wrong.write_text("#!/bin/bash\nexit 1\n")                 # fails the version check
    wrong.chmod(0o755)
    env = {"PATH": str(tools), "PYTHON": str(wrong), "PYENV_ROOT": str(sandbox.parent / "none"),
           "HOME": str(sandbox.parent)}
    res = subprocess.run([str(tools / "bash"), str(sandbox / "run.sh"), "main"], env=env,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 1, res.stderr
    assert res.stderr.splitlines() == [
        f"surfgrad: PYTHON={wrong} is not a Python 3.13 with its venv module; looking for one"
        " elsewhere",
        "surfgrad: Python 3.13 is needed (the bpy wheels of this line exist only for 3.13).",
        "  Install it with its venv module (e.g. 'pyenv install 3.13', or your system's"
        " python3.13 and python3.13-venv packages), or point PYTHON=/path/to/python3.13 at one."]
    assert sorted(p.name for p in sandbox.iterdir()) == [
        "requirements-4.2.txt", "requirements-4.5.txt", "requirements-5.0.txt",
        "requirements.txt", "run.sh", "tools"]


def test_a_line_killed_or_with_no_test_fails_the_command(sandbox):
    """A line whose pytest is killed (SIGKILL) and one that collects no test (pytest's exit 5)
    are each FAILED in the summary, and the command exits 1."""
    for line, body in (("5.2", "import os, signal\nos.kill(os.getpid(), signal.SIGKILL)\n"),
                       ("5.0", "import sys\nsys.exit(5)\n")):
        (_venv(sandbox, line) / "pytest.py").write_text(body)
    rc, out = _done(sandbox, "test", lines="5.2 5.0")
    assert rc == 1, out
    assert "Blender 5.2: FAILED (exit 137)" in out and "Blender 5.0: FAILED (exit 5)" in out
    assert "| 5.2 | ? | FAILED |" in out and "| 5.0 | ? | FAILED |" in out, out
    assert out.rstrip().endswith("lines: 0 passed, 2 failed"), out


def test_a_venv_whose_bpy_was_removed_or_replaced_is_installed_again(sandbox):
    """The stamp matches but bpy is gone (pip uninstall) or another version (pip install
    bpy==5.0.1 into the 5.2 venv). Before: the stamp was trusted and the suite ran; without bpy
    its bpy tests skip, and the line was reported passed. Now the install runs again; where it
    cannot give the pinned bpy, the line fails before its tests."""
    venv = _venv(sandbox, "5.2")
    for before in (None, "5.0.1"):
        if before is None:
            (venv / "bpy-version").unlink()
        else:
            (venv / "bpy-version").write_text(before + "\n")
        (venv / "calls.log").unlink(missing_ok=True)
        rc, out = _done(sandbox, "test", lines="5.2")
        assert rc == 0, out
        assert "-m pip install --quiet -r requirements.txt" in _calls(venv), out
        assert (venv / "bpy-version").read_text() == "5.2.3\n"
    (venv / "bpy-version").write_text("5.0.1\n")
    (sandbox / "requirements.txt").write_text("bpy==5.2.3\npytest\n")   # same pin, new text
    (venv / "pip-keeps-bpy").touch()                   # an install that leaves bpy as it is
    (venv / "calls.log").unlink()
    rc, out = _done(sandbox, "test", lines="5.2")
    assert rc == 1, out
    assert ".venv has bpy '5.0.1' after installing requirements.txt, which pins 5.2.3" in out
    assert "-m pytest" not in _calls(venv)


def test_a_venv_that_cannot_be_made_is_one_message_and_no_venv(sandbox):
    """`python -m venv` fails after making the folder (Debian's Python without its venv
    package: ensurepip missing). Before: the failure was ignored, pip and the suite ran in the
    half venv and the next runs reused it."""
    (sandbox.parent / "stubs" / "venv-fails").touch()
    rc, out = _done(sandbox, "test", lines="5.0")
    assert rc == 1, out
    assert "'" + str(sandbox.parent / "stubs" / "python") + " -m venv .venv-bpy50' failed" in out
    assert "point PYTHON311 at another" in out, out
    assert not (sandbox / ".venv-bpy50").exists()


def test_sigterm_to_bash_alone_stops_the_running_pytest(sandbox):
    """A farm's or CI runner's cancel sends SIGTERM to bash alone: before, bash ended at once
    (killed by the signal) and left the line's pytest running to its end, orphaned. Now pytest
    is stopped with it, the lines after it do not run, and the exit status is 143."""
    first = _venv(sandbox, "5.2")
    second = _venv(sandbox, "5.0")
    started = sandbox / "started"
    (first / "pytest.py").write_text(
        "import os, pathlib, time\n"
        f"pathlib.Path({str(started)!r}).write_text(str(os.getpid()))\n"
        "time.sleep(60)\n")
    proc = _run(sandbox, "test", lines="5.2 5.0", start_new_session=True,
                preexec_fn=_as_in_a_terminal)
    pid = None
    try:
        for _ in range(400):
            if started.exists() and started.read_text():
                break
            time.sleep(0.05)
        pid = int(started.read_text())
        os.kill(proc.pid, signal.SIGTERM)             # bash alone, not its process group
        out, _ = proc.communicate(timeout=30)
        assert proc.returncode == 143, out
        assert "terminated" in out, out
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)                           # pytest is gone (and reaped)
        assert _calls(second) == [], out
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        if pid is not None:
            try:
                os.kill(pid, signal.SIGKILL)          # the orphan, where it was left
            except ProcessLookupError:
                pass


def test_the_terminals_lines_variable_is_not_taken_for_blender_lines(sandbox):
    """Shells that export LINES (the terminal's height, a number: POSIX) made run.sh refuse to
    run: "unknown line 50 in LINES", exit 2. SURFGRAD_LINES names the lines and comes first;
    LINES still does where it holds line names."""
    venvs = {line: _venv(sandbox, line) for line in ("5.2", "5.0")}

    def ran(line):
        return [c for c in _calls(venvs[line]) if c.startswith("-m pytest")]

    rc, out = _done(sandbox, "test", lines="50", env_more={"SURFGRAD_LINES": "5.0"})
    assert rc == 0, out
    assert (ran("5.2"), ran("5.0")) == ([], ["-m pytest"]), out
    rc, out = _done(sandbox, "test", lines="5.2")          # the documented LINES still works
    assert rc == 0, out
    assert (ran("5.2"), ran("5.0")) == (["-m pytest"], ["-m pytest"]), out
    rc, out = _done(sandbox, "test", env_more={"SURFGRAD_LINES": "5.2,5.0"})
    assert rc == 2 and "unknown line 5.2,5.0 in SURFGRAD_LINES" in out, out
    rc, out = _done(sandbox, "test", lines="", env_more={"SURFGRAD_LINES": ""})  # as unset
    assert rc == 0 and "lines: 4 passed, 0 failed" in out, out
    rc, out = _done(sandbox, "test", lines=" 50 ")           # the terminal's: every line
    assert rc == 0, out
    assert "lines: 4 passed, 0 failed" in out, out
    assert (ran("5.2"), ran("5.0")) == (["-m pytest"] * 3, ["-m pytest"] * 3), out
