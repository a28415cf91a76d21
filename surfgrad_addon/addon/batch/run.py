"""One batch run (bake_batch): check the plan, scan every file, plan and check the whole batch,
then bake, recording each asset in the manifest as it finishes (see the package docstring)."""

import os
import time
from pathlib import Path

from .. import bake_request as BR
from .. import interrupts
from .. import normal_bake as NB
from ..exit_codes import MapNotWritten
from ..publish_files import others_backups
from . import manifest as M
from . import list_tasks as LT
from . import plan as P
from .output_names import one_file_because, output_key
from .progress import Progress
from .workers import InProcess, Pool


def bake_batch(blends=(), output="{file}_{object}.<UDIM>.png", objects=None, collections=None,
               defaults=None, settings_file=None, workers=1, force=False, overwrite=False,
               manifest=None, tiles=None, empty_tiles="error", open_file=False, worker_env=None,
               worker_command_override=None, log=print, threads=None, warn=BR.warn_stderr,
               worker_timeout=None, list_tasks=None, session_edits=True):
    """Bake every asset of `blends` (paths; or the open file with open_file) selected by
    `objects` / `collections` into files named by `output`. threads: Cycles threads per bake
    (default: all cores in this process or one worker, their share with several). Returns the
    run's report (also written, merged with earlier runs, to the manifest): per asset its
    status (baked, skipped, failed), settings, hashes, timings, warnings (also passed to
    `warn`: stderr), files.
    The whole plan is checked before any bake: BatchError (nothing baked, nothing written)
    for bad input of the whole run (settings values, output collisions, folders that cannot
    be written); an asset whose own input is bad (mesh, images, UV layout) fails alone.
    worker_timeout: seconds a scan or bake may take in a worker before it is taken as hung
    (default: SCAN_TIMEOUT_S for a scan, bake_timeout() for a bake). Entries naming the same
    file are merged: `a.blend` with `a.blend:Obj` bakes the file's assets and Obj.
    list_tasks: (asset list, [(index, entry)] of its other entries) where this run bakes one
    entry of it (--asset-index): an output another entry writes too is refused (list_tasks.py).
    session_edits (open_file): the session may hold edits a script made since the file was
    opened (the API); False where Blender's command line has just opened it (--open-file)."""
    import bpy
    from ..groups.common import VERSION

    tiles, base, overrides = P.checked_options(output, workers, worker_timeout, threads,
                                               empty_tiles, tiles, settings_file, defaults)
    if open_file:
        if not bpy.data.filepath:
            raise P.BatchError("the open file has never been saved: save it, or give .blend "
                               "files")
        blends = [bpy.data.filepath]
        workers = 0                               # the open session is the one to bake
    # Unsaved changes: the file's hash says nothing of what is baked. is_dirty misses a
    # script's edits in a background session (the bpy module, blender -b): there, a second
    # call after an edit skipped the asset with the first call's map, and a later run on the
    # file skipped the maps of the edited session as the file's. Such a run bakes every asset
    # and records them as unsaved, which no run skips or reuses. A file the command line has
    # just opened holds none (is_dirty is True there up to 5.0: every task was baked again).
    unsaved = open_file and session_edits and (bpy.data.is_dirty or bpy.app.background)
    force = force or unsaved
    if not blends:
        raise P.BatchError("give .blend files to bake (or bake the open file)")
    per_file, whole = P.grouped_entries(blends)
    if list_tasks:
        list_tasks = (list_tasks[0], LT.entries(list_tasks[1]))
    blends = list(per_file)
    manifest_path = M.checked_path(manifest, output)
    M.hold(manifest_path)                 # one run per manifest (released below)
    manifest_existed = os.path.lexists(manifest_path)
    try:
        previous = M.read(manifest_path) or {"assets": {}}
    except P.BatchError:
        M.release(manifest_path)
        raise
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
        problem = P.blend_problem(blend)
        if problem:
            report["assets"][M.asset_key(blend, "*")] = {
                "file": blend, "object": None, "status": "failed", "kind": "input",
                "error": problem}
            continue
        prev = prev_files.get(blend)
        deps = prev.get("dependencies", []) if prev else []
        ihash = P.input_hash(blend, deps)
        files[blend] = {"input_hash": ihash, "dependencies": deps, "selection": selection,
                        **({"unsaved": True} if unsaved else {})}
        if prev and prev.get("input_hash") == ihash and prev.get("selection") == selection \
                and "scan" in prev and not unsaved and not prev.get("unsaved"):
            files[blend]["scan"] = prev["scan"]
            files[blend]["scan_reused"] = True
        else:
            to_scan.append(blend)
    pool = InProcess(log) if workers == 0 else \
        Pool(workers, worker_command_override, worker_env)
    progress = Progress(log)
    progress.known = len(report["assets"])          # the files refused already
    progress.unscanned = len(to_scan)
    outputs_seen, collisions, folders, too_long = {}, [], set(), []
    made_folders = []                     # output folders this run made (leaf first)
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
            # files not read yet (a stop while scanning): their assets are not known, and
            # "0 asset(s) not baked" told a farm log that nothing was left
            planned = {e["file"] for e in report["assets"].values()}
            unread = [b for b in files if b not in planned]
            report["interrupted"] = signal_name
            # No manifest yet (a stop while scanning) and no file read: a manifest would be a
            # new file with nothing a rerun uses, so none is written (and release removes the
            # folders the run made).
            recorded = manifest_path.exists() or any(
                ("scan" in f and not f.get("scan_reused")) or "scan_error" in f
                for f in files.values())
            if recorded:
                M.write_last(manifest_path, M.merged(previous, report, files))
            M.release(manifest_path)
            interrupts.say(f"[batch] {signal_name}: stopped {n} worker process(es); "
                           f"{len(left)} asset(s) not baked" +
                           (f", {len(unread)} file(s) not read yet (a rerun reads and bakes "
                            f"them)" if unread else "") +
                           (f", recorded as interrupted in {manifest_path}" if recorded else
                            "; nothing was recorded (no manifest written)"))
        finally:
            if held:
                pool.lock.release()

    def step_entry(entry):
        what = f"{Path(entry['file']).name}:{entry.get('object') or '*'}"
        progress.step(entry["status"], what,
                      f": {entry['error']}" if entry["status"] == "failed" else "")

    def plan_file(blend):
        """(the bake requests of one scanned file, its failed and skipped entries)."""
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
            key = M.asset_key(blend, a["object"])
            s = P.asset_settings(base, overrides, name, a["object"])
            entry = {"file": blend, "object": a["object"], "settings": s}
            entries.append(entry)
            problem = P.asset_problem(a, s, name)
            if problem:
                entry.update(status="failed", kind="input", error=problem)
                continue
            uv = s["uv_map"] or a["active_uv"] or next(iter(a["uv_maps"]))
            s = dict(s, uv_map=uv)
            entry["settings"] = s
            out = P.expand(output, name, a["object"], uv)
            entry["output"] = out
            problem = NB.blender_path_problem(out)
            if problem:                    # (before any folder is made)
                too_long.append(f"{name}:{a['object']}: {problem}")
            # (resolved: two names of one folder through a symbolic link or '..' are one file)
            seen_as = output_key(Path(out).resolve())
            if seen_as in outputs_seen:
                other, other_blend, other_out = outputs_seen[seen_as]
                if other_out != out and Path(other_out).resolve() == Path(out).resolve():
                    collisions.append(
                        f"{name}:{a['object']} and {other} would write {out} and "
                        f"{other_out}, one file ({Path(out).resolve()}, through a symbolic "
                        f"link or '..' on the way): the second map would replace the first; "
                        f"make the output pattern tell them apart, or bake them in two runs")
                elif other_out != out:         # one file where case (or form) is ignored
                    collisions.append(
                        f"{name}:{a['object']} and {other} would write {out} and "
                        f"{other_out}, one file on this file system "
                        f"({one_file_because(out, other_out)}): the second map would replace "
                        f"the first; rename one, or make the output pattern tell them apart")
                elif other == f"{name}:{a['object']}":     # same names, files in two folders
                    collisions.append(
                        f"{blend}:{a['object']} and {other_blend}:{a['object']} would both "
                        f"write {out}: no output token can tell them apart (one file name, "
                        f"two folders); bake them in two runs with their own output folders, "
                        f"or rename one")
                else:
                    collisions.append(f"{name}:{a['object']} and {other} would both write "
                                      f"{out}: make the output pattern tell them apart "
                                      f"({', '.join(P.TOKENS)})")
                continue
            problem = list_tasks and LT.clash(list_tasks[1], list_tasks[0], output, base,
                                              overrides, blend, a["object"], uv, seen_as)
            if problem:
                collisions.append(problem)
                continue
            outputs_seen[seen_as] = (f"{name}:{a['object']}", blend, out)
            entry["input_hash"] = f["input_hash"]
            if unsaved:
                entry["unsaved"] = True
            entry["settings_hash"] = P.settings_hash(s, out, blender_version, VERSION)
            prev = previous["assets"].get(key, {})
            ours = P.unchanged_outputs(prev)
            # the tiles this bake writes: an earlier run of some (--tiles) skips none of the rest
            written = [t for t in a["uv_maps"].get(uv) or [] if tiles is None or t in tiles]
            if not force and prev.get("status") in ("baked", "skipped") and ours and \
                    not prev.get("unsaved") and \
                    prev.get("input_hash") == entry["input_hash"] and \
                    prev.get("settings_hash") == entry["settings_hash"] and \
                    set(map(str, written)) <= set(prev["files"]):
                entry.update(status="skipped", files=prev["files"], tiles=prev.get("tiles"),
                             warnings=prev.get("warnings", []),
                             note="inputs, settings and outputs unchanged (--force bakes "
                                  "again)")
                continue
            folders.add(Path(out).parent)
            n_tiles = len(tiles) if tiles else len(a["uv_maps"].get(uv) or [1])
            jobs.append({"op": "bake", "id": key, "file": blend,
                         "timeout": worker_timeout or P.bake_timeout(s, n_tiles),
                         "blend": None if open_file else blend, "object": a["object"],
                         "output": str(_resolved_folder(out)), "settings": s, "tiles": tiles,
                         "empty_tiles": empty_tiles, "threads": threads,
                         # our own earlier, unmodified outputs may be replaced
                         "overwrite": overwrite or P.replaceable(prev, out, written)})
        for entry in entries:
            report["assets"][M.asset_key(blend, entry.get("object") or "*")] = entry
        progress.known += len(entries)
        return jobs, [e for e in entries if e.get("status") in ("failed", "skipped")]

    def on_pending(req, maps):
        """A bake is about to put `maps` ({tile: (final, temporary file)}) in place: record
        them first, with the hash of what they will hold, so that a run killed before it
        records the bake (SIGKILL, a worker's crash) is followed by one that knows them as
        its own (plan.replaceable), not as someone's file that "exists"."""
        entry = report["assets"][req["id"]]
        try:
            entry["pending"] = {str(t): {"path": str(final), "sha256": P.sha256_file(temp)}
                                for t, (final, temp) in maps.items()}
        except OSError:                 # (gone: its publish fails and says so)
            return
        try:
            M.write_pending(manifest_path, M.merged(previous, report, files))
        except MapNotWritten:           # (the bake puts nothing in place: no record of it)
            entry.pop("pending")
            raise

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
                    f["input_hash"] = P.input_hash(req["file"], f["dependencies"])
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
            # (it may have died after putting its maps in place: they are its own)
            req["overwrite"] = req["overwrite"] or P.replaceable(entry, req["output"], [])
            log(f"[batch] {what}: {reply['error']} - retrying once in a fresh process")
            return []
        if reply["status"] == "ok":
            reply = _read_back(reply)
        if reply["status"] == "ok":
            entry.pop("pending", None)
            entry.update(status="baked", tiles=reply["tiles"], uv_map=reply["uv_map"],
                         depth=reply["depth"], warnings=reply["warnings"],
                         timings={k: reply.get(k) for k in ("load_s", "bake_s", "save_s",
                                                            "total_s", "cpu_s")},
                         files={**P.same_bake_files(previous["assets"].get(req["id"], {}),
                                                    entry),
                                **{t: {"path": p, "sha256": reply["sha256"][t]}
                                   for t, p in reply["paths"].items()}})
            f = files[req["file"]]
            if reply["dependencies"] != f["dependencies"]:
                f["dependencies"] = reply["dependencies"]
                f["input_hash"] = P.input_hash(req["file"], f["dependencies"])
                entry["input_hash"] = f["input_hash"]
            progress.step("baked", what, f": tile(s) {NB._tiles_text(reply['tiles'])}"
                                         f" in {reply['total_s']:.1f} s")
            for w in reply["warnings"]:
                warn(f"{what}: {w}")
        else:
            entry.update(status="failed", kind=reply.get("kind"), error=reply["error"])
            progress.step("failed", what, f": {reply['error']}")
        M.write(manifest_path, M.merged(previous, report, files))
        return []

    try:
        for entry in list(report["assets"].values()):
            step_entry(entry)
        log(f"[batch] {len(files)} file(s), {len(to_scan)} to scan; baking with {how}")
        # 1. Read every file, 2. plan and check the whole batch, 3. only then bake.
        with interrupts.on_stop(stop_batch):
            pool.map([{"op": "scan", "file": b, "blend": None if open_file else b,
                       "timeout": worker_timeout or P.SCAN_TIMEOUT_S,
                       **files[b]["selection"]} for b in to_scan], on_reply)
            requests, settled = [], []
            for blend in files:
                jobs, done = plan_file(blend)
                requests += jobs
                settled += done
            for entry in settled:          # once every file is planned: the total is known
                step_entry(entry)
            # (a path past what the file system takes is said as such, not as past Blender's)
            problems = collisions + (sorted({p for p in map(BR.folder_problem, folders) if p})
                                     or too_long)
            if problems:
                raise P.BatchError(P.joined(problems) + "\n(nothing was baked)")
            for folder in sorted(folders):
                made_folders[:0] = [f for f in (folder, *folder.parents) if not f.exists()]
                folder.mkdir(parents=True, exist_ok=True)
                _note_leftovers(folder, warn)
            M.write(manifest_path, M.merged(previous, report, files))
            pool.map(requests, on_reply, on_pending)
        report["process_start_s"] = pool.start_times()
    except BaseException:
        M.release(manifest_path)          # a refusal, an error: the run ends here
        raise
    finally:
        pool.close()
    report["total_s"] = time.perf_counter() - t_start
    report["counts"] = dict(progress.counts)
    report["manifest"] = str(manifest_path)
    try:
        M.write_final(manifest_path, M.merged(previous, report, files))
    except BaseException:
        _remove_unrecorded(manifest_path, manifest_existed, report, made_folders)
        raise
    finally:
        M.release(manifest_path)
    c = progress.counts
    log(f"[batch] {c['baked']} baked, {c['skipped']} skipped, {c['failed']} failed in "
        f"{report['total_s']:.1f} s; manifest {manifest_path}")
    return report


