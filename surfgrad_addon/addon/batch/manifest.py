"""The batch's manifest (JSON, beside the outputs): where it goes, reading it back, and
writing it whole, one write at a time."""

import errno
import json
import os
import sys
import threading
from pathlib import Path

from .. import bake_request as BR
from .. import interrupts
from ..exit_codes import BakeFailed, MapNotWritten
from .. import normal_bake as NB
from .plan import BatchError

MANIFEST_NAME = "surfgrad-bake-manifest.json"


def default_manifest(pattern):
    """The manifest beside the outputs: in the pattern's folder before its first token."""
    parts = Path(pattern).parent.parts
    fixed = []
    for part in parts:
        if "{" in part or NB.UDIM_TOKEN in part:
            break
        fixed.append(part)
    return Path(*fixed) / MANIFEST_NAME if fixed else Path(MANIFEST_NAME)


def checked_path(manifest, pattern):
    """The manifest's path (`manifest`, else default_manifest(pattern)), or BatchError if it
    cannot be written there."""
    problem = manifest and NB.blend_relative_problem(manifest, "manifest")
    if problem:
        raise BatchError(problem)
    if manifest and str(manifest).endswith(("/", os.sep)):
        # Path() drops the slash: `--manifest maps/manifests/` wrote a file `manifests`.
        raise BatchError(f"manifest {str(manifest)!r} ends in '/', a folder: give a file name "
                         f"in it (e.g. {os.path.join(str(manifest), MANIFEST_NAME)!r})")
    path = Path(manifest) if manifest else default_manifest(pattern)
    problem = BR.folder_problem(path.parent) or _manifest_problem(path)
    if problem:
        raise BatchError(f"manifest {path}: {problem}")
    return path


def _manifest_problem(path):
    """None if the manifest path can be read and replaced, else what is wrong with it."""
    if path.suffix.lower() in NB.FORMATS:       # (a map's name: --manifest maps/Rock.1001.png)
        return (f"ends in {path.suffix}, a map's name: a map the batch writes there would "
                f"replace it, and it the map (with --overwrite, the map was the manifest's "
                f"JSON, exit 0); name it .json")
    if path.is_dir():
        return f"is a folder; give a file path (e.g. {path / MANIFEST_NAME})"
    if path.exists() and not path.is_file():
        return "is not a regular file; give a file path"
    if path.is_symlink() and not path.exists():     # read as none, then replaced by a file
        return (f"is a symbolic link to {os.readlink(path)!r}, which does not exist (an "
                f"unmounted share or a moved file?): mount or restore it, or give another "
                f"--manifest")
    return None


def read(path):
    """The manifest at `path`, or None if there is none. A damaged or edited one, or a file
    that is no manifest, is refused (BatchError): read as none, the run would replace it
    and forget what it recorded, or trip over a value of the wrong type."""
    fix = "restore it, or move it away and bake again (--overwrite to replace the maps it " \
          "recorded)"
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except json.JSONDecodeError as e:
        raise BatchError(f"manifest {path} is damaged (not valid JSON: {e.msg}, line "
                         f"{e.lineno}): {fix}") from None
    except UnicodeDecodeError:
        raise BatchError(f"manifest {path} is not UTF-8 text (not a surfgrad manifest); give "
                         f"another --manifest path or remove that file") from None
    # (every manifest has the surfgrad version: a settings file, whose "assets" table of
    # patterns passed, was taken for one and replaced, exit 0)
    if not isinstance(data, dict) or not isinstance(data.get("assets"), dict) or \
            "surfgrad" not in data:
        raise BatchError(f"manifest {path} is not a surfgrad manifest (no \"assets\" table "
                         f"and \"surfgrad\" version); give another --manifest path or move "
                         f"that file away")
    problem = _shape_problem(data)
    if problem:
        raise BatchError(f"manifest {path} was edited or damaged: {problem}; {fix}")
    return data


