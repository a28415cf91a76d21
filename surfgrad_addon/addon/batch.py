"""Batch normal-map bakes for pipelines: many objects, collections or .blend files in one call.

    blender -c surfgrad bake-batch assets/*.blend --output "maps/{file}/{object}.<UDIM>.png" \\
        --resolution 2048 --samples 16 --workers 4
    python -m surfgrad_addon bake-batch ...              (the same, from a checkout)
    api.bake_batch(["a.blend", "b.blend"], "maps/{file}_{object}.<UDIM>.exr", workers=2)

Each asset (a mesh object with a material) is baked by normal_bake.bake_normal_tiles into files
named by the output pattern ({file}: the .blend's name without extension, {object}, {uv}: the UV
map, <UDIM>: the tile). Settings (uv_map, space, resolution, samples, margin, depth) have
defaults and per-asset overrides from a JSON settings file. A manifest (JSON, beside the
outputs) records for every asset its settings, a hash of its inputs (the .blend and the files it
uses) and settings, timings, warnings and the files written (with their hashes); an asset whose
inputs, settings and outputs are unchanged is skipped unless force. With workers >= 1 the bakes
run in that many separate Blender processes (batch_worker.py); a worker that dies or a bake
that fails unexpectedly is retried once in a fresh process; bad input fails that asset alone.
Files are written under a temporary name and renamed when complete (normal_bake).
"""

import fnmatch
import hashlib
import json
import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from ..reference import tiles as T
from . import bake_request as BR
from . import interrupts
from . import normal_bake as NB

SETTING_KEYS = ("uv_map", "space", "resolution", "samples", "margin", "depth", "allow_partial")
DEFAULTS = {"uv_map": None, "space": "tangent", "resolution": 1024, "samples": 1, "margin": 16,
            "depth": None, "allow_partial": False}
NOT_HASHED = ("allow_partial",)            # settings that change no texel of the map
TOKENS = ("{file}", "{object}", "{uv}")
MANIFEST_NAME = "surfgrad-bake-manifest.json"
RESULT_MARK = "@@surfgrad-batch "          # a worker's reply line (other output is its log)
BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")   # plain, gzip, zstd
FAULT_ENV = "SURFGRAD_BATCH_FAULT"          # tests: "die:OBJECT", "die-once:OBJECT", "hang:OBJECT"
SCAN_TIMEOUT_S = 600.0                      # a worker's scan of one file, unless told
BAKE_TIMEOUT_S = 300.0                      # a worker's bake: this plus 10 s per million
TEXEL_SAMPLES_PER_S = 1e5                   # texel-samples (about 1/30 of one loaded core)


class BatchError(ValueError):
    """Bad input for the whole batch (not one asset's): names the thing and the fix."""


# Inputs ------------------------------------------------------------------------------------------

def blend_problem(path):
    """None if `path` is a readable .blend file, else what is wrong with it."""
    path = Path(path)
    if not path.exists():
        return f"{path}: no such file"
    if path.is_dir():
        return f"{path} is a folder: give .blend files"
    if path.suffix.lower() != ".blend":
        return f"{path} is not a .blend file (give Blender files)"
    if not path.is_file():      # a named pipe or device would block the read below forever
        return f"{path} is not a regular file (a pipe or device?): give .blend files"
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as err:
        return f"{path} cannot be read ({err.strerror}): check its permissions"
    if not head.startswith(BLEND_MAGIC):
        return f"{path} is named .blend but is not a Blender file (damaged, or another format)"
    return None


