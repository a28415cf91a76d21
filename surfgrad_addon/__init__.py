"""surfgrad: Mikkelsen's surface-gradient bump mapping framework for Blender.

This package is both the Blender extension and a plain Python package:
`surfgrad_addon.reference` is the numpy reference evaluator and must stay importable without
bpy, so nothing here imports bpy at module level. Blender calls register()/unregister(); they
import the user interface (and with it bpy) lazily. Blender 4.2 LTS to 5.2 LTS.
"""


def register():
    """Add the "Surface Gradient" submenu to the Shader Editor's Add menu."""
    from .blender import ui
    ui.register()


def unregister():
    """Remove the submenu and its operator; node groups already in files stay (plain data)."""
    from .blender import ui
    ui.unregister()
