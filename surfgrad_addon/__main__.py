"""`python -m surfgrad_addon ...`: the proving harness's command line (harness/cli.py), from a
checkout. Not part of the extension zip."""

import codecs
import os
import signal
import sys


def _started_as_this_module():
    """True when this process is `python [options] -m surfgrad_addon ...` itself (its command
    line, sys.orig_argv, read as CPython reads its options), not a script or `-c` that runs
    this module through runpy: starting that process again would run the script again."""
    args = iter(getattr(sys, "orig_argv", [])[1:])
    for arg in args:
        if arg == "--check-hash-based-pycs":
            next(args, None)
            continue
        if not arg.startswith("-") or arg in ("-", "--"):
            return False                        # a script, stdin
        if arg.startswith("--"):
            continue
        for i, flag in enumerate(arg[1:], 2):   # short options, several in one ("-Im")
            if flag in "cmWX":                  # takes a value: the rest, else the next one
                value = arg[i:] or next(args, "")
                if flag in "cm":
                    return flag == "m" and value in ("surfgrad_addon", __spec__.name)
                break
    return False


# An ASCII locale (LC_ALL=C or POSIX with Python's UTF-8 mode turned off): Blender's names and
# paths are UTF-8, and an object named 'ü' could neither be printed nor made a path ('ascii'
# codec can't encode, exit 2; a batch's asset failed), a UTF-8 --object was refused as "not
# UTF-8". Blender's own Python always runs in UTF-8 mode; so does this command, started again
# in it (its workers inherit it), when it is the process's own command.
_ASCII = os.name == "posix" and codecs.lookup(sys.getfilesystemencoding()).name == "ascii" \
    and os.environ.get("PYTHONUTF8") != "1"
if _ASCII and _started_as_this_module():
    os.environ["PYTHONUTF8"] = "1"
    os.execv(sys.executable, [sys.executable, *sys.orig_argv[1:]])

# Closed stdout / stderr / stdin (`>&-`): before anything opens a file on their descriptors;
# a strict stdout made tolerant (paths that are not UTF-8).
from .addon.std_streams import prepare
prepare()
if _ASCII and sys.stderr is not None:
    print("surfgrad: warning: this Python runs in an ASCII locale, so names and paths that are "
          "not ASCII fail; run it in UTF-8 mode (PYTHONUTF8=1 or python -X utf8) or a UTF-8 "
          "locale (LC_ALL=C.UTF-8)", file=sys.stderr, flush=True)

# numpy asks the kernel for transparent huge pages for its large arrays (madvise). Where the
# kernel compacts memory to find them (THP defrag "madvise", as on the development machine),
# each large array allocated after a bake stalled: compare's first 32 MB took 0.07 s instead
# of 0.015 s, about 0.2 s of a 2048^2 compare in all (measured on 5.2). numpy reads this at
# import, so it is set before anything imports it; a value the user set stays.
os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")

# Ctrl-C is held while the modules load: a KeyboardInterrupt raised inside a C extension's
# import of numpy (numba's) is printed and swallowed there, and the command then ran to the
# end with exit 0 (seen on 4.5). Let go once they are loaded, a pending Ctrl-C stops here.
# SIGTERM is held too: its default action ended the process with no line (exit 143) before
# the command's own stop was in place (red team 43a); one that came meanwhile is said here.
_HOLD = hasattr(signal, "pthread_sigmask")
_HELD = {signal.SIGINT, signal.SIGTERM}
if _HOLD:
    signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)

try:
    from .addon.command_line import leave
    from .harness.cli import main
    if _HOLD and signal.SIGTERM in signal.sigpending():
        print("surfgrad: terminated by SIGTERM before the command began: nothing was done; "
              "exit code 143", file=sys.stderr, flush=True)
        os._exit(143)
    if _HOLD:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _HELD)
    code = leave(main())
except KeyboardInterrupt:
    # Ctrl-C outside a command's own stop (interrupts.stoppable): while the modules load
    # (held until then) or before the stop is in place; nothing is written yet. One line.
    print("surfgrad: interrupted by SIGINT: stopped; exit code 130", file=sys.stderr,
          flush=True)
    code = 130
sys.exit(code)
