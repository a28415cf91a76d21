"""The render-depsgraph reader lives in the addon layer (bakes use it too): re-exported here."""

from ..addon.render_mesh import ENGINE_ID, RenderMeshError, read_in_render_mode  # noqa: F401
