"""The proving harness's Python API (needs bpy and a checkout: the extension does not ship the
harness). The add-on's own API is surfgrad_addon.api.

    from surfgrad_addon.harness import api as harness_api
    report = harness_api.compare(bpy.data.objects["Rock"], "triplanar", resolution=128)
    report, heat = harness_api.compare(rock, "normal-map", 256, with_heat_map=True)

compare bakes the method's node groups on the object with Cycles and compares them texel by
texel with the numpy reference: the report dict (mean / p99 / max angular error in degrees,
texel counts, timings), with with_heat_map the per-texel error image too; tiles: the UDIM tiles
to bake and compare (default: what Blender's bake fills). The node groups it added are removed
again. Errors are ValueError subclasses naming the problem and the fix.
"""

from .compare import compare

__all__ = ["compare"]
