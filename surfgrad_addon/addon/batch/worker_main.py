"""One batch worker process, run as a file by workers.worker_command:

    blender -b --factory-startup --python-exit-code 1 --python worker_main.py   (a Blender)
    python -P worker_main.py                                      (the bpy module's Python)

It reads requests, one JSON object a line, on stdin; does each in this session
(session.run_request: scan a .blend, or open it and bake one asset); writes each reply as one
line starting with RESULT_MARK on stdout. Anything else on stdout is the worker's log. It ends
at the end of its input.

Run as a file, it is no module of a package yet: it loads the package it sits in from its
folder under a private name, so a checkout and an installed extension (whose package is named
by Blender, and is not enabled in a --factory-startup worker) both work. Imported as a module
(by workers.py, for RESULT_MARK and its path) it does nothing.
"""

import importlib
import importlib.util
import json
import sys
from pathlib import Path

RESULT_MARK = "@@surfgrad-batch "          # a worker's reply line (other output is its log)
TEMPDIR_PREFIX = "surfgrad-worker-"         # the temp folder the batch makes for each worker
OWN_TEMPDIR = "SURFGRAD_WORKER_TMPDIR"      # names it to the worker (also its TMPDIR)
# The batch's answer to a "pending" line when it could not record the files (then its reason).
UNRECORDED = "unrecorded "
PACKAGE = "_surfgrad_batch"                 # the name the worker loads surfgrad under
PACKAGE_ROOT = Path(__file__).resolve().parents[2]     # surfgrad's folder (its __init__.py)


def load_package(root=PACKAGE_ROOT, name=PACKAGE):
    """Import the package in folder `root` as `name` (its relative imports then resolve)."""
    spec = importlib.util.spec_from_file_location(name, Path(root) / "__init__.py",
                                                  submodule_search_locations=[str(root)])
    package = importlib.util.module_from_spec(spec)
    sys.modules[name] = package
    spec.loader.exec_module(package)
    return package


def reply(data):
    sys.stdout.write(RESULT_MARK + json.dumps(data) + "\n")
    sys.stdout.flush()


def announce(files):
    """Tell the batch the files this bake is about to put in place ({tile: (final, temporary
    file)}), and wait until it has recorded them (a "pending" reply, answered by one line): a
    batch killed in between then finds them recorded. No answer (the batch is gone): nothing
    is put in place; nor where the batch could not record them (its reason: MapNotWritten)."""
    reply({"op": "pending", "files": {str(t): [str(f), str(p)] for t, (f, p) in files.items()}})
    line = sys.stdin.readline()
    if line.startswith(UNRECORDED):
        exit_codes = importlib.import_module(f"{PACKAGE}.addon.exit_codes")
        raise exit_codes.MapNotWritten(json.loads(line[len(UNRECORDED):]))
    if not line.strip():
        raise RuntimeError("the batch ended before it recorded the map; nothing published")


def watch_parent(poll_s=0.5):
    """A batch killed with SIGKILL (a farm's hard kill, the OOM killer) cannot stop its
    workers, each in a process group of its own: the one baking would go on to the end of its
    bake, and write a map no manifest records. Once the parent is gone (this worker is
    re-parented) the worker sends itself SIGTERM: its temporary files go, it exits 143."""
    import os
    import signal
    import threading
    import time
    parent = os.getppid()

    def watch():
        while os.getppid() == parent:
            time.sleep(poll_s)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, daemon=True, name="surfgrad-parent-watch").start()


def remove_own_tempdir():
    """Remove the temp folder the batch made for this worker (workers.Worker), Blender's
    session folder in it included. The batch removes it once the worker has ended; a batch
    killed with SIGKILL cannot, so the worker does on its way out. Only that folder: the one
    OWN_TEMPDIR names, when it is also TMPDIR and a surfgrad-worker-* folder (never a temp
    folder a user set)."""
    import os
    import shutil
    own = os.environ.get(OWN_TEMPDIR, "")
    if not own or os.environ.get("TMPDIR") != own:
        return
    folder = Path(own)
    if folder.name.startswith(TEMPDIR_PREFIX) and folder.is_dir() and not folder.is_symlink():
        shutil.rmtree(folder, ignore_errors=True)


def serve(run_request, interrupts):
    """Answer requests from stdin until it ends; returns the exit code."""
    import bpy  # noqa: F401 - loaded before "ready": the process start includes it
    reply({"op": "ready"})
    # SIGTERM / SIGINT sent to this worker: its temporary files go, exit 143 / 130 (the batch
    # then fails that asset without a retry); the batch itself stops workers with SIGKILL.
    # The maps of earlier requests stay: the batch has recorded them as baked.
    # The folder's clean-up is registered outside the stop: a stop raised as an exception out
    # of the block (our reader gone: BrokenPipeError, interrupts.output_closed) runs after the
    # inner blocks have ended, and left the worker's empty folder in $TMPDIR (a batch killed
    # with SIGKILL while its workers baked: 7 of 8 runs).
    with interrupts.on_stop(lambda name: remove_own_tempdir()), \
            interrupts.stoppable("the worker", keep_placed=True):
        watch_parent()
        for line in sys.stdin:
            line = line.strip()
            if not line:
                continue
            reply(run_request(json.loads(line), log=lambda *a: print(*a, flush=True),
                              before_publish=announce))
    # Input ends when the batch is done with this worker, or died (its end of the pipe
    # closes before this process is re-parented, so getppid cannot tell which yet).
    remove_own_tempdir()
    return 0


def main():
    load_package()
    importlib.import_module(f"{PACKAGE}.addon.std_streams").prepare()   # non-UTF-8 paths
    session = importlib.import_module(f"{PACKAGE}.addon.batch.session")
    interrupts = importlib.import_module(f"{PACKAGE}.addon.interrupts")
    command_line = importlib.import_module(f"{PACKAGE}.addon.command_line")
    return command_line.leave(serve(session.run_request, interrupts))


if __name__ == "__main__":
    sys.exit(main())