def _shape_problem(data):
    """The first value the batch reads from an earlier manifest that has the wrong type."""
    tables = [(f"assets[{k!r}]", v) for k, v in data["assets"].items()]
    if not isinstance(data.get("files", {}), dict):
        return "\"files\" is not a table"
    tables += [(f"files[{k!r}]", v) for k, v in data.get("files", {}).items()]
    for where, value in tables:
        if not isinstance(value, dict):
            return f"{where} is not a table"
    for key, asset in data["assets"].items():
        for table in ("files", "earlier_files", "pending"):
            written = asset.get(table) or {}
            if not isinstance(written, dict) or not all(
                    isinstance(r, dict) and isinstance(r.get("path"), str) and
                    isinstance(r.get("sha256"), str) for r in written.values()):
                return f"assets[{key!r}][\"{table}\"] is not a table of {{path, sha256}} records"
    for key, f in data.get("files", {}).items():
        deps = f.get("dependencies", [])
        if not isinstance(deps, list) or not all(isinstance(d, str) for d in deps):
            return f"files[{key!r}][\"dependencies\"] is not a list of paths"
    return None


# One manifest write at a time. A stop (write_last) takes it for good before its own write:
# the process then ends, and no write of the main thread is left half done (a temporary) or
# lands after the stop's (a manifest without the interrupted assets).
_WRITE_LOCK = threading.Lock()


def write(path, data):
    """Write the manifest whole: a temporary file, then renamed over the old one. One that
    cannot be written (a full disk) is left as it was: the run goes on, and its last write
    (write_final) says so."""
    with _WRITE_LOCK:
        try:
            _write_json(path, data)
        except OSError:
            pass


def write_final(path, data):
    """The run's last write: BakeFailed (exit code 1), one line, when it cannot be written."""
    with _WRITE_LOCK:
        try:
            _write_json(path, data)
        except OSError as err:
            raise BakeFailed(_unwritten(path, err)) from None


def write_pending(path, data):
    """Record the files a bake is about to put in place (run.on_pending): MapNotWritten when
    the manifest cannot take it (a full disk), so that the bake puts nothing there. Before, the
    map went in unrecorded and the next run failed the asset on it ("exists")."""
    with _WRITE_LOCK:
        try:
            _write_json(path, data)
        except OSError as err:
            raise MapNotWritten(_unwritten(path, err, pending=True)) from None


def write_last(path, data):
    """The stop's write: holds the write lock for good (the process ends after this, and no
    other write may follow or overlap)."""
    _WRITE_LOCK.acquire(timeout=5)
    try:
        _write_json(path, data)
    except OSError as err:
        print(f"surfgrad: error: {_unwritten(path, err)}", file=sys.stderr, flush=True)


# A folder that stopped taking files (permissions changed, remounted read-only, immutable)
REFUSED = (errno.EACCES, errno.EPERM, errno.EROFS)


def _unwritten(path, err, pending=False):
    folder = repr(str(Path(path).parent))
    fix = (f"check that {folder} still takes files (its permissions, a read-only mount)"
           if err.errno in REFUSED else
           "raise this process's file-size limit (ulimit -f; a farm job's file-size limit)"
           if err.errno == errno.EFBIG else f"free space in {folder} (the disk may be full)")
    if pending:
        return (f"manifest {path} could not record the map before it was put in place "
                f"({err.strerror}), so none was: {fix} and bake again")
    return (f"manifest {path} could not be written ({err.strerror}): it does not record "
            f"this run; {fix} and bake again (--overwrite to replace the maps it could not "
            f"record)")


