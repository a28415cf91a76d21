"""Read run.sh's results and hold them against three models of a Linear lookup:
    python tools/texture_unit_probe/analyse.py RESULTS_DIR [docs/gpu_texture_unit.json]
        [tests/data/h100_texture_unit.npz]
exact weights (the CPU); the reference's earlier GPU model (each axis' weight rounded to the
nearest 1/256, ties to even, the corners its exact products); and the reference now
(image_sampling.gpu_texture_filter: ties up, the far corner's product rounded too). Writes the
share of lookups each model gets to float32 rounding, per run and coordinate set, and a sample of
the random-texel run for tests/test_gpu_texture_unit.py."""
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parents[1])]
from coords import N_SET, probe_sets                      # noqa: E402
from surfgrad_addon.reference import image_sampling as IS  # noqa: E402

TOLERANCE = 1e-6        # float32 rounding of a value in 0..1 (the results are float32)
SAMPLE = 2048           # lookups per coordinate set kept for the test


def texels(w, kind):
    """probe.cu's texture, (h, w, 2): its first two channels, row 0 at v = 0, as the values
    its texels decode to (kind: parity or random)."""
    if kind == "parity":
        y, x = np.mgrid[0:w, 0:w]
        return np.stack([x & 1, y & 1], axis=-1).astype(np.float64)
    s = np.uint64(12345)
    values = np.empty(w * w * 4)
    for i in range(len(values)):                # probe.cu's generator, in its order
        s = (s * np.uint64(1664525) + np.uint64(1013904223)) & np.uint64(0xFFFFFFFF)
        values[i] = float(int(s) >> 8) / 16777216.0
    return values.reshape(w, w, 4)[..., :2]


def earlier_model(image, st, extension):
    """The reference before: axis weights np.round to 1/256, exact corner products."""
    h, w = image.shape[:2]
    index = (lambda i, n: i % n) if extension == "REPEAT" else (lambda i, n: np.clip(i, 0, n - 1))
    x = st[:, 0].astype(np.float64) * w - 0.5
    y = st[:, 1].astype(np.float64) * h - 0.5
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    tx = (np.round((x - x0) * 256) / 256)[:, None]
    ty = (np.round((y - y0) * 256) / 256)[:, None]
    c = lambda yy, xx: image[index(yy, h), index(xx, w)]
    return ((1 - ty) * ((1 - tx) * c(y0, x0) + tx * c(y0, x0 + 1))
            + ty * ((1 - tx) * c(y0 + 1, x0) + tx * c(y0 + 1, x0 + 1)))


def models(image, st, extension):
    st = st.astype(np.float64)
    with IS.gpu_texture_filter():
        now = IS.sample_image(image, st, extension=extension)
    return {"exact": IS.sample_image(image, st, extension=extension),
            "earlier": earlier_model(image, st, extension), "now": now}


def main(argv):
    results = Path(argv[0])
    dest = Path(argv[1]) if len(argv) > 1 else HERE.parents[1] / "docs" / "gpu_texture_unit.json"
    sample = Path(argv[2]) if len(argv) > 2 else \
        HERE.parents[1] / "tests" / "data" / "h100_texture_unit.npz"
    gpu = (results / "gpu.txt").read_text().strip()
    report = {"gpu": gpu, "lookups_per_set": N_SET, "tolerance": TOLERANCE, "runs": []}
    kept = {}
    for path in sorted(results.glob("r_*.npz")):
        name = path.stem
        if name.endswith("_texels"):
            continue
        _, w, address, memory, *rest = name.split("_")
        w, kind = int(w), (rest or ["parity"])[0]
        got = np.load(path)["a"].astype(np.float64)
        sets = probe_sets(w)
        image = texels(w, kind)
        if address == "clamp":
            image_ext = "EXTEND"
        else:
            image_ext = "REPEAT"
        run = {"run": name, "size": w, "address": address, "memory": memory,
               "texels": kind, "sets": {}}
        for k, (set_name, st) in enumerate(sets.items()):
            ref = got[k * N_SET:(k + 1) * N_SET]
            got_by = models(image, st, "EXTEND" if address == "clamp" else "REPEAT")
            shares = {m: float(np.mean(np.all(np.abs(v - ref) <= TOLERANCE, -1)))
                      for m, v in got_by.items()}
            shares.update({f"{m}_max_error": float(np.abs(v - ref).max())
                           for m, v in got_by.items() if m != "exact"})
            run["sets"][set_name] = shares
            if kind == "random":
                pick = np.random.default_rng(k).choice(N_SET, SAMPLE, replace=False)
                kept[f"st_{set_name}"] = st[pick]
                kept[f"gpu_{set_name}"] = ref[pick].astype(np.float32)
        if kind == "random":
            kept["texels"] = image.astype(np.float32)
        report["runs"].append(run)
        print(name, {s: {m: round(v, 6) for m, v in r.items()} for s, r in run["sets"].items()})
    dest.write_text(json.dumps(report, indent=1) + "\n")
    if kept:
        np.savez_compressed(sample, gpu=np.array(gpu), **kept)
    print(f"wrote {dest} and {sample}")


if __name__ == "__main__":
    main(sys.argv[1:])