def _resolved_folder(out):
    """The output with its folder resolved (absolute, for a worker) and its file name as given:
    resolved whole, a symbolic link as the output was followed, so the checks named its target
    ("output '/dev/null': use a .png or .exr file name" for maps/Rock.png -> /dev/null) and the
    map replaced the file it pointed to, where bake-normal-map checks the link itself."""
    return Path(out).parent.resolve() / Path(out).name


def _remove_unrecorded(manifest_path, existed, report, made_folders):
    """The run's last manifest write failed (a full disk). Where this run made the manifest
    and put no map in place, the one its earlier writes left holds only the scan, and the
    folders it made are empty: both are removed, so that the failure leaves nothing behind
    (before: a 1.2 kB manifest of the scan in an empty maps/ folder, exit 1). A manifest that
    records a map this run put in place (or may have: a pending record) stays: a rerun must
    know that map as its own."""
    if existed or any(e.get("status") == "baked" or e.get("pending")
                      for e in report["assets"].values()):
        return
    try:
        Path(manifest_path).unlink(missing_ok=True)
    except OSError:
        return
    for folder in made_folders:               # leaf first; one holding a file stays
        try:
            folder.rmdir()
        except OSError:
            pass


def _note_leftovers(folder, warn):
    """Name the temporary files of other runs in an output folder, and the old maps they kept
    aside while putting theirs in place: a run killed with SIGKILL leaves its own (a map being
    checked, a manifest being written, an old map), and one of them may be a run under way on
    another machine, so they are named for the TD, not removed."""
    found = interrupts.others_partials(folder)
    if found:
        warn(f"{len(found)} temporary file(s) of other runs in {str(folder)!r} "
            f"({', '.join(found[:3])}{', ...' if len(found) > 3 else ''}): left by killed "
            f"runs, or runs under way elsewhere; once no run writes there, remove them "
            f"(rm {str(folder / '.*.part*-*')})")
    backups = others_backups(folder)
    sole = [b.name for b, final in backups if not os.path.lexists(final)]
    if backups:
        warn(f"{len(backups)} old file(s) kept aside by other runs in {str(folder)!r} "
             f"({', '.join(b.name for b, _ in backups[:3])}{', ...' if len(backups) > 3 else ''}"
             f"): left by runs killed while putting their maps in place, or runs under way "
             f"elsewhere; once no run writes there, remove them"
             + (f", except {', '.join(sole[:3])}{', ...' if len(sole) > 3 else ''}: the only "
                f"copy of a map whose name is gone, rename it back to that name (without the "
                f"leading '.' and the '.old-...' end)" if sole else ""))


def _read_back(reply):
    """A bake's reply with the hashes of the maps it put in place; a failure (kind "output")
    where one cannot be read back. The output folder removed, renamed or unmounted while the
    batch ran (a TD's clean-up, a share gone), or another process removing the map, between
    the worker putting it in place and this read: the FileNotFoundError ended the thread that
    served that worker, a raw traceback, and the asset was left with no status in the
    manifest and counted nowhere (8 assets: "6 baked, 0 skipped, 1 failed")."""
    hashes = {}
    for tile, path in reply["paths"].items():
        try:
            hashes[tile] = P.sha256_file(path)
        except OSError as err:
            return dict(reply, status="error", kind="output", error=(
                f"the map {path} was baked and put in place, then could not be read back "
                f"({err.strerror}): its folder was removed, renamed or unmounted while the "
                f"batch ran, or another process removed or replaced it; make sure nothing "
                f"else writes there and run the batch again"))
    return dict(reply, sha256=hashes)
