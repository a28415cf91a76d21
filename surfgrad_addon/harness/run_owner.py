"""Which run owns a working folder left on a shared disk (staged_folder.py), and whether that
run is provably gone.

A run killed with SIGKILL (a farm's hard kill, the out-of-memory killer) leaves its hidden
`.NAME.partial-PID-TOKEN` folder behind. A process id says nothing on a farm's share: the
folder may be a live run's on another machine, or in another container on this one (each
with its own process ids). So a run records who it is (record) and a later run removes a
leftover only when it proves the owner gone: the same machine since the same boot (Linux's
boot_id), the same process-id space (its pid namespace), and no process of that id started
at that time. Anything else (another machine or container, no record, no /proc) is left."""

import json
import os
import socket
from pathlib import Path

RECORD_NAME = ".surfgrad-owner.json"


def _read(path):
    try:
        return Path(path).read_text().strip()
    except OSError:
        return ""


def _start_time(pid):
    """The process's start time in clock ticks since boot (/proc/PID/stat's field 22), or ""
    when there is no such process."""
    stat = _read(f"/proc/{int(pid)}/stat")
    return stat.rsplit(")", 1)[-1].split()[19] if stat else ""


def _pid_space():
    try:
        return os.readlink("/proc/self/ns/pid")
    except OSError:
        return ""


def identity(pid=None):
    """This process (or `pid` on this machine): machine, boot, process-id space, id, start."""
    pid = os.getpid() if pid is None else pid
    return {"host": socket.gethostname(), "boot": _read("/proc/sys/kernel/random/boot_id"),
            "pid_space": _pid_space(), "pid": pid, "start": _start_time(pid)}


def record(folder):
    """Write this process's identity into `folder` (RECORD_NAME)."""
    (Path(folder) / RECORD_NAME).write_text(json.dumps(identity()))


def gone(folder):
    """True only when the run that recorded itself in `folder` provably no longer runs."""
    try:
        owner = json.loads((Path(folder) / RECORD_NAME).read_text())
        pid, start = int(owner["pid"]), str(owner["start"])
    except (OSError, ValueError, KeyError, TypeError):
        return False
    here = identity()
    same_space = all(here[k] and owner.get(k) == here[k] for k in ("host", "boot", "pid_space"))
    return same_space and pid > 0 and bool(start) and not _runs(pid, start)


def _runs(pid, start):
    """Whether process `pid` that started at `start` may still run: another user's process
    (EPERM), or one whose start this process cannot read (/proc mounted with hidepid), is
    taken as running."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    now = _start_time(pid)
    return not now or now == start
