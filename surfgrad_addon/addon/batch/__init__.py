"""Batch normal-map bakes for pipelines: many objects, collections or .blend files in one call.

    blender -c surfgrad bake-batch assets/*.blend --output "maps/{file}/{object}.<UDIM>.png" \\
        --resolution 2048 --samples 16 --workers 4
    python -m surfgrad_addon bake-batch ...              (the same, from a checkout)
    api.bake_batch(["a.blend", "b.blend"], "maps/{file}_{object}.<UDIM>.exr", workers=2)

Each asset (a mesh object with a material) is baked by normal_bake.bake_normal_tiles into files
named by the output pattern ({file}: the .blend's name without extension, {object}, {uv}: the UV
map, <UDIM>: the tile). Settings (uv_map, space, resolution, samples, margin, depth) have
defaults and per-asset overrides from a JSON settings file. A manifest (JSON, beside the
outputs) records for every asset its settings, a hash of its inputs (the .blend and the files it
uses) and settings, timings, warnings and the files written (with their hashes); an asset whose
inputs, settings and outputs are unchanged is skipped unless force. With workers >= 1 the bakes
run in that many separate Blender processes (worker_main.py); a worker that dies or a bake
that fails unexpectedly is retried once in a fresh process; bad input fails that asset alone.
Files are written under a temporary name and renamed when complete (normal_bake).

The jobs: plan.py (options, settings, hashes, skip-unchanged), manifest.py, session.py (scan and
bake in one Blender session), workers.py and worker_main.py (the worker processes), progress.py,
run.py (bake_batch, the run itself).
"""

from .manifest import MANIFEST_NAME
from .plan import DEFAULTS, SETTING_KEYS, BatchError, bake_timeout, read_asset_list
from .run import bake_batch

__all__ = ["MANIFEST_NAME", "DEFAULTS", "SETTING_KEYS", "BatchError", "bake_batch",
           "bake_timeout", "read_asset_list"]
