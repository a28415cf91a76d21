"""Blender glue (needs bpy): node groups, mesh extraction, bakes and their comparison with the
numpy reference. Nothing in surfgrad_addon.reference imports from here."""
