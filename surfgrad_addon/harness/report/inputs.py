"""What the report page reads: JSON files (a malformed one is an error naming the file) and
where a committed figure came from (its date and machine)."""

import datetime
import json
import subprocess
from pathlib import Path

from PIL import Image


class ReportInputError(ValueError):
    """An input of the report page cannot be read: the message names the file."""


def load_json(path, what):
    """The parsed JSON at path (None when the file is absent); `what` says which file it is in
    an error. A file that is there but is not JSON is an error, never skipped."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ReportInputError(f"{path} ({what}) is not valid JSON: {err}; rerun the command "
                               f"that writes it") from None


def need(data, path, *keys):
    """data[keys[0]][keys[1]]... or a ReportInputError naming the file and the missing key."""
    value = data
    for key in keys:
        try:
            value = value[key]
        except (KeyError, IndexError, TypeError):
            raise ReportInputError(f"{path} has no {'/'.join(map(str, keys))}: not the shape "
                                   f"the report page reads; rerun the command that writes "
                                   f"it") from None
    return value


def git_date(path, repo_root):
    """The commit date (YYYY-MM-DD HH:MM UTC) of the last commit touching path, or None
    (not in git, no git)."""
    try:
        rel = Path(path).resolve().relative_to(Path(repo_root).resolve())
        done = subprocess.run(["git", "log", "-1", "--format=%ct", "--", str(rel)],
                              cwd=repo_root, capture_output=True, text=True, timeout=20)
    except (ValueError, OSError, subprocess.SubprocessError):
        return None
    stamp = done.stdout.strip()
    if done.returncode != 0 or not stamp:
        return None
    when = datetime.datetime.fromtimestamp(int(stamp), datetime.timezone.utc)
    return when.strftime("%Y-%m-%d %H:%M UTC") + " (commit)"


def machine_text(machine):
    """A JSON's machine record ({cpus, platform, ...} or a string) as a short phrase."""
    if isinstance(machine, str):
        return machine
    if not isinstance(machine, dict):
        return None
    parts = []
    if machine.get("cpus"):
        parts.append(f"{machine['cpus']} CPUs")
    for key in ("cpu", "gpu", "platform", "hostname"):
        if machine.get(key):
            parts.append(str(machine[key]))
    return ", ".join(parts) or None


def json_provenance(data, path, repo_root):
    """(date, machine) of a committed bench JSON: its own fields where it records them, else
    the commit date; the machine None where it records none."""
    date = None
    machine = None
    if isinstance(data, dict):
        date = data.get("date") or data.get("when") or data.get("generated")
        machine = machine_text(data.get("machine"))
        if machine is None and data.get("cpus"):
            machine = f"{data['cpus']} CPUs"
        if data.get("blender"):
            machine = ", ".join(filter(None, [machine, f"Blender {data['blender']}"]))
    return date or git_date(path, repo_root), machine


def png_provenance(path, repo_root):
    """(date, machine) of a committed picture: Blender's render stamp (Date, RenderTime) where
    the PNG carries it, else the commit date; Blender records no machine."""
    try:
        info = Image.open(path).info
    except OSError as err:
        raise ReportInputError(f"{path} is not a readable PNG: {err}") from None
    date = info.get("Date")
    if date:
        date = f"{date} (rendered" + (f" in {info['RenderTime']}" if info.get("RenderTime")
                                       else "") + ")"
    return date or git_date(path, repo_root), info.get("Hostname")