def _write_json(path, data):
    """Write `data` to a temporary file and rename it to `path`; a failed write leaves no
    temporary (OSError)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temp = interrupts.partial_path(path)      # its process token too: see interrupts.py
    try:
        temp.write_text(json.dumps(data, indent=1, sort_keys=False))
        os.replace(temp, path)
    finally:
        if temp.exists():
            temp.unlink()


# Manifests this process holds: path -> (lock file descriptor, lock path, folders it made).
_HELD = {}


def hold(path):
    """Take the manifest for this run (an exclusive lock on `.NAME.lock` beside it), or
    BatchError when another run holds it: two runs writing one manifest each write it whole
    from what they read at the start, and the last one's write drops the other's records (its
    maps then look like foreign files, refused without --overwrite). The system drops the lock
    when the process ends, SIGKILL included; re-entrant within a process. No-op without
    fcntl (Windows)."""
    try:
        import fcntl
    except ImportError:
        return
    path = Path(path)
    if path in _HELD:
        return
    made = [f for f in (path.parent, *path.parent.parents) if not f.exists()]   # leaf first
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = path.with_name(f".{path.name}.lock")
    while True:
        created = not lock.exists()
        fd = _open_lock(path, lock, made if created else [])
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            os.close(fd)
            if err.errno == errno.EBADF:   # (read only, on NFS, whose locks need writing)
                raise BatchError(_foreign_lock(path, lock, "this user may not write it")) \
                    from None
            if err.errno not in (errno.EWOULDBLOCK, errno.EAGAIN):
                # (an NFS share whose lock service does not answer: ENOLCK) not another run
                _remove(([lock.unlink] if created else []) + [f.rmdir for f in made])
                raise BatchError(f"manifest {path}: its folder's file system does not lock "
                                 f"files ({err.strerror}), so a second run on it could not "
                                 f"be stopped: check the share's lock service (NFS: lockd), "
                                 f"or give a --manifest on a disk that does") from None
            raise BatchError(f"manifest {path} is in use by another bake-batch run (it holds "
                             f"{lock}): wait for that run to end, or give this one another "
                             f"--manifest and output folder") from None
        # The run that held it removes the lock file as it lets go (release): a lock taken on
        # the file it removed holds nothing, so take the one now at that path.
        try:
            if os.stat(lock).st_ino == os.fstat(fd).st_ino:
                break
        except FileNotFoundError:
            pass
        os.close(fd)
    _HELD[path] = (fd, lock, made)


def _open_lock(path, lock, made):
    """The lock file's descriptor. Another user's lock file (a run of theirs into a shared
    folder, under way or killed with SIGKILL, which leaves it 0644) could not be opened for
    writing: a raw PermissionError ended the run. flock needs only reading (NFS aside); a lock
    that cannot be opened at all is a BatchError naming it."""
    try:
        return os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    except PermissionError:
        try:
            return os.open(lock, os.O_RDONLY)
        except OSError as err:
            reason = err.strerror
    except IsADirectoryError:
        raise BatchError(f"manifest {path}: {lock} is a folder, where bake-batch keeps the "
                         f"manifest's lock file: remove it (rmdir {lock})") from None
    except OSError as err:
        _remove([f.rmdir for f in made])
        raise BatchError(f"manifest {path}: its lock file {lock} cannot be made "
                         f"({err.strerror}): give a --manifest in a folder you can write "
                         f"to") from None
    raise BatchError(_foreign_lock(path, lock, f"this user may not open it: {reason}"))


def _foreign_lock(path, lock, why):
    return (f"manifest {path}: its lock file {lock} is another user's ({why}): a run of "
            f"theirs under way holds it (wait for it to end, or give this run another "
            f"--manifest and output folder), or one killed left it (remove it once no run "
            f"writes there: rm {lock})")


def release(path):
    """Give the manifest back (hold), removing the lock file and the folders hold made that
    are left empty."""
    fd, lock, made = _HELD.pop(Path(path), (None, None, None))
    if fd is None:
        return
    _remove([lock.unlink, *(f.rmdir for f in made)])
    os.close(fd)


def _remove(removals):
    for remove in removals:
        try:
            remove()
        except OSError:                           # (a folder with the maps in it stays)
            pass


def asset_key(blend, obj):
    """An asset's key in the manifest: "file:object" ("file:*" for the file itself)."""
    return f"{blend}:{obj}"


def merged(previous, report, files):
    """The manifest: this run's report, with earlier runs' assets and files kept."""
    out = dict(report)
    out["assets"] = dict(previous.get("assets", {}))
    for key, entry in report["assets"].items():
        # An asset not (yet) baked by this run (failed, interrupted, killed) keeps on record
        # the maps an earlier run wrote: forgotten, a rerun took them for someone's files
        # ("exists", exit 1) after any run that had not finished them.
        before = previous.get("assets", {}).get(key, {})
        earlier = before.get("files") or before.get("earlier_files")
        out["assets"][key] = dict(entry, earlier_files=earlier) \
            if earlier and not entry.get("files") else entry
    out["files"] = dict(previous.get("files", {}))
    for blend, f in files.items():
        out["files"][blend] = {"input_hash": f["input_hash"],
                               **({"unsaved": True} if f.get("unsaved") else {}),
                               "dependencies": f["dependencies"], "selection": f["selection"],
                               "load_s": f.get("scan_load_s"),
                               **({"scan": f["scan"]} if "scan" in f else {})}
    return out
