"""A command started with its standard output, error or input closed (`>&-`, `2>&-`, a daemon
or scheduler that closes them): Python then sets sys.stdout (or stderr) to None, and the first
progress line was an AttributeError traceback (exit 1, no map). Worse, the next file or pipe
the process opens takes the free descriptor 1 or 2, so what Blender's C code prints to its
stdout would land in that file. `reopen_closed()` points each closed descriptor at the null
device before anything else opens a file, and gives Python a stream on it: the command runs
and its lines go nowhere, as the caller asked.

A path whose bytes are not UTF-8 (a folder named on an old Latin-1 share) reaches Python as
surrogates; under a UTF-8 locale (en_US.UTF-8, a farm's usual one) stdout is strict, so the
line naming the map failed after the map was written (`can't encode character`),
exit 2, the file left in place. `tolerant_output()` makes stdout write such characters as
escapes (as stderr already does), the one stream that was strict."""

import os
import sys

_STREAMS = ((0, "stdin", "r"), (1, "stdout", "w"), (2, "stderr", "w"))


def reopen_closed():
    """Open the null device on each of descriptors 0, 1 and 2 that is closed, and on sys's
    stream for it where that is None. Returns the names of the streams reopened."""
    reopened = []
    for fd, name, mode in _STREAMS:
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDWR)
            if null != fd:                      # a lower descriptor was closed too: placed
                os.dup2(null, fd)
                os.close(null)
            reopened.append(name)
        if getattr(sys, name) is None:
            stream = open(fd, mode, encoding="utf-8", errors="replace", closefd=False)
            setattr(sys, name, stream)
            setattr(sys, f"__{name}__", stream)
    return reopened


def tolerant_output():
    """stdout (and stderr) that was strict writes what it cannot encode as backslash escapes
    instead of raising. Returns the names of the streams changed."""
    changed = []
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if getattr(stream, "errors", None) == "strict" and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
            changed.append(name)
    return changed


def prepare():
    """Both, at a command's start: closed streams reopened, strict output made tolerant."""
    reopen_closed()
    tolerant_output()
