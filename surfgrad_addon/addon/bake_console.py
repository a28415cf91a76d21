"""Blender's bake operator prints "Info: Baking map saved to internal image, save it
externally or pack it" on every bake, which reads as if nothing was saved: surfgrad saves the
map itself. `quiet_bake()` holds the process's stdout (file descriptor 1, where Blender's C
code prints) for the length of one bake and passes every other line on afterwards, so no
message but that one is lost. A bake is one blocking call that reports no progress in the
background, so `heartbeat()` says how long it has run, every few seconds, from a thread (the
bake releases Python's lock while Cycles works)."""

import os
import sys
import tempfile
import threading
import time
from contextlib import contextmanager

# Blender's own notes about the internal image; surfgrad writes or reports the file itself.
NOISE = ("Info: Baking map saved to internal image",)


def _print_now(text):
    print(text, flush=True)


@contextmanager
def quiet_bake():
    """Drop NOISE lines that C code prints to stdout inside the block; keep everything else
    (written out, in order, when the block ends, also when it raises). Yields say(text),
    which prints a line to the real stdout at once (progress while the rest is held)."""
    try:
        fd = sys.__stdout__.fileno() if sys.__stdout__ is not None else 1
        saved = os.dup(fd)
    except (OSError, ValueError, AttributeError):
        yield _print_now           # no real stdout to hold (an embedded console): say all
        return

    def say(text):
        os.write(saved, (text + "\n").encode("utf-8"))

    with tempfile.TemporaryFile() as held:
        sys.stdout.flush()
        os.dup2(held.fileno(), fd)
        try:
            yield say
        finally:
            try:
                sys.stdout.flush()
            except (OSError, ValueError):
                pass
            os.dup2(saved, fd)
            os.close(saved)
            held.seek(0)
            kept = [line for line in held.read().decode("utf-8", "replace").splitlines(True)
                    if not line.startswith(NOISE)]
            if kept:
                os.write(fd, "".join(kept).encode("utf-8"))


# Seconds between heartbeat lines where a caller gives none.
HEARTBEAT_S = 15.0


@contextmanager
def heartbeat(say, what, every=None):
    """While the block runs, say(f"{what}: N s so far") every `every` seconds (HEARTBEAT_S
    when None; the first after `every`, so a short bake says nothing)."""
    every = HEARTBEAT_S if every is None else every
    stop = threading.Event()
    start = time.perf_counter()

    def beat():
        while not stop.wait(every):
            try:
                say(f"{what}: {time.perf_counter() - start:.0f} s so far")
            except OSError:
                return

    thread = threading.Thread(target=beat, name="surfgrad-heartbeat", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
