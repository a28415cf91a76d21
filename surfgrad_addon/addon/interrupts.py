"""Ctrl-C (SIGINT) and SIGTERM for the pipeline commands: bake-normal-map, bake-batch and its
worker processes stop within about a second, exit 130 (SIGINT) or 143 (SIGTERM), leave no
output, no temporary file and no process behind, and print one line, no traceback.

Why not KeyboardInterrupt: a bake is one blocking call into Cycles, and Python runs a signal
handler only between bytecodes; the KeyboardInterrupt then surfaces inside Cycles' own Python
bake callback, where Blender logs it and goes on to finish the bake (the file is written,
exit 0). So the handler here raises nothing: Python's C-level handler also writes the
signal number to a wake-up pipe (signal.set_wakeup_fd), a watcher thread reading that pipe
runs the registered clean-ups (kill worker process groups, remove temporary files, record
unfinished assets in the manifest) and ends the process with os._exit(128 + signal). Cycles
releases the GIL while it bakes, so the watcher runs at once; a call that holds the GIL
(loading a .blend, saving an image) delays it until that call returns.

The clean-ups must not race the command: the Python-level handler parks the main thread for
good at its next Python step (the watcher waits for that, at most PARK_WAIT_S, and not at all
while the main thread is inside a bake: `native_call()`), so nothing the command would write
next can appear behind them. Files a command puts in place are written inside `committing()`
and recorded with `placed()`: a block under way ends before the main thread parks (the
clean-ups see all of it, never half), and the stop then removes the placed files (exit
non-zero: no file). A batch keeps what it placed (keep_placed): its manifest records those
assets as baked.

Only command-line entry points install this (stoppable); the Python API and the operators
leave the session's own signal handling alone.
"""

import os
import re
import secrets
import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path

SIGNALS = (signal.SIGINT, signal.SIGTERM)
# Signals a terminal or a farm sends whose default action ends the process at once, leaving
# a map's temporary file, Blender's session folder and an unrecorded manifest: SIGHUP (the
# terminal closed), SIGQUIT (Ctrl+Backslash), SIGUSR1 / SIGUSR2 (a scheduler's notice before it
# kills or suspends: Slurm's --signal, SGE's -notify), SIGXCPU (the soft CPU time limit:
# `ulimit -S -t`, SGE's s_cpu; its default action dumps core). They stop as SIGTERM does, exit
# 128 + n; one this process inherited as ignored (nohup's SIGHUP) stays ignored.
OTHER_SIGNALS = tuple(getattr(signal, n) for n in ("SIGHUP", "SIGQUIT", "SIGUSR1", "SIGUSR2",
                                                   "SIGXCPU") if hasattr(signal, n))
CPU_LIMIT = getattr(signal, "SIGXCPU", None)
# The program reading our output (`| head`, a log collector) has gone: Python ignores SIGPIPE
# and raises BrokenPipeError at the next progress line instead, a traceback that ended a batch
# midway (from a pool thread) with its unfinished assets unrecorded. output_closed() stops as
# a SIGPIPE would (exit 141). The signal itself stays ignored: it also comes with a write to a
# worker that died, which the batch retries (workers.Worker.call), and must not stop the batch.
BROKEN_PIPE = getattr(signal, "SIGPIPE", None)
_WAKE_END = 0                               # byte that ends the watcher (no signal is 0)
_state = {"active": False, "what": "the command", "cleanups": [], "placed": [],
          "keep_placed": False, "caught": frozenset(int(s) for s in SIGNALS)}
_stopping = threading.Lock()
_committing = threading.RLock()
_stop_begun = threading.Event()
_main_parked = threading.Event()
_main = {"commits": 0, "park_pending": False, "native": 0}      # the main thread's state
COMMIT_WAIT_S = 30.0                        # a stop waits at most this long for a commit
PARK_WAIT_S = 2.0                           # and this long for the main thread to park


