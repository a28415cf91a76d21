"""Open a .blend without letting its own Python run.

Blender's -c loads the user's Preferences; with "Auto Run Python Scripts" on, a plain
open_mainfile would run the file's registered text blocks and Python drivers. Every place
that opens a user's file goes through here, with use_scripts=False."""

import re
import sys
from pathlib import Path


class BlendOpenError(ValueError):
    """The file is not a .blend Blender can open (a bad request, not a crash)."""


def open_mainfile(path, load_ui=False):
    """Open `path` with scripts off (text blocks and Python drivers stay disabled)."""
    import bpy
    if Path(path).is_dir():
        raise BlendOpenError(f".blend file {str(path)!r} is a folder: give a .blend file")
    if not Path(path).exists():       # a batch's file removed or renamed after its scan
        raise BlendOpenError(f".blend file {str(path)!r} does not exist (removed or renamed?): "
                             f"give a .blend file that exists")
    if not Path(path).is_file():     # a pipe would block the read
        raise BlendOpenError(f".blend file {str(path)!r} is not a regular file (a pipe or "
                             f"device?): give a .blend file")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=load_ui, use_scripts=False)
        # The loaded file's own version: the header of a compressed (zstd) file, Blender's
        # default for many artists, is not readable here and gave no warning.
        running = running_line()
        newer = _newer_line(tuple(bpy.data.version[:2]), running)
        if newer:            # Blender says so on stdout only, where a farm log buries it
            print(f"surfgrad: warning: .blend file {str(path)!r} was saved by Blender {newer}, "
                  f"newer than this Blender ({running[0]}.{running[1]}): "
                  f"what that line added to the file may be lost and the map may differ; "
                  f"bake with Blender {newer} or later", file=sys.stderr, flush=True)
        for lib in bpy.data.libraries:          # linked data comes from these files too
            newer = _newer_line(tuple(lib.version[:2]), running)
            if newer:
                print(f"surfgrad: warning: library {lib.filepath!r} of .blend file "
                      f"{str(path)!r} was saved by Blender {newer}, newer than this Blender "
                      f"({running[0]}.{running[1]}): what that line added to the linked data "
                      f"may be lost and the map may differ; bake with Blender {newer} or "
                      f"later", file=sys.stderr, flush=True)
    except RuntimeError as err:       # Blender's own text starts "Error: ": say it once
        reason = str(err).strip()
        reason = reason[len("Error:"):].strip() if reason.startswith("Error:") else reason
        running = f"{bpy.app.version[0]}.{bpy.app.version[1]}"
        newer = newer_than_running(path, bpy.app.version)
        if newer:              # e.g. 5.x's new file header, which 4.x calls "not a blend file"
            raise BlendOpenError(f".blend file {str(path)!r} could not be opened ({reason}); "
                                 f"it was saved by Blender {newer}, newer than this Blender "
                                 f"({running}): open it with Blender {newer} or later") from None
        library = _unreadable_library(reason, path)
        if library:            # the file opened; a library it links did not (4.2: 5.x's header)
            newer = newer_than_running(library, bpy.app.version)
            fix = f"it was saved by Blender {newer}, newer than this Blender ({running}): " \
                  f"bake with Blender {newer} or later" if newer else \
                  "put a readable copy of the library there, or relink the data"
            raise BlendOpenError(f"library {library!r}, which .blend file {str(path)!r} links "
                                 f"data from, could not be read ({reason}); {fix}") from None
        raise BlendOpenError(f".blend file {str(path)!r} could not be opened ({reason}): "
                             f"give a .blend file Blender can open") from None


def _unreadable_library(reason, path):
    """The other .blend Blender's error names ("Failed to read blend file '...'"): a library
    the file links, when it is not `path` itself; else None."""
    match = re.search(r"blend file '(.+?)'", reason)
    if match is None or Path(match.group(1)) == Path(path) or \
            Path(match.group(1)).resolve() == Path(path).resolve():
        return None
    return match.group(1)


def saved_by(header):
    """(major, minor) of the Blender that wrote a .blend, from its first 17 bytes, or None
    (not an uncompressed .blend). Two header layouts: 'BLENDER' + pointer size + endianness +
    3 digits (BLENDER-v402: 4.2), and from 5.0 'BLENDER' + header size + '-' + format version
    + endianness + 4 digits (BLENDER17-01v0502: 5.2)."""
    if not header.startswith(b"BLENDER"):
        return None
    rest = header[7:]
    if rest[:1] in (b"_", b"-") and rest[1:2] in (b"v", b"V") and rest[2:5].isdigit():
        number = int(rest[2:5])
    elif rest[:2].isdigit() and rest[2:3] == b"-" and rest[5:6] in (b"v", b"V") and \
            rest[6:10].isdigit():
        number = int(rest[6:10])
    else:
        return None
    return number // 100, number % 100


def running_line():
    """(major, minor) of the running Blender."""
    import bpy
    return tuple(bpy.app.version[:2])


def _newer_line(version, running):
    """'X.Y' when `version` is a newer Blender line than `running`, else None."""
    if version is None or tuple(version) <= tuple(running[:2]):
        return None
    return f"{version[0]}.{version[1]}"


def newer_than_running(path, running):
    """'X.Y' when `path` was saved by a newer Blender line than `running` (read from its
    header: for a file Blender could not open), else None."""
    try:
        with open(path, "rb") as f:
            version = saved_by(f.read(17))
    except OSError:
        return None
    return _newer_line(version, running)
