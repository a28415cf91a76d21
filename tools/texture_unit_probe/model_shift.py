"""How far the reference's GPU lookup model now moves each method's reference from the earlier
one, on compare's test objects (64^2, as gpu_check.sh's compare-all):
    python tools/texture_unit_probe/model_shift.py [docs/gpu_model_shift.json]
Earlier: each axis' weight on the 1/256 grid (ties to even) and exact corner products, every
lookup through sample_image, as on the GPU machine that measured docs/gpu_compare.json (without
numba there: its one-texel height map agreed with the grid and not with exact weights). Where
the texture unit is what a GPU bake differs by, a GPU bake's p99 / max against the earlier
reference (docs/gpu_compare.json) is about this shift (docs/performance.md, "On a GPU")."""
import json
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
import bpy  # noqa: E402,F401  (the scenes)
from surfgrad_addon import reference as R  # noqa: E402
from surfgrad_addon.reference import image_sampling as IS, methods as M  # noqa: E402
from surfgrad_addon.harness import bake as B, scale_limits, scenes  # noqa: E402
from surfgrad_addon.harness.compare import prepare_inputs  # noqa: E402
from surfgrad_addon.harness.methods import METHODS, PARALLAX_SCALE, unavailable_reason  # noqa: E402
from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object  # noqa: E402
from surfgrad_addon.addon.precise_bake import precise_far  # noqa: E402

RESOLUTION = 64
OBJECTS = ("Sphere", "Transformed")


def _earlier_bilinear(rows, x0, x1, y0, y1, tx, ty):
    tx, ty = np.round(tx * 256) / 256, np.round(ty * 256) / 256
    row0 = np.take(rows, y0 + x0, axis=-1) * (1 - tx) + np.take(rows, y0 + x1, axis=-1) * tx
    row1 = np.take(rows, y1 + x0, axis=-1) * (1 - tx) + np.take(rows, y1 + x1, axis=-1) * tx
    return row0 * (1 - ty) + row1 * ty


@contextmanager
def earlier_model():
    saved = IS._texture_unit_bilinear
    IS._texture_unit_bilinear = _earlier_bilinear
    try:
        yield
    finally:
        IS._texture_unit_bilinear = saved


def normals(method, inp, td):
    with IS.gpu_texture_filter():
        blocks = [np.asarray(b[-1]) for b in M.evaluated_blocks(
            lambda b: M.resolve(method.reference(inp, b)), td)]
    return np.concatenate([b if b.shape[-1] == 3 else b.T for b in blocks]).reshape(-1, 3)


def shift(obj, name, variant):
    m = METHODS[name]
    inp = prepare_inputs(obj, None, None, variant)
    inp.parallax_scale, _ = scale_limits.parallax_depth(obj, PARALLAX_SCALE)
    scaled, inp.relief_scale = scale_limits.scaled_relief(obj, m)
    with m.scene(obj, inp), precise_far(obj, None):
        td = R.rasterize(mesh_arrays_from_object(obj), inp.uv_map, RESOLUTION, RESOLUTION,
                         facts=B.running_line(), as_baked=True)
        now = normals(scaled, inp, td)
        with earlier_model():
            before = normals(scaled, inp, td)
    cos = np.sum(now * before, -1) / np.linalg.norm(now, axis=-1) / np.linalg.norm(before, axis=-1)
    deg = np.degrees(np.arccos(np.clip(cos[np.isfinite(cos)], -1.0, 1.0)))
    return [round(float(np.percentile(deg, 99)), 4), round(float(deg.max()), 4)]


def main(argv):
    dest = Path(argv[0]) if argv else ROOT / "docs" / "gpu_model_shift.json"
    objects = scenes.new_scene()
    out = {"resolution": RESOLUTION, "blender": bpy.app.version_string, "shift": {}}
    for obj_name in OBJECTS:
        for name in sorted(METHODS):
            for variant in METHODS[name].variants:
                if unavailable_reason(name) is not None:
                    continue
                key = f"{name} {variant} {obj_name}" if len(METHODS[name].variants) > 1 else \
                    f"{name} {obj_name}"
                out["shift"][key] = shift(objects[obj_name], name, variant)
                print(key, out["shift"][key], flush=True)
    dest.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {dest}")


if __name__ == "__main__":
    main(sys.argv[1:])
