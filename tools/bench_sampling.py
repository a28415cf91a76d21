"""Image lookups per second: sample_image's numpy path against its compiled kernel
(reference/sampling_kernels.py), measured in the same run. Prints a table and writes it as JSON.

    python tools/bench_sampling.py OUT.json [--overwrite]

A 512 x 512 RGBA image (float32, float64) sampled at 256^2, 1024^2 and 2048^2 random points
in [-1, 2)^2, Linear and Closest, REPEAT; best of several runs; the numpy path with its channel
rows built once (images_unchanged, as evaluate_in_blocks runs it).
"""

import json
import os
import sys
from pathlib import Path

import numpy as np

from surfgrad_addon.harness.bench.reference import run_seconds
from surfgrad_addon.reference import compiled, image_sampling as IS

SIZES = (256, 1024, 2048)


def lookups_per_second(image, st, interpolation, flag, repeats):
    os.environ[compiled.ENV] = flag
    with IS.images_unchanged():
        fn = lambda: IS.sample_image(image, st, interpolation, "REPEAT")  # noqa: E731
        fn()
        return len(st) / min(run_seconds(fn, repeats))


def run(log=print):
    rng = np.random.default_rng(0)
    rows = []
    saved = os.environ.get(compiled.ENV)
    try:
        for dtype in (np.float32, np.float64):
            image = rng.random((512, 512, 4)).astype(dtype)
            for n in SIZES:
                st = rng.uniform(-1, 2, (n * n, 2)).astype(dtype)
                for interpolation in IS.INTERPOLATIONS:
                    repeats = 3 if n >= 2048 else 7
                    numpy_rate = lookups_per_second(image, st, interpolation, "0", repeats)
                    kernel_rate = lookups_per_second(image, st, interpolation, "1", repeats)
                    row = {"dtype": np.dtype(dtype).name, "lookups": n * n,
                           "interpolation": interpolation,
                           "numpy_M_per_s": round(numpy_rate / 1e6, 1),
                           "kernel_M_per_s": round(kernel_rate / 1e6, 1),
                           "speedup": round(kernel_rate / numpy_rate, 2)}
                    rows.append(row)
                    log(f"{row['dtype']:7s} {interpolation:7s} {n:4d}^2 lookups: "
                        f"numpy {row['numpy_M_per_s']:6.1f}  kernel {row['kernel_M_per_s']:6.1f}"
                        f" M lookups/s  x{row['speedup']:.1f}")
    finally:
        if saved is None:
            os.environ.pop(compiled.ENV, None)
        else:
            os.environ[compiled.ENV] = saved
    return rows


def main(argv):
    args = [a for a in argv if a != "--overwrite"]
    if len(args) != 1:
        print("usage: python tools/bench_sampling.py OUT.json [--overwrite]", file=sys.stderr)
        return 2
    out = Path(args[0])
    if out.exists() and "--overwrite" not in argv:
        print(f"{out} exists; pass --overwrite to replace it", file=sys.stderr)
        return 2
    if not compiled.enabled():
        print("numba is not installed (or SURFGRAD_REFERENCE_COMPILED=0): nothing to compare",
              file=sys.stderr)
        return 2
    import numba
    print(f"numba {numba.__version__}, {numba.get_num_threads()} threads, numpy {np.__version__}")
    rows = run()
    out.write_text(json.dumps({"numba": numba.__version__, "numpy": np.__version__,
                               "threads": numba.get_num_threads(), "rows": rows}, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
