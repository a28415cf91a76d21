"""Open a .blend without letting its own Python run.

Blender's -c loads the user's Preferences; with "Auto Run Python Scripts" on, a plain
open_mainfile would run the file's registered text blocks and Python drivers. Every place
that opens a user's file goes through here, with use_scripts=False."""


def open_mainfile(path, load_ui=False):
    """Open `path` with scripts off (text blocks and Python drivers stay disabled)."""
    import bpy
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=load_ui, use_scripts=False)