def exit_code(signum):
    """The shell's code for a process ended by `signum`: 130 for SIGINT, 143 for SIGTERM
    (129 SIGHUP, 131 SIGQUIT, 138 SIGUSR1, 140 SIGUSR2, 152 SIGXCPU)."""
    return 128 + int(signum)


def why(signum):
    """What a signal that does not say it itself means, as ' (...)' (or '')."""
    return {BROKEN_PIPE: " (the program reading its output ended)",
            CPU_LIMIT: " (its CPU time limit was reached: raise `ulimit -t` or the job's CPU "
                       "time limit)"}.get(signum, "")


def say(text):
    """One line on stderr, written straight to the descriptor (the watcher must not wait on a
    stream lock the main thread may hold)."""
    try:
        os.write(2, (text.rstrip("\n") + "\n").encode("utf-8", "replace"))
    except OSError:
        pass


@contextmanager
def stoppable(what="the command", keep_placed=False, load_blender=False):
    """Within this block SIGINT and SIGTERM (and OTHER_SIGNALS) stop the process cleanly (see
    the module's docstring). Only in the main thread (elsewhere signals cannot be handled: a
    no-op); a nested block keeps the outer one. keep_placed: a stop leaves the files placed().
    load_blender: import bpy first, with those signals held (_load_blender)."""
    if _state["active"] or threading.current_thread() is not threading.main_thread():
        yield
        return
    read_fd, write_fd = os.pipe()
    caught = SIGNALS + tuple(s for s in OTHER_SIGNALS
                             if signal.getsignal(s) is not signal.SIG_IGN)
    previous = {s: signal.getsignal(s) for s in caught}
    try:
        os.set_blocking(write_fd, False)
        old_fd = signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
    except (ValueError, OSError):               # Windows wants a socket: signals as before
        old_fd = None
    if old_fd is None:
        os.close(read_fd)
        os.close(write_fd)
        yield
        return
    for s in caught:
        signal.signal(s, _note)
    _state.update(active=True, what=what, placed=[], keep_placed=keep_placed,
                  caught=frozenset(int(s) for s in caught))
    held = load_blender and "bpy" not in sys.modules and hasattr(signal, "pthread_sigmask")
    if held:                    # before the watcher starts: it inherits the mask (see below)
        signal.pthread_sigmask(signal.SIG_BLOCK, caught)
    watcher = threading.Thread(target=_watch, args=(read_fd,), daemon=True,
                               name="surfgrad-interrupts")
    watcher.start()
    try:
        if held:
            _load_blender(caught)
        yield
    except BrokenPipeError:                      # our output's reader went (`| head`)
        output_closed()
        raise
    finally:
        _state.update(active=False, placed=[])   # first: a stop from here on waits for no park
        for s, handler in previous.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)
        signal.set_wakeup_fd(old_fd)
        try:
            os.write(write_fd, bytes([_WAKE_END]))
        except OSError:
            pass
        watcher.join(5)
        os.close(write_fd)
        os.close(read_fd)


def _load_blender(caught):
    """Import bpy with `caught` held (blocked in this thread, and in the watcher and Blender's
    threads, which inherit the mask), then let them go: one that came meanwhile stops the
    command now. Blender makes its session folder ($TMPDIR/blender_XXXXXX) early in bpy's
    import, then runs Python start-up code, where a stop parked the main thread before bpy was
    in sys.modules: its folder, found through bpy.app.tempdir, was left behind (red team 56c:
    a SIGTERM 0.8 to 1.1 s into `python -m surfgrad_addon bake-normal-map`, exit 143)."""
    try:
        import bpy  # noqa: F401
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, caught)


def _note(signum, frame):
    """The Python-level handler, run by the main thread at its next Python step: park it
    for good (the watcher ends the process; raising here would land inside Blender's
    callbacks), or at the end of the commit it is in."""
    if _main["commits"]:
        _main["park_pending"] = True
    else:
        _park()


def _park():
    _main_parked.set()
    while True:                 # a second signal runs _note in here, and parks again
        threading.Event().wait()


