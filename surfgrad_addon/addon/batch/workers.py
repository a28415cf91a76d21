"""Worker processes for the batch: each a Blender (or bpy-module) process in its own process
group running worker_main.py, one JSON request a line in and one marked reply line out; a
Pool of them with a timeout per request, one retry after a crash, and a stop that kills them
all. InProcess is the same interface in this session (workers = 0)."""

import json
import os
import queue
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from .. import interrupts
from ..exit_codes import MapNotWritten
from ..process_ends import how_it_ended
from . import worker_main
from .worker_main import OWN_TEMPDIR, RESULT_MARK, TEMPDIR_PREFIX
from .session import run_request


def worker_command():
    """The command that starts one worker, running worker_main.py as a file: Blender itself
    (-b --factory-startup) when this is a Blender binary, else this Python (the bpy module;
    -P: the file's folder is not put on sys.path)."""
    import bpy
    script = str(Path(worker_main.__file__).resolve())
    binary = getattr(bpy.app, "binary_path", "") or ""
    if binary and Path(binary).name.lower().startswith("blender") and Path(binary).is_file():
        # --python-exit-code: an uncaught Python error ends Blender non-zero (else 0)
        return [binary, "-b", "--factory-startup", "--python-exit-code", "1", "--python", script]
    return [sys.executable, "-P", script]


TIMED_OUT = "timed out"                     # Worker.call's answer when a request overran
STOP_CODES = {code: s.name + interrupts.why(s) for s in interrupts.SIGNALS +
              interrupts.OTHER_SIGNALS for code in (interrupts.exit_code(s), -int(s))}
# 130 / -2: "SIGINT", ...


class Worker:
    """One worker process: requests in on stdin, replies out on stdout (marked lines). It runs
    in its own process group (a terminal's Ctrl-C reaches the batch, which stops it), and a
    reader thread takes its output so that a request can time out."""

    def __init__(self, command, env=None):
        # Its own temp folder: Blender's session folder (TMPDIR/blender_XXXXXX) of a worker
        # that is killed (stop, timeout) is removed with it (interrupts.py).
        # A worker whose batch was killed removes it itself (worker_main.remove_own_tempdir).
        self.tempdir = tempfile.mkdtemp(prefix=TEMPDIR_PREFIX)
        env = dict(os.environ if env is None else env)
        env.update(TMPDIR=self.tempdir, TEMP=self.tempdir, TMP=self.tempdir)
        env[OWN_TEMPDIR] = self.tempdir
        self.part_token = env[interrupts.PART_TOKEN_ENV] = interrupts.new_part_token()
        self.proc = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, bufsize=1, env=env,
                                     # Blender prints paths as their bytes, not always UTF-8:
                                     # a strict decode ended the reader (the worker seemed dead)
                                     errors="replace",
                                     start_new_session=True)
        self.tail = []
        self.started = time.perf_counter()
        self.ready_s = None
        self.lines = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        try:
            for line in self.proc.stdout:
                self.lines.put(line)
        except (OSError, ValueError):
            pass
        self.lines.put(None)

    def call(self, request, timeout=None, on_pending=None):
        """Send a request and wait for its reply: None if the process died first, TIMED_OUT
        after `timeout` seconds (the process is left to the caller). A bake's "pending" line
        (worker_main.announce) is passed to on_pending({tile: (final, temporary file)}) and
        then answered: recorded, or why not (a str it returns: the worker fails the bake)."""
        try:
            self.proc.stdin.write(json.dumps(request) + "\n")
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError):
            return None
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=None if deadline is None else
                                      max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                return TIMED_OUT
            if line is None:
                return None
            if line.startswith(RESULT_MARK):
                reply = json.loads(line[len(RESULT_MARK):])
                if reply.get("op") == "ready":
                    self.ready_s = time.perf_counter() - self.started
                    continue
                if reply.get("op") == "pending":
                    answer = True if on_pending is None else \
                        on_pending({t: tuple(v) for t, v in reply["files"].items()})
                    if answer is False:
                        return None                 # (stopped: no answer, nothing published)
                    try:
                        self.proc.stdin.write(
                            f"{worker_main.UNRECORDED}{json.dumps(answer)}\n"
                            if isinstance(answer, str) else "recorded\n")
                        self.proc.stdin.flush()
                    except (BrokenPipeError, OSError):
                        return None
                    continue
                return reply
            self.tail = (self.tail + [line.rstrip()])[-15:]

    def kill(self):
        """End the process and everything in its group now."""
        if hasattr(os, "killpg"):                # POSIX; on Windows the process alone
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        try:
            self.proc.kill()
        except OSError:
            pass
        code = self.proc.wait()
        self.remove_tempdir()
        return code

    def remove_tempdir(self):
        """Remove the worker's temp folder once its process has ended."""
        if self.proc.poll() is not None:
            shutil.rmtree(self.tempdir, ignore_errors=True)

    def exit_code(self):
        try:
            code = self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            return self.kill()
        self.remove_tempdir()
        return code

    def close(self):
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
            self.exit_code()


