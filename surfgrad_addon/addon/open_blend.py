"""Open a .blend without letting its own Python run.

Blender's -c loads the user's Preferences; with "Auto Run Python Scripts" on, a plain
open_mainfile would run the file's registered text blocks and Python drivers. Every place
that opens a user's file goes through here, with use_scripts=False."""

from pathlib import Path


class BlendOpenError(ValueError):
    """The file is not a .blend Blender can open (a bad request, not a crash)."""


def open_mainfile(path, load_ui=False):
    """Open `path` with scripts off (text blocks and Python drivers stay disabled)."""
    import bpy
    if Path(path).is_dir():
        raise BlendOpenError(f".blend file {str(path)!r} is a folder: give a .blend file")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=load_ui, use_scripts=False)
    except RuntimeError as err:       # Blender's own text starts "Error: ": say it once
        reason = str(err).strip()
        reason = reason[len("Error:"):].strip() if reason.startswith("Error:") else reason
        raise BlendOpenError(f".blend file {str(path)!r} could not be opened ({reason}): "
                             f"give a .blend file Blender can open") from None
