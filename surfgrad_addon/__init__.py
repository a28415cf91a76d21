"""surfgrad: Mikkelsen's surface-gradient bump mapping framework for Blender.

This package is both the Blender extension and a plain Python package:
`surfgrad_addon.reference` is the numpy reference evaluator and must stay importable without
bpy, so nothing here imports bpy at module level. Blender calls register()/unregister(); they
import the user interface (and with it bpy) lazily. Blender 4.2 LTS to 5.2 LTS.
"""


def register():
    """Add the "Surface Gradient" submenu to the Shader Editor's Add menu, the operators and
    panel, and the `blender -c surfgrad` commands."""
    from .addon import commands, ui
    ui.register()
    commands.register()


def unregister():
    """Remove all of it; node groups already in files stay (plain data)."""
    from .addon import commands, ui
    commands.unregister()
    ui.unregister()