def _is_main():
    return threading.current_thread() is threading.main_thread()


@contextmanager
def native_call():
    """Around a long call into Blender that writes none of our files (a bake): a stop does
    not wait for the main thread to park (it parks when the call returns to Python)."""
    _main["native"] += _is_main()
    try:
        yield
    finally:
        _main["native"] -= _is_main()


def _watch(read_fd):
    while True:
        try:
            data = os.read(read_fd, 64)
        except OSError:
            return
        if not data:
            return
        for byte in data:
            if byte == _WAKE_END:
                return
            if byte in _state["caught"]:
                stop(byte)


def stop(signum):
    """Run the clean-ups (last registered first), say so, end the process."""
    if not _stopping.acquire(blocking=False):     # a second Ctrl-C while stopping
        return
    name = signal.Signals(signum).name
    # Held until os._exit: a commit under way ends first, and none starts after; then the
    # main thread is parked (or inside a bake), so the clean-ups race nothing.
    _stop_begun.set()
    _committing.acquire(timeout=COMMIT_WAIT_S)
    if _state["active"] and not _main["native"]:
        _main_parked.wait(PARK_WAIT_S)
    if not _state["keep_placed"]:
        remove_placed()
    for cleanup in reversed(list(_state["cleanups"])):
        try:
            cleanup(name)
        except Exception as err:                  # noqa: BLE001 - the stop goes on
            say(f"surfgrad: while stopping: {type(err).__name__}: {err}")
    try:
        sys.stdout.flush()
    except Exception:                             # noqa: BLE001
        pass
    remove_blender_tempdir()
    say(f"surfgrad: interrupted by {name}{why(signum)}: stopped {_state['what']}; exit code "
        f"{exit_code(signum)}")
    os._exit(exit_code(signum))


def ignore_at_exit():
    """For a process whose command has ended (its files written, its stop gone) and which
    exits next: SIGINT, SIGTERM and the others are ignored. Their default action ended it
    during Python's and Blender's exit (about 50 ms), by the signal (exit 143, no line), and
    left Blender's session folder ($TMPDIR/blender_XXXXXX) in about half of such runs, its
    removal at exit never reached: a farm's cancel that comes as a task ends. The process
    now ends with its command's code. Only in the main thread (elsewhere: as before)."""
    if threading.current_thread() is not threading.main_thread():
        return
    for s in SIGNALS + OTHER_SIGNALS:
        try:
            signal.signal(s, signal.SIG_IGN)
        except (OSError, ValueError):             # (one the platform does not let us set)
            pass


def remove_blender_tempdir():
    """os._exit skips Blender's own exit, which removes its session folder
    ($TMPDIR/blender_XXXXXX, bpy.app.tempdir): remove it here, but only a blender_* folder
    directly inside the system temp folder (never a user-set temp path)."""
    import shutil
    import tempfile
    bpy = sys.modules.get("bpy")
    try:
        folder = Path(bpy.app.tempdir) if bpy is not None else None
    except Exception:                             # noqa: BLE001 - bpy half torn down
        return None
    if folder is None or not str(folder).strip():
        return None
    try:
        system = Path(tempfile.gettempdir()).resolve()
        folder = folder.resolve()
    except OSError:
        return None
    if folder.parent != system or not folder.name.startswith("blender_") \
            or not folder.is_dir():
        return None
    shutil.rmtree(folder, ignore_errors=True)
    return folder


def output_closed():
    """Our output's reader went away (a BrokenPipeError on stdout or stderr): stop as a SIGPIPE
    would, exit 141, from whichever thread met it; a stop already under way ends the process
    instead. Outside a stoppable block: returns (the caller re-raises)."""
    if not _state["active"] or BROKEN_PIPE is None:
        return
    if _is_main():
        _main_parked.set()                  # the main thread runs the stop: nothing to wait for
    stop(int(BROKEN_PIPE))
    _park() if _is_main() else threading.Event().wait()    # another thread's stop ends us


