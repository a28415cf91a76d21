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
    "cycles.texture_limit_render",
)
# Simplify's texture limit shrinks every image Cycles reads (to 128 px and up): a render
# setting for quick previews, which would bake a blurred map with exit 0; a bake lifts it.
NO_TEXTURE_LIMIT = "OFF"
