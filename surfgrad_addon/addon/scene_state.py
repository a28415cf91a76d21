"""Scene settings a bake touches, remembered and put back: the add-on's normal-map bake and the
proving harness's bakes both change nothing in the user's scene beyond what was asked."""

from contextlib import contextmanager


def _get_attr(root, path):
    for part in path.split("."):
        root = getattr(root, part)
    return root


def _set_attr(root, path, value):
    parts = path.split(".")
    for part in parts[:-1]:
        root = getattr(root, part)
    setattr(root, parts[-1], value)


@contextmanager
def restored(root, paths):
    """Remember the given attribute paths of `root` and put them back on exit."""
    saved = [(p, _get_attr(root, p)) for p in paths]
    try:
        yield
    finally:
        for p, v in reversed(saved):
            _set_attr(root, p, v)


# Everything on the scene a bake touches.
SCENE_SETTINGS = (
    "render.engine", "cycles.device", "cycles.samples", "cycles.use_denoising",
    "cycles.use_adaptive_sampling", "cycles.seed", "cycles.sample_clamp_direct",
    "cycles.sample_clamp_indirect", "cycles.bake_type", "render.bake.margin",
    "render.bake.use_clear", "render.bake.target", "render.bake.use_selected_to_active",
    "cycles.texture_limit_render", "render.use_motion_blur", "cycles.use_camera_cull",
    "cycles.use_distance_cull",
)
# Simplify's texture limit shrinks every image Cycles reads (to 128 px and up): a render
# setting for quick previews, which would bake a blurred map with exit 0; a bake lifts it.
NO_TEXTURE_LIMIT = "OFF"


def without_render_effects(scene):
    """What a render does to the scene that a bake must not, off for the bake (put back by
    restored(scene, SCENE_SETTINGS)):
    - motion blur: Cycles syncs the scene at the shutter's centre, half a shutter after the
      current frame for the Start position, before it for End, so an animated object baked
      moved or deformed (measured on 5.2: a shape key animated over 2 frames, shutter 1,
      Start: the object-space map 16 deg off the current frame's; compare called a correct
      group 58 deg wrong on an animated rotation). A bake takes the current frame, as the
      viewport and the reference do;
    - Simplify's camera and distance culling: an object outside the camera's view (or far
      from it) is left out of the sync, and its bake was the background, a grey map of
      zero-length normals, with exit 0."""
    scene.render.use_motion_blur = False
    scene.cycles.use_camera_cull = False
    scene.cycles.use_distance_cull = False