@contextmanager
def committing():
    """Put finished files in place within this block: a stop waits for it to end (at most
    COMMIT_WAIT_S) before its clean-ups run, and once a stop began the block never starts."""
    main = _is_main()
    with _committing:
        if _stop_begun.is_set():               # the lock is not fair: this thread may win it
            _committing.release()              # back from the waiting stop; hand it over
            _park() if main else threading.Event().wait()
        _main["commits"] += main
        try:
            yield
        finally:
            _main["commits"] -= main
    if main and not _main["commits"] and (_main["park_pending"] or _stop_begun.is_set()):
        _park()                                # a signal came during the commit


def placed(path):
    """Record a file (or a folder) this command made: a stop before the command ends
    removes it, last made first, a folder only when empty (unless the stoppable block keeps
    them). Outside a stoppable block: nothing."""
    if _state["active"]:
        _state["placed"].append(Path(path))


def remove_placed():
    for path in reversed(_state["placed"]):
        try:
            path.rmdir() if path.is_dir() else path.unlink()
        except OSError:
            pass


@contextmanager
def on_stop(cleanup):
    """Run cleanup(signal_name) if the process is stopped within this block."""
    _state["cleanups"].append(cleanup)
    try:
        yield
    finally:
        _state["cleanups"].remove(cleanup)


# What makes this process's temporary file names its own beside a shared output: a process id
# alone is not (farm tasks in containers, each its own process-id space, run Blender under the
# same small id: two tasks baking one map wrote, published and removed each other's temporary
# file, red team 42b). A batch gives each worker its token (PART_TOKEN_ENV) to find its files.
PART_TOKEN_ENV = "SURFGRAD_PART_TOKEN"
PART_TOKEN_LENGTH = 8                       # hex digits


def new_part_token():
    return secrets.token_hex(PART_TOKEN_LENGTH // 2)


PART_TOKEN = os.environ.pop(PART_TOKEN_ENV, "") or new_part_token()


def partial_path(output, suffix=None):
    """The temporary file a bake of `output` (a Path) writes beside it before the rename:
    `.{stem}.part{pid}-{token}{suffix}`."""
    return output.parent / (f".{output.stem}.part{os.getpid()}-{PART_TOKEN}"
                            f"{output.suffix if suffix is None else suffix}")


def partial_pattern(output, pid, token=None):
    """A regex matching the temporary files a bake of `output` in process `pid` with `token`
    (this process's by default) writes (partial_path, with <UDIM> as the tile number, and the
    `.half` copy of a half-float EXR)."""
    stem = re.escape(Path(str(output)).stem).replace(re.escape("<UDIM>"), r"\d+")
    token = re.escape(PART_TOKEN if token is None else token)
    return re.compile(rf"\.{stem}\.part{int(pid)}-{token}\..+")


# Any process's temporary file (partial_path): `.{stem}.part{pid}-{token}{suffix}`
ANY_PARTIAL = re.compile(rf"\..+\.part\d+-[0-9a-f]{{{PART_TOKEN_LENGTH}}}\..+")


def others_partials(folder):
    """The names of temporary files in `folder` of bakes other than this process's: left by
    killed runs, or another run's under way (no process id tells which on a farm's share)."""
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    return sorted(n for n in names if ANY_PARTIAL.fullmatch(n) and
                  f".part{os.getpid()}-{PART_TOKEN}." not in n)


def remove_partials(output, pid, token=None):
    """Remove the temporary files of a bake of `output` by process `pid` (with `token`: this
    process's by default); returns them."""
    folder = Path(str(output)).parent
    pattern = partial_pattern(output, pid, token)
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for name in names:
        if pattern.fullmatch(name):
            try:
                (folder / name).unlink()
                removed.append(str(folder / name))
            except OSError:
                pass
    return removed


@contextmanager
def partials_of(output):
    """While baking `output` in this process: a stop removes its temporary files."""
    with on_stop(lambda _name: remove_partials(output, os.getpid())):
        yield
