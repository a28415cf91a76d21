"""surfgrad: Mikkelsen's surface-gradient bump mapping framework for Blender.

This package is both the Blender extension (registration arrives with the node groups) and a
plain Python package: `surfgrad_addon.reference` is the numpy reference evaluator and must
stay importable without bpy, so nothing here imports bpy at module level.
"""
