"""The proving harness (needs bpy): Cycles bakes, their comparison with the numpy reference, the
speed-against-accuracy bench, the demo file, the main job and the command line. It imports the
add-on (surfgrad_addon.addon) and the reference; neither imports it. Not in the extension zip."""
