"""Blender's bake operator prints "Info: Baking map saved to internal image, save it
externally or pack it" on every bake, which reads as if nothing was saved: surfgrad saves the
map itself. `quiet_bake()` holds the process's stdout (file descriptor 1, where Blender's C
code prints) for the length of one bake and passes every other line on afterwards, so no
message but that one is lost."""

import os
import sys
import tempfile
from contextlib import contextmanager

# Blender's own notes about the internal image; surfgrad writes or reports the file itself.
NOISE = ("Info: Baking map saved to internal image",)


@contextmanager
def quiet_bake():
    """Drop NOISE lines that C code prints to stdout inside the block; keep everything else
    (written out, in order, when the block ends, also when it raises)."""
    try:
        fd = sys.__stdout__.fileno() if sys.__stdout__ is not None else 1
        saved = os.dup(fd)
    except (OSError, ValueError, AttributeError):
        yield                      # no real stdout to hold (an embedded console): say all
        return
    with tempfile.TemporaryFile() as held:
        sys.stdout.flush()
        os.dup2(held.fileno(), fd)
        try:
            yield
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
