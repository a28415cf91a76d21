"""Where float32 positions stop being precise enough and the groups' far-from-origin route
takes over. No bpy here: the harness's numpy-only code (scale_limits) reads these too."""

# Beyond this distance from the origin (metres) float32 world positions step by 7.6e-6 m or
# more: projector coordinates switch to their precise route there. Near the origin the Texture
# Coordinate node itself is used (EEVEE picks its image mip levels the same way as before).
FAR_METRES = 64.0


# Beyond this many texture repeats from the texture's origin the object's origin is far: its
# world coordinate is taken modulo one repeat (float32 steps there exceed 1e-5 of a repeat).
FAR_REPEATS = 64.0
