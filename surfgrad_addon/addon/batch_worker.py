"""One batch worker process (started by batch.Pool with Blender or the bpy module): reads
requests, one JSON object a line, on stdin; does each in this session (batch.run_request:
scan a .blend, or open it and bake one asset); writes each reply as one line starting with
batch.RESULT_MARK on stdout. Anything else on stdout is the worker's log. Ends at end of input."""

import json
import sys

from . import batch, interrupts


def _reply(data):
    sys.stdout.write(batch.RESULT_MARK + json.dumps(data) + "\n")
    sys.stdout.flush()


def main():
    import bpy  # noqa: F401 - loaded before "ready": the process start includes it
    _reply({"op": "ready"})
    # SIGTERM / SIGINT sent to this worker: its temporary files go, exit 143 / 130 (the batch
    # then fails that asset without a retry); the batch itself stops workers with SIGKILL.
    with interrupts.stoppable("the worker"):
        for line in sys.stdin:
            line = line.strip()
            if not line:
                continue
            request = json.loads(line)
            _reply(batch.run_request(request, log=lambda *a: print(*a, flush=True)))
    return 0
