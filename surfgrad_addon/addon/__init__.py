"""The extension artists install (needs bpy): node groups built by code, the Add menu, operators
and the sidebar panel, the normal-map bake for TDs and its `blender -c surfgrad` commands. It
imports only itself and the numpy reference, never the proving harness (tests/test_layers.py)."""