def sha256_file(path, chunk=1 << 20):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def _read_text(path, what, fix):
    """A UTF-8 text file's text, or a BatchError naming `what` it is and the fix."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise BatchError(f"{what} {path} is not UTF-8 text ({err.reason} at byte "
                         f"{err.start}); {fix}") from None
    except OSError as err:
        raise BatchError(f"{what} {path} cannot be read ({err.strerror}); check its "
                         f"permissions") from None


def load_settings_file(path):
    """{"defaults": {...}, "assets": {PATTERN: {...}}}: PATTERN matches "file.blend:Object",
    "file.blend" or "Object" (shell wildcards); later matches override earlier ones."""
    if Path(path).is_dir():
        raise BatchError(f"settings file {path} is a folder; give the JSON settings file")
    if Path(path).exists() and not Path(path).is_file():
        raise BatchError(f"settings file {path} is not a regular file; give the JSON settings "
                         f"file")
    if not Path(path).exists():
        raise BatchError(f"settings file {path}: no such file")
    text = _read_text(path, "settings file", "save it as UTF-8 JSON")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise BatchError(f"settings file {path} is not valid JSON ({err})") from None
    if not isinstance(data, dict) or set(data) - {"defaults", "assets"}:
        raise BatchError(f"settings file {path}: use an object with 'defaults' and/or 'assets'")
    if not isinstance(data.get("assets", {}), dict):
        raise BatchError(f"settings file {path}: 'assets' must be an object of "
                         f"\"PATTERN\": {{settings}}")
    problems = []
    for where, block in [("defaults", data.get("defaults", {}))] + \
            [(f"assets[{k!r}]", v) for k, v in data.get("assets", {}).items()]:
        if not isinstance(block, dict):
            problems.append(f"settings file {path}: {where} must be an object")
            continue
        # Every value is checked before any file is opened: a bad one bakes nothing.
        problems += BR.settings_problems(block, f"settings file {path}: {where}")
    if problems:
        raise BatchError(_joined(problems))
    return data


def _joined(problems):
    return problems[0] if len(problems) == 1 else \
        f"{len(problems)} problems:\n  - " + "\n  - ".join(problems)


def asset_settings(defaults, overrides, blend_name, object_name):
    """The settings of one asset: defaults, then every matching override in order."""
    out = dict(DEFAULTS)
    out.update({k: v for k, v in (defaults or {}).items() if v is not None})
    keys = (f"{blend_name}:{object_name}", blend_name, object_name)
    for pattern, block in (overrides or {}).items():
        if any(fnmatch.fnmatchcase(k, pattern) for k in keys):
            out.update(block)
    return out


_UNSAFE = re.compile(r'[\\/:*?"<>|\x00-\x1f]')


def _safe(name):
    """A name as a file-name part (no folder separators or characters Windows refuses)."""
    return _UNSAFE.sub("_", name).strip() or "_"


def check_pattern(pattern):
    """The output pattern's problems, before anything runs."""
    pattern = str(pattern)
    name = Path(pattern).name
    if not name:
        raise BatchError(f"output pattern {pattern!r} ends in a folder: give a file name")
    if Path(name).suffix.lower() not in NB.FORMATS:
        raise BatchError(f"output pattern {pattern!r}: end it in .png or .exr")
    left = re.findall(r"\{[^}]*\}", pattern.replace("{file}", "").replace("{object}", "")
                      .replace("{uv}", ""))
    if left:
        raise BatchError(f"output pattern {pattern!r}: unknown token {left[0]}; the tokens are "
                         f"{', '.join(TOKENS)} and {NB.UDIM_TOKEN}")
    if NB.UDIM_TOKEN in str(Path(pattern).parent):
        raise BatchError(f"output pattern {pattern!r}: put {NB.UDIM_TOKEN} in the file name, "
                         f"not a folder")
    return pattern


def expand(pattern, blend_name, object_name, uv_map):
    """The output name of one asset (keeps <UDIM>)."""
    stem = Path(blend_name).stem if blend_name else "untitled"
    return (str(pattern).replace("{file}", _safe(stem)).replace("{object}", _safe(object_name))
            .replace("{uv}", _safe(uv_map)))


def default_manifest(pattern):
    """The manifest beside the outputs: in the pattern's folder before its first token."""
    parts = Path(pattern).parent.parts
    fixed = []
    for part in parts:
        if "{" in part or NB.UDIM_TOKEN in part:
            break
        fixed.append(part)
    return Path(*fixed) / MANIFEST_NAME if fixed else Path(MANIFEST_NAME)


