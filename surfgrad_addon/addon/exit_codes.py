"""The exit codes of surfgrad's commands (bake-normal-map, bake-batch; `blender -c surfgrad` and
`python -m surfgrad_addon`), in one place so every entry point and the README say the same.

    0    done: every file asked for was written (or, in a batch, skipped as unchanged)
    1    a bake failed after it started (Cycles or the file write), or in bake-batch one or
         more assets failed (each named on stderr and in the manifest); the others were baked
    2    the request was refused before anything was baked: bad option or setting, missing
         or unreadable input (object, mesh, UV map, image), output that cannot be written.
         Nothing was written and the .blend is unchanged
    130  interrupted (SIGINT, Ctrl-C)
    143  terminated (SIGTERM)
    128 + n  stopped the same way by another signal n a terminal or a farm sends: 129 SIGHUP,
         131 SIGQUIT, 138 SIGUSR1, 140 SIGUSR2, 141 SIGPIPE (the program reading our output
         ended); an inherited ignore (nohup's SIGHUP) is kept
"""

OK = 0
BAKE_FAILED = 1
BAD_REQUEST = 2
INTERRUPTED = 130          # 128 + SIGINT
TERMINATED = 143           # 128 + SIGTERM


class BakeFailed(RuntimeError):
    """A bake that was accepted but did not complete (exit code BAKE_FAILED)."""


class MapNotWritten(BakeFailed):
    """The bake's map could not be written whole (a full disk, a file-size limit, a folder
    that no longer takes files): a fresh process would meet the same, so a batch does not
    retry it."""


def code_for(error):
    """The exit code for an exception that ends a command (its message is printed)."""
    if isinstance(error, BakeFailed):
        return BAKE_FAILED
    return BAD_REQUEST
