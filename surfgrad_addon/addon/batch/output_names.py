"""Whether two of a batch's output paths name one file: on a file system that ignores case
(macOS and Windows by default, many SMB shares), `Rock.png` and `rock.png` are one file, and
the second asset's map would replace the first's with exit 0. The file system is asked, not
assumed: a probe file is made in the nearest folder that exists and looked up in another case."""

import os
import uuid
from pathlib import Path


def ignores_case(folder):
    """True when the file system holding `folder` (or its nearest existing parent) finds a file
    under a name in another case; False where it does not, or where no probe can be made (the
    output checks name an unwritable folder on their own)."""
    folder = Path(folder)
    while not _is_dir(folder) and folder.parent != folder:
        folder = folder.parent
    return _probe(str(folder))


_ANSWERS = {}


def _probe(existing):
    """One probe per existing folder (a batch's outputs mostly share one), not one per asset;
    a folder where no probe could be made is asked again next time (it may take files then)."""
    if existing in _ANSWERS:
        return _ANSWERS[existing]
    folder = Path(existing)
    probe = folder / f".surfgrad-case-probe-{uuid.uuid4().hex}"
    try:
        probe.touch(exist_ok=False)
    except OSError:
        return False
    try:
        _ANSWERS[existing] = os.path.exists(folder / probe.name.upper())
    finally:
        probe.unlink(missing_ok=True)
    return _ANSWERS[existing]


def _is_dir(path):
    try:
        return path.is_dir()
    except OSError:                 # a name too long for the file system: the checks say so
        return False


def output_key(path):
    """The key under which two outputs collide: the path, folded in case where its file system
    ignores case."""
    return str(path).casefold() if ignores_case(str(Path(path).parent)) else str(path)
