"""How many threads the reference's parallel passes use (the block evaluation, the banded
rasteriser)."""

import os


def reference_threads():
    """Threads that evaluate blocks at once: SURFGRAD_REFERENCE_THREADS, default the machine's
    cores (at most 8), as Cycles' bake uses them. numpy and the compiled kernels release the
    GIL inside their loops, so blocks run in parallel; results are identical for any count
    (tests/test_fast_reference.py). A farm running one process per core sets it to 1."""
    value = os.environ.get("SURFGRAD_REFERENCE_THREADS", "").strip()
    if not value:
        return max(1, min(8, os.cpu_count() or 1))
    try:
        return max(1, int(value))
    except ValueError:
        raise ValueError(f"SURFGRAD_REFERENCE_THREADS must be a whole number, got {value!r}")