class Pool:
    """`workers` worker threads, each driving one worker process (started when first needed,
    started anew after one dies). map() runs requests; a request whose worker died or which
    failed unexpectedly (kind "crash") is retried once in a fresh process. A request that
    overruns its "timeout" (seconds) has its worker killed and fails (kind "timeout"); a
    worker ended by SIGINT/SIGTERM from outside fails its request (kind "interrupted"); neither
    is retried. stop() kills every worker and removes its unfinished files."""

    def __init__(self, workers, command=None, env=None, retries=1):
        self.workers, self.command, self.env, self.retries = workers, command, env, retries
        self.procs = [None] * workers
        self.process_starts = []                  # seconds from spawn to ready, per process
        self.lock = threading.RLock()             # on_reply runs under it; so does stop()
        self.current = {}                         # slot -> (worker, request) in flight
        self.stopped = False

    def map(self, requests, on_reply, on_pending=None):
        """Run `requests`; on_reply(request, reply, retry) may return follow-up requests: the
        same thread runs the first next (its worker has that file open), the rest go first in
        line for any worker. on_pending(request, files): a bake is about to put `files` in
        place (Worker.call)."""
        todo, urgent = queue.Queue(), queue.Queue()
        for r in requests:
            todo.put(dict(r, attempt=1))
        lock = self.lock
        busy = [0]

        def take(local):
            if local:
                return local.pop(0)
            for q in (urgent, todo):
                try:
                    return q.get_nowait()
                except queue.Empty:
                    pass
            return None

        def run(slot):
            local = []
            while not self.stopped:
                with lock:
                    req = take(local)
                    if req is None:
                        if busy[0] == 0:
                            return
                    else:
                        busy[0] += 1
                if req is None:               # others may still queue retries or follow-ups
                    time.sleep(0.02)
                    continue
                try:
                    reply = self._call(slot, req, lock, on_pending)
                    if self.stopped:              # the batch is being stopped: no reply
                        return
                    retry = reply["status"] == "error" and reply.get("kind") == "crash" \
                        and req["attempt"] <= self.retries
                    reply["attempt"] = req["attempt"]
                    with lock:
                        more = on_reply(req, reply, retry) or []
                        if retry:
                            urgent.put(dict(req, attempt=req["attempt"] + 1))
                        more = [dict(m, attempt=1) for m in more]
                        local.extend(more[:1])
                        for m in more[1:]:
                            urgent.put(m)
                except BrokenPipeError:           # our output was closed: stop (exit 141)
                    interrupts.output_closed()
                    raise
                finally:
                    with lock:
                        busy[0] -= 1

        threads = [threading.Thread(target=run, args=(i,), daemon=True)
                   for i in range(self.workers)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

    def _call(self, slot, req, lock, on_pending=None):
        worker = self.procs[slot]
        if worker is None or worker.proc.poll() is not None:
            if worker is not None:
                worker.remove_tempdir()
            worker = self.procs[slot] = Worker(self.command or worker_command(), self.env)
        with lock:
            self.current[slot] = (worker, req)
        if self.stopped:                          # stop() ran while this one was starting
            worker.kill()
        def pending(files):
            with lock:
                if self.stopped:
                    return False
                if on_pending is not None:
                    try:
                        on_pending(req, files)
                    except MapNotWritten as err:    # (the manifest took no record of them)
                        return str(err)
                return True
        reply = worker.call(dict(req, in_worker=True), req.get("timeout"), pending)
        with lock:
            self.current.pop(slot, None)
        if worker.ready_s is not None and not getattr(worker, "counted", False):
            worker.counted = True
            with lock:
                self.process_starts.append((worker, worker.ready_s))
        if reply is TIMED_OUT:
            worker.kill()
            self.procs[slot] = None
            if req["op"] == "bake":
                interrupts.remove_partials(req["output"], worker.proc.pid, worker.part_token)
            return {"op": req["op"], "id": req.get("id"), "status": "error", "kind": "timeout",
                    "error": f"no reply from its worker process in {req['timeout']:.0f} s: "
                             f"taken as hung and killed (not retried); if it only needs "
                             f"longer, raise --worker-timeout"}
        if reply is None:
            code = worker.exit_code()
            self.procs[slot] = None
            if req["op"] == "bake":
                interrupts.remove_partials(req["output"], worker.proc.pid, worker.part_token)
            tail = "\n    ".join(worker.tail[-5:])
            if code in STOP_CODES:
                return {"op": req["op"], "id": req.get("id"), "status": "error",
                        "kind": "interrupted",
                        "error": f"its worker process was stopped by {STOP_CODES[code]} "
                                 f"(not retried)"}
            reply = {"op": req["op"], "id": req.get("id"), "status": "error", "kind": "crash",
                     "error": f"the worker process died ({how_it_ended(code, 'exit code')})"
                              + (f"; its last output:\n    {tail}" if tail else "")}
        return reply

    def stop(self):
        """Kill every worker process (and its group) now and remove the temporary files of
        the bakes they were doing; no request is retried or replied to after this. Returns
        the number of processes stopped."""
        self.stopped = True
        stopped = 0
        for slot, worker in enumerate(self.procs):
            if worker is None:
                continue
            if worker.proc.poll() is None:
                stopped += 1
            worker.kill()
            _, req = self.current.get(slot, (None, None))
            if req and req["op"] == "bake":
                interrupts.remove_partials(req["output"], worker.proc.pid, worker.part_token)
        return stopped

    def start_times(self):
        return [s for _, s in self.process_starts]

    def close(self):
        for w in self.procs:
            if w is not None:
                w.close()
        self.procs = [None] * self.workers


class InProcess:
    """The same interface in this session (workers = 0): requests run here, one by one, with
    one retry for unexpected failures."""

    def __init__(self, log, retries=1):
        self.log, self.retries = log, retries
        self.lock = threading.RLock()

    def map(self, requests, on_reply, on_pending=None):
        todo = [dict(r, attempt=1) for r in requests]

        def pending(req, files):
            with interrupts.committing(), self.lock:
                if on_pending is not None:
                    on_pending(req, files)
        while todo:
            req = todo.pop(0)
            reply = run_request(req, before_publish=lambda files, req=req: pending(req, files))
            reply["attempt"] = req["attempt"]
            retry = reply["status"] == "error" and reply.get("kind") == "crash" \
                and req["attempt"] <= self.retries
            # A commit: a stop waits for the reply to be recorded (the main thread would park
            # holding the lock the stop's manifest write needs).
            with interrupts.committing(), self.lock:
                more = on_reply(req, reply, retry) or []
            if retry:
                more = [dict(req, attempt=req["attempt"] + 1)] + \
                    [dict(m, attempt=1) for m in more]
            else:
                more = [dict(m, attempt=1) for m in more]
            todo[:0] = more

    def stop(self):
        return 0

    def start_times(self):
        return []

    def close(self):
        pass