def settings_hash(settings, output, blender_version, version):
    settings = {k: v for k, v in settings.items() if k not in NOT_HASHED}
    blob = json.dumps({"settings": settings, "output": str(output), "blender": blender_version,
                       "surfgrad": version}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def input_hash(blend, dependencies=()):
    """sha256 over the .blend and the external files it uses (images, libraries)."""
    h = hashlib.sha256(sha256_file(blend).encode())
    for dep in sorted(dependencies):
        h.update(dep.encode())
        h.update(sha256_file(dep).encode() if Path(dep).is_file() else b"missing")
    return h.hexdigest()


# In a Blender session: scan and bake -----------------------------------------------------------

def scan_open_file(objects=None, collections=None, everything=False):
    """The assets of the open file: with `objects` (names or wildcards) and/or `collections`
    (names, their objects and child collections), those; with neither, or with everything,
    (also) every mesh object with a material. Returns {"assets": [...], "errors": [...]}: per asset its name, UV maps with
    the tiles each holds, the active render UV map, and its material count."""
    import bpy
    chosen, errors = [], []
    mesh_objects = [o for o in bpy.data.objects if o.type == "MESH"]
    if objects:
        for pattern in objects:
            exact = bpy.data.objects.get(pattern)       # a name with * or [ in it is a name
            hits = [exact] if exact else \
                [o for o in bpy.data.objects if fnmatch.fnmatchcase(o.name, pattern)]
            if not hits:
                errors.append({"object": pattern, "error": f"no object named {pattern!r} in "
                               f"{Path(bpy.data.filepath).name}"})
            chosen += hits
    for name in collections or ():
        coll = bpy.data.collections.get(name)
        if coll is None:
            errors.append({"object": f"collection:{name}", "error": f"no collection named "
                           f"{name!r} in {Path(bpy.data.filepath).name}; collections: "
                           f"{sorted(c.name for c in bpy.data.collections)}"})
            continue
        chosen += [o for o in coll.all_objects if o.type == "MESH"]
    if everything or (not objects and not collections):
        chosen += [o for o in mesh_objects if any(s.material for s in o.material_slots)]
    seen, assets = set(), []
    for obj in chosen:
        if obj.name in seen:
            continue
        seen.add(obj.name)
        entry = {"object": obj.name, "type": obj.type, "uv_maps": {}, "active_uv": None,
                 "materials": 0}
        if obj.type == "MESH":
            entry["materials"] = sum(1 for s in obj.material_slots if s.material)
            entry["outside"] = {}
            for uv in obj.data.uv_layers:
                entry["uv_maps"][uv.name], entry["outside"][uv.name] = \
                    NB.uv_tiles(obj.data, uv.name)
                if uv.active_render:
                    entry["active_uv"] = uv.name
            entry["problems"] = _input_problems(obj)
        assets.append(entry)
    return {"assets": assets, "errors": errors}


def _input_problems(obj):
    """What bake_request finds wrong with obj's mesh and images (no setting changes these),
    so the planner refuses the asset before any bake."""
    if len(obj.data.polygons) == 0:
        return []                          # the bake's own check names it
    return BR.mesh_problems(obj, None, []) + BR.image_problems(obj)


def dependencies_of_open_file():
    """Absolute paths of the external files the open file uses (not packed)."""
    import bpy
    try:
        paths = bpy.utils.blend_paths(absolute=True, packed=False, local=False)
    except TypeError:
        paths = bpy.utils.blend_paths(absolute=True)
    return sorted({str(Path(p).resolve()) for p in paths if p and "<UDIM>" not in p})


_OPENED = [None]        # the file this session opened last (a bake leaves it as it was)


def open_blend(path):
    """Open `path` unless this session opened it last and it is still the open file (every
    bake puts back what it touched); returns the seconds it took."""
    import bpy
    path = str(Path(path).resolve())
    if _OPENED[0] == path and bpy.data.filepath and \
            str(Path(bpy.data.filepath).resolve()) == path:
        return 0.0
    t0 = time.perf_counter()
    from .open_blend import open_mainfile
    open_mainfile(path)                  # scripts off, whatever the Preferences say
    _OPENED[0] = path
    return time.perf_counter() - t0


def run_request(request, log=lambda *_: None):
    """Do one request in this session: {"op": "scan", blend, objects, collections} or
    {"op": "bake", blend, object, output, settings, tiles, empty_tiles, overwrite}. Returns the
    reply dict (status "ok", or "error" with kind "input" / "crash" and the message)."""
    t0, cpu0 = time.perf_counter(), time.process_time()
    reply = {"op": request["op"], "id": request.get("id")}
    try:
        load_s = open_blend(request["blend"]) if request.get("blend") else 0.0
        reply["load_s"] = load_s
        if request["op"] == "scan":
            reply.update(scan_open_file(request.get("objects"), request.get("collections"),
                                        request.get("everything", False)))
            reply["dependencies"] = dependencies_of_open_file()
        else:
            import bpy
            _fault(request)
            obj = bpy.data.objects.get(request["object"])
            if obj is None:
                raise NB.NormalBakeError(f"no object named {request['object']!r}")
            bake_request = BR.BakeRequest.from_settings(
                obj.name, request["output"], request["settings"], tiles=request.get("tiles"),
                empty_tiles=request.get("empty_tiles", "error"),
                overwrite=request.get("overwrite", False), threads=request.get("threads"))
            # warnings travel in the reply: the parent prints them once
            with interrupts.partials_of(request["output"]):     # a stop removes its temps
                res = BR.bake(bake_request, obj, log=log, warn=lambda *_: None)
            reply.update({"paths": {str(t): str(p) for t, p in res["paths"].items()},
                          "tiles": res["tiles"], "uv_map": res["uv_map"], "depth": res["depth"],
                          "warnings": res["warnings"], "bake_s": res["bake_s"],
                          "save_s": res["save_s"], "dependencies": dependencies_of_open_file()})
        reply["status"] = "ok"
    except NB.NormalBakeError as err:
        reply.update(status="error", kind="input", error=str(err))
    except Exception as err:                    # noqa: BLE001 - reported, retried once
        reply.update(status="error", kind="crash", error=f"{type(err).__name__}: {err}")
    reply["total_s"] = time.perf_counter() - t0
    reply["cpu_s"] = time.process_time() - cpu0      # every thread of this process (Cycles')
    return reply


def _fault(request):
    """Test hook (SURFGRAD_BATCH_FAULT): make this worker process die or hang on an asset."""
    fault = os.environ.get(FAULT_ENV, "")
    if ":" in fault and request.get("in_worker"):
        kind, name = fault.split(":", 1)
        if name == request["object"] and (kind == "die" or
                                          (kind == "die-once" and request.get("attempt") == 1)):
            os._exit(70)
        if name == request["object"] and kind == "hang":
            time.sleep(24 * 3600)


# Worker processes --------------------------------------------------------------------------------

_BOOT = ("import importlib.util, sys\n"
         "root = {root!r}\n"
         "spec = importlib.util.spec_from_file_location('_surfgrad_batch', root + '/__init__.py',"
         " submodule_search_locations=[root])\n"
         "pkg = importlib.util.module_from_spec(spec)\n"
         "sys.modules['_surfgrad_batch'] = pkg\n"
         "spec.loader.exec_module(pkg)\n"
         "from _surfgrad_batch.addon import batch_worker\n"
         "sys.exit(batch_worker.main())\n")


def worker_command():
    """The command that starts one worker: Blender itself (-b --factory-startup
    --python-exit-code 1 --python-expr) when this is a Blender binary, else this Python (the bpy module). The
    worker loads this package from its folder, so a checkout and an installed extension both
    work."""
    import bpy
    code = _BOOT.format(root=str(Path(__file__).resolve().parents[1]))
    binary = getattr(bpy.app, "binary_path", "") or ""
    if binary and Path(binary).name.lower().startswith("blender") and Path(binary).is_file():
        # --python-exit-code: an uncaught Python error ends Blender non-zero (else 0)
        return [binary, "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr",
                code]
    return [sys.executable, "-c", code]


TIMED_OUT = "timed out"                     # Worker.call's answer when a request overran
STOP_CODES = {130: "SIGINT", 143: "SIGTERM", -2: "SIGINT", -15: "SIGTERM"}


class Worker:
    """One worker process: requests in on stdin, replies out on stdout (marked lines). It runs
    in its own process group (a terminal's Ctrl-C reaches the batch, which stops it), and a
    reader thread takes its output so that a request can time out."""

    def __init__(self, command, env=None):
        # Its own temp folder: Blender's session folder (TMPDIR/blender_XXXXXX) of a worker
        # that is killed (stop, timeout) is removed with it (interrupts.py).
        self.tempdir = tempfile.mkdtemp(prefix="surfgrad-worker-")
        env = dict(os.environ if env is None else env)
        env.update(TMPDIR=self.tempdir, TEMP=self.tempdir, TMP=self.tempdir)
        self.proc = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, bufsize=1, env=env,
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

    def call(self, request, timeout=None):
        """Send a request and wait for its reply: None if the process died first, TIMED_OUT
        after `timeout` seconds (the process is left to the caller)."""
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

    def map(self, requests, on_reply):
        """Run `requests`; on_reply(request, reply, retry) may return follow-up requests: the
        same thread runs the first next (its worker has that file open), the rest go first in
        line for any worker."""
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
                    reply = self._call(slot, req, lock)
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
                finally:
                    with lock:
                        busy[0] -= 1

        threads = [threading.Thread(target=run, args=(i,), daemon=True)
                   for i in range(self.workers)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

    def _call(self, slot, req, lock):
        worker = self.procs[slot]
        if worker is None or worker.proc.poll() is not None:
            if worker is not None:
                worker.remove_tempdir()
            worker = self.procs[slot] = Worker(self.command or worker_command(), self.env)
        with lock:
            self.current[slot] = (worker, req)
        if self.stopped:                          # stop() ran while this one was starting
            worker.kill()
        reply = worker.call(dict(req, in_worker=True), req.get("timeout"))
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
                interrupts.remove_partials(req["output"], worker.proc.pid)
            return {"op": req["op"], "id": req.get("id"), "status": "error", "kind": "timeout",
                    "error": f"no reply from its worker process in {req['timeout']:.0f} s: "
                             f"taken as hung and killed (not retried); if it only needs "
                             f"longer, raise --worker-timeout"}
        if reply is None:
            code = worker.exit_code()
            self.procs[slot] = None
            if req["op"] == "bake":
                interrupts.remove_partials(req["output"], worker.proc.pid)
            tail = "\n    ".join(worker.tail[-5:])
            if code in STOP_CODES:
                return {"op": req["op"], "id": req.get("id"), "status": "error",
                        "kind": "interrupted",
                        "error": f"its worker process was stopped by {STOP_CODES[code]} "
                                 f"(not retried)"}
            reply = {"op": req["op"], "id": req.get("id"), "status": "error", "kind": "crash",
                     "error": f"the worker process died (exit code {code})"
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
                interrupts.remove_partials(req["output"], worker.proc.pid)
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

    def map(self, requests, on_reply):
        todo = [dict(r, attempt=1) for r in requests]
        while todo:
            req = todo.pop(0)
            reply = run_request(req)
            reply["attempt"] = req["attempt"]
            retry = reply["status"] == "error" and reply.get("kind") == "crash" \
                and req["attempt"] <= self.retries
            with self.lock:
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


# The batch ------------------------------------------------------------------------------------

class Progress:
    """done/total with elapsed time and an ETA from the assets baked so far. Until every file
    is scanned the total counts each unscanned file as the mean of the scanned ones."""

    def __init__(self, log):
        self.log, self.done, self.known, self.unscanned = log, 0, 0, 0
        self.scanned_files, self.scanned_assets = 0, 0
        self.counts = {"baked": 0, "skipped": 0, "failed": 0}
        self.t0 = time.perf_counter()

    @property
    def total(self):
        per_file = self.scanned_assets / self.scanned_files if self.scanned_files else 1
        return self.known + round(self.unscanned * max(per_file, 1))

    def step(self, status, what, detail=""):
        self.done += 1
        self.counts[status] += 1
        elapsed = time.perf_counter() - self.t0
        worked = self.counts["baked"] + self.counts["failed"]
        total = max(self.total, self.done)
        left = total - self.done
        eta = "done" if not left else \
            (f"ETA {elapsed / worked * left:.0f} s" if worked else "ETA ?")
        approx = "~" if self.unscanned else ""
        self.log(f"[{self.done}/{approx}{total}] {status} {what}{detail} | "
                 f"{self.counts['baked']} baked, {self.counts['skipped']} skipped, "
                 f"{self.counts['failed']} failed | {elapsed:.1f} s elapsed, {eta}")


def _manifest_problem(path):
    """None if the manifest path can be read and replaced, else what is wrong with it."""
    if path.is_dir():
        return f"is a folder; give a file path (e.g. {path / MANIFEST_NAME})"
    if path.exists() and not path.is_file():
        return "is not a regular file; give a file path"
    return None


def _read_manifest(path):
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        return data if isinstance(data, dict) and isinstance(data.get("assets"), dict) else None
    except (FileNotFoundError, json.JSONDecodeError):
        return None
    except UnicodeDecodeError:
        raise BatchError(f"manifest {path} is not UTF-8 text (not a surfgrad manifest); give "
                         f"another --manifest path or remove that file") from None


# One manifest write at a time. A stop (stop_batch) takes it for good before its own write:
# the process then ends, and no write of the main thread is left half done (a temporary) or
# lands after the stop's (a manifest without the interrupted assets).
_WRITE_LOCK = threading.Lock()


def write_json_atomic(path, data):
    with _WRITE_LOCK:
        _write_json(path, data)


def _write_json(path, data):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temp = path.with_name(f".{path.name}.part{os.getpid()}")
    temp.write_text(json.dumps(data, indent=1, sort_keys=False))
    os.replace(temp, path)


def _asset_key(blend, obj):
    return f"{blend}:{obj}"


def _tile_list(value):
    """'1001-1003,1005' / [1001, 1002] / None -> sorted tiles (None stays None)."""
    try:
        return T.parse_tiles(value)
    except ValueError as err:
        raise BatchError(str(err)) from None


def split_entry(entry):
    """'file.blend' or 'file.blend:Object' -> (file, object or None)."""
    text = str(entry)
    head, sep, tail = text.rpartition(".blend:")
    if sep and tail:
        return head + ".blend", tail
    return text, None


def read_asset_list(path):
    """An asset list: one `file.blend` or `file.blend:Object` a line (# comments); relative
    paths are taken from the list's folder. Returns the entries with absolute paths."""
    path = Path(path)
    if not path.is_file():
        raise BatchError(f"asset list {path}: no such file")
    entries = []
    text = _read_text(path, "asset list", "save it as UTF-8, one .blend path a line")
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        blend, obj = split_entry(line)
        p = Path(blend)
        p = p if p.is_absolute() else path.parent / p
        entries.append(f"{p}:{obj}" if obj else str(p))
    return entries


def bake_batch(blends=(), output="{file}_{object}.<UDIM>.png", objects=None, collections=None,
               defaults=None, settings_file=None, workers=1, force=False, overwrite=False,
               manifest=None, tiles=None, empty_tiles="error", open_file=False, worker_env=None,
               worker_command_override=None, log=print, threads=None, warn=BR.warn_stderr,
               worker_timeout=None):
    """Bake every asset of `blends` (paths; or the open file with open_file) selected by
    `objects` / `collections` into files named by `output`. threads: Cycles threads per bake
    (default: all cores in this process or one worker, their share with several). Returns the run's report (also
    written, merged with earlier runs, to the manifest): per asset its status (baked, skipped,
    failed), settings, hashes, timings, warnings (also passed to `warn`: stderr), files.
    The whole plan is checked before any bake: BatchError (nothing baked, nothing written)
    for bad input of the whole run (settings values, output collisions, folders that cannot
    be written); an asset whose own input is bad (mesh, images, UV layout) fails alone.
    worker_timeout: seconds a scan or bake may take in a worker before it is taken as hung
    (default: SCAN_TIMEOUT_S for a scan, bake_timeout() for a bake). Entries naming the same
    file are merged: `a.blend` with `a.blend:Obj` bakes the file's assets and Obj."""
    import bpy
    from .groups.common import VERSION

    check_pattern(output)
    if workers is None or isinstance(workers, bool) or not isinstance(workers, int) \
            or workers < 0:
        raise BatchError(f"workers {workers!r}: give 0 (this process) or more processes")
    if worker_timeout is not None and (isinstance(worker_timeout, bool) or
                                       not isinstance(worker_timeout, (int, float)) or
                                       not worker_timeout > 0):
        raise BatchError(f"worker timeout {worker_timeout!r}: give seconds, more than 0")
    if threads is not None and BR._whole("threads", threads, 1, 1024):
        raise BatchError(BR._whole("threads", threads, 1, 1024))   # before any file opens
    if empty_tiles not in ("error", "skip"):
        raise BatchError("empty tiles: use 'error' or 'skip'")
    tiles = _tile_list(tiles)
    overrides_data = load_settings_file(settings_file) if settings_file else {}
    base = dict(overrides_data.get("defaults", {}))
    base.update({k: v for k, v in (defaults or {}).items() if v is not None})
    bad = sorted(set(base) - set(SETTING_KEYS))
    if bad:
        raise BatchError(f"unknown setting(s) {', '.join(bad)}; the settings are "
                         f"{', '.join(SETTING_KEYS)}")
    overrides = overrides_data.get("assets", {})
    problems = BR.settings_problems(base, "settings")
    for where, block in [("settings", base)] + [(f"settings for {k!r}", v)
                                                  for k, v in overrides.items()]:
        if block.get("depth") is not None and not BR.settings_problems(
                {"depth": block["depth"]}):
            try:
                NB.depth_for(str(output), block["depth"])
            except NB.NormalBakeError as err:
                problems.append(f"{where}: {err}")
    if problems:
        raise BatchError(_joined(problems))
    if open_file:
        if not bpy.data.filepath:
            raise BatchError("the open file has never been saved: save it, or give .blend files")
        blends = [bpy.data.filepath]
        workers = 0                               # the open session is the one to bake
        force = force or bpy.data.is_dirty        # unsaved changes: the file's hash says nothing
    if not blends:
        raise BatchError("give .blend files to bake (or bake the open file)")
    per_file, whole = {}, set()                  # file -> objects named with it; files named
    for entry in blends:                         # alone (all their assets)
        blend, obj = split_entry(entry)
        blend = str(Path(blend).resolve())
        per_file.setdefault(blend, [])
        if obj:
            per_file[blend].append(obj)
        else:
            whole.add(blend)
    blends = list(per_file)
    manifest_path = Path(manifest) if manifest else default_manifest(output)
    problem = BR.folder_problem(manifest_path.parent) or _manifest_problem(manifest_path)
    if problem:
        raise BatchError(f"manifest {manifest_path}: {problem}")
    previous = _read_manifest(manifest_path) or {"assets": {}}
    blender_version = bpy.app.version_string
    t_start = time.perf_counter()
    report = {"surfgrad": VERSION, "blender": blender_version,
              "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "output": str(output),
              "workers": workers, "force": force, "assets": {}, "files": {}}

    # 1. The files: bad ones fail here; unchanged ones reuse their earlier scan.
    files, to_scan = {}, []
    prev_files = previous.get("files", {})
    for blend in blends:
        selection = {"objects": (objects or []) + per_file[blend],
                     "collections": collections or []}
        if blend in whole and per_file[blend] and not objects and not collections:
            selection["everything"] = True      # `a.blend a.blend:Obj`: the union
        problem = blend_problem(blend)
        if problem:
            report["assets"][_asset_key(blend, "*")] = {
                "file": blend, "object": None, "status": "failed", "kind": "input",
                "error": problem}
            continue
        prev = prev_files.get(blend)
        deps = prev.get("dependencies", []) if prev else []
        ihash = input_hash(blend, deps)
        files[blend] = {"input_hash": ihash, "dependencies": deps, "selection": selection}
        if prev and prev.get("input_hash") == ihash and prev.get("selection") == selection \
                and "scan" in prev:
            files[blend]["scan"] = prev["scan"]
            files[blend]["scan_reused"] = True
        else:
            to_scan.append(blend)
    pool = InProcess(log) if workers == 0 else \
        Pool(workers, worker_command_override, worker_env)
    progress = Progress(log)
    progress.known = len(report["assets"])          # the files refused already
    progress.unscanned = len(to_scan)
    outputs_seen, collisions, folders = {}, [], set()
    how = "this process" if workers == 0 else f"{workers} worker process(es)"
    # Cycles takes every core by default: several worker processes share them out.
    if threads is None:
        threads = None if workers <= 1 else max(1, (os.cpu_count() or 1) // workers)

    def stop_batch(signal_name):
        """On Ctrl-C / SIGTERM (interrupts.py): stop the workers, record every asset not
        finished as interrupted (a rerun bakes it), write the manifest."""
        held = pool.lock.acquire(timeout=5)      # not while a reply is being recorded
        try:
            n = pool.stop()
            left = [e for e in report["assets"].values() if "status" not in e]
            for e in left:
                e.update(status="interrupted", error=f"stopped by {signal_name} before it "
                                                     f"was baked")
            report["interrupted"] = signal_name
            # Kept: the process ends after this, and no other write may follow or overlap.
            _WRITE_LOCK.acquire(timeout=5)
            _write_json(manifest_path, _merged(previous, report, files))
            interrupts.say(f"[batch] {signal_name}: stopped {n} worker process(es); "
                           f"{len(left)} asset(s) not baked, recorded as interrupted in "
                           f"{manifest_path}")
        finally:
            if held:
                pool.lock.release()

    def step_entry(entry):
        what = f"{Path(entry['file']).name}:{entry.get('object') or '*'}"
        progress.step(entry["status"], what,
                      f": {entry['error']}" if entry["status"] == "failed" else "")

    def plan_file(blend):
        """The bake requests of one scanned file; its failed and skipped assets reported."""
        f, name = files[blend], Path(blend).name
        entries, jobs = [], []
        if "scan_error" in f:
            entries.append({"file": blend, "object": None, "status": "failed",
                            "kind": "input", "error": f"could not read {name}: "
                                                      f"{f['scan_error']}"})
        else:
            for err in f["scan"]["errors"]:
                entries.append({"file": blend, "object": err["object"], "status": "failed",
                                "kind": "input", "error": err["error"]})
            if not f["scan"]["assets"] and not f["scan"]["errors"]:
                entries.append({"file": blend, "object": None, "status": "failed",
                                "kind": "input",
                                "error": f"{name} has no mesh object with a material to bake"})
        for a in f.get("scan", {}).get("assets", []):
            key = _asset_key(blend, a["object"])
            s = asset_settings(base, overrides, name, a["object"])
            entry = {"file": blend, "object": a["object"], "settings": s}
            entries.append(entry)
            problem = _asset_problem(a, s, name)
            if problem:
                entry.update(status="failed", kind="input", error=problem)
                continue
            uv = s["uv_map"] or a["active_uv"] or next(iter(a["uv_maps"]))
            s = dict(s, uv_map=uv)
            entry["settings"] = s
            out = expand(output, name, a["object"], uv)
            entry["output"] = out
            if out in outputs_seen:
                collisions.append(f"{name}:{a['object']} and {outputs_seen[out]} would both "
                                  f"write {out}: make the output pattern tell them apart "
                                  f"({', '.join(TOKENS)})")
                continue
            outputs_seen[out] = f"{name}:{a['object']}"
            entry["input_hash"] = f["input_hash"]
            entry["settings_hash"] = settings_hash(s, out, blender_version, VERSION)
            prev = previous["assets"].get(key, {})
            ours = _unchanged_outputs(prev)
            if not force and prev.get("status") in ("baked", "skipped") and ours and \
                    prev.get("input_hash") == entry["input_hash"] and \
                    prev.get("settings_hash") == entry["settings_hash"] and \
                    (tiles is None or set(map(str, tiles)) <= set(prev["files"])):
                entry.update(status="skipped", files=prev["files"], tiles=prev.get("tiles"),
                             warnings=prev.get("warnings", []),
                             note="inputs, settings and outputs unchanged (--force bakes "
                                  "again)")
                continue
            folders.add(Path(out).parent)
            n_tiles = len(tiles) if tiles else len(a["uv_maps"].get(uv) or [1])
            jobs.append({"op": "bake", "id": key, "file": blend,
                         "timeout": worker_timeout or bake_timeout(s, n_tiles),
                         "blend": None if open_file else blend, "object": a["object"],
                         "output": str(Path(out).resolve()), "settings": s, "tiles": tiles,
                         "empty_tiles": empty_tiles, "threads": threads,
                         # our own earlier, unmodified outputs may be replaced
                         "overwrite": overwrite or bool(ours)})
        for entry in entries:
            report["assets"][_asset_key(blend, entry.get("object") or "*")] = entry
        progress.known += len(entries)
        for entry in entries:
            if entry.get("status") in ("failed", "skipped"):
                step_entry(entry)
        return jobs

    def on_reply(req, reply, retry):
        if req["op"] == "scan":
            if retry:
                return []
            f = files[req["file"]]
            f["scan_load_s"] = reply.get("load_s")
            if reply["status"] == "ok":
                f["scan"] = {"assets": reply["assets"], "errors": reply["errors"]}
                if reply["dependencies"] != f["dependencies"]:
                    f["dependencies"] = reply["dependencies"]
                    f["input_hash"] = input_hash(req["file"], f["dependencies"])
            else:
                f["scan_error"] = reply["error"]
            progress.unscanned -= 1
            progress.scanned_files += 1
            progress.scanned_assets += len(f.get("scan", {}).get("assets", [])) or 1
            return []                           # bakes are planned once every file is read
        entry = report["assets"][req["id"]]
        what = f"{Path(req['file']).name}:{req['object']}"
        entry.setdefault("attempts", []).append(
            {k: reply.get(k) for k in ("status", "kind", "error", "load_s", "bake_s",
                                       "save_s", "total_s") if k in reply})
        if retry:
            log(f"[batch] {what}: {reply['error']} - retrying once in a fresh process")
            return []
        if reply["status"] == "ok":
            entry.update(status="baked", tiles=reply["tiles"], uv_map=reply["uv_map"],
                         depth=reply["depth"], warnings=reply["warnings"],
                         timings={k: reply.get(k) for k in ("load_s", "bake_s", "save_s",
                                                            "total_s", "cpu_s")},
                         files={t: {"path": p, "sha256": sha256_file(p)}
                                for t, p in reply["paths"].items()})
            f = files[req["file"]]
            if reply["dependencies"] != f["dependencies"]:
                f["dependencies"] = reply["dependencies"]
                f["input_hash"] = input_hash(req["file"], f["dependencies"])
                entry["input_hash"] = f["input_hash"]
            progress.step("baked", what, f": tile(s) {NB._tiles_text(reply['tiles'])}"
                                         f" in {reply['total_s']:.1f} s")
            for w in reply["warnings"]:
                warn(f"{what}: {w}")
        else:
            entry.update(status="failed", kind=reply.get("kind"), error=reply["error"])
            progress.step("failed", what, f": {reply['error']}")
        write_json_atomic(manifest_path, _merged(previous, report, files))
        return []

    try:
        for entry in list(report["assets"].values()):
            step_entry(entry)
        log(f"[batch] {len(files)} file(s), {len(to_scan)} to scan; baking with {how}")
        # 1. Read every file, 2. plan and check the whole batch, 3. only then bake.
        with interrupts.on_stop(stop_batch):
            pool.map([{"op": "scan", "file": b, "blend": None if open_file else b,
                       "timeout": worker_timeout or SCAN_TIMEOUT_S,
                       **files[b]["selection"]} for b in to_scan], on_reply)
            requests = []
            for blend in files:
                requests += plan_file(blend)
            problems = collisions + sorted({p for p in map(BR.folder_problem, folders) if p})
            if problems:
                raise BatchError(_joined(problems) + "\n(nothing was baked)")
            for folder in sorted(folders):
                folder.mkdir(parents=True, exist_ok=True)
            write_json_atomic(manifest_path, _merged(previous, report, files))
            pool.map(requests, on_reply)
        report["process_start_s"] = pool.start_times()
    finally:
        pool.close()
    report["total_s"] = time.perf_counter() - t_start
    report["counts"] = dict(progress.counts)
    report["manifest"] = str(manifest_path)
    write_json_atomic(manifest_path, _merged(previous, report, files))
    c = progress.counts
    log(f"[batch] {c['baked']} baked, {c['skipped']} skipped, {c['failed']} failed in "
        f"{report['total_s']:.1f} s; manifest {manifest_path}")
    return report


def bake_timeout(settings, n_tiles):
    """Seconds a worker's bake may take before it is taken as hung: BAKE_TIMEOUT_S plus the
    texel-samples at TEXEL_SAMPLES_PER_S, generous (about 30x a loaded 2-core machine)."""
    texels = int(settings.get("resolution") or DEFAULTS["resolution"]) ** 2
    work = texels * int(settings.get("samples") or 1) * max(1, int(n_tiles))
    return BAKE_TIMEOUT_S + work / TEXEL_SAMPLES_PER_S



def _asset_problem(scan, s, blend_name=""):
    """What stops this asset from baking, known from the scan (None if nothing): the
    bake request's checks of its mesh and images, its UV map and layout."""
    name = scan["object"]
    if scan["type"] != "MESH":
        return f"object {name!r} is a {scan['type'].lower()}, not a mesh: pick mesh objects"
    if not scan["uv_maps"]:
        return f"object {name!r} has no UV map; unwrap it first"
    if s["uv_map"] and s["uv_map"] not in scan["uv_maps"]:
        return (f"object {name!r} has no UV map {s['uv_map']!r}; it has "
                f"{sorted(scan['uv_maps'])}")
    if not scan["materials"]:
        return f"object {name!r} has no material to bake"
    if scan.get("problems"):
        return _joined(scan["problems"])
    uv = s["uv_map"] or scan["active_uv"] or next(iter(scan["uv_maps"]))
    outside = scan.get("outside", {}).get(uv, 0)
    if outside and not s.get("allow_partial"):
        return (f"{outside} face(s) of UV map {uv!r} of object {name!r} lie outside the UDIM "
                f"range (u 0..10, v >= 0) and would not be baked: move them into tiles, or "
                f"bake the rest on purpose with --allow-partial (settings file: "
                f"\"allow_partial\": true for {blend_name}:{name})")
    return None


def _unchanged_outputs(prev):
    """True if every file an earlier run recorded still holds what it wrote."""
    files = prev.get("files") or {}
    if not files:
        return False
    for rec in files.values():
        p = Path(rec["path"])
        if not p.is_file() or sha256_file(p) != rec["sha256"]:
            return False
    return True


def _merged(previous, report, files):
    """The manifest: this run's report, with earlier runs' assets and files kept."""
    out = dict(report)
    out["assets"] = dict(previous.get("assets", {}))
    out["assets"].update(report["assets"])
    out["files"] = dict(previous.get("files", {}))
    for blend, f in files.items():
        out["files"][blend] = {"input_hash": f["input_hash"],
                               "dependencies": f["dependencies"], "selection": f["selection"],
                               "load_s": f.get("scan_load_s"),
                               **({"scan": f["scan"]} if "scan" in f else {})}
    return out
