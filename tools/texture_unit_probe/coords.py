"""Lookup coordinates for probe.cu (float32 (u, v) pairs): python3 coords.py W OUT.
Four sets, one after the other, each N_SET lookups (probe_sets() names them)."""
import sys
import numpy as np

N_SET = 262144


def probe_sets(w):
    rng = np.random.default_rng(21)
    n = N_SET
    # 1. anywhere in the image; 2. tiled, -8..8 (wrap); 3. one texel swept at 1/65536 texel
    # steps in x (y at a texel centre); 4. a 64^2 bake's texel centres, then +-1 and +-2 ulp.
    one = rng.random((n, 2))
    tiled = rng.uniform(-8.0, 8.0, (n, 2))
    k = np.arange(n) % 65536
    row = np.arange(n) // 65536
    sweep = np.stack([(5 + 0.5 + (row * 7) + k / 65536.0) / w,
                      np.full(n, 9.5 / w)], axis=-1)
    c = (np.arange(64) + 0.5) / 64.0
    centres = np.stack(np.meshgrid(c, c), axis=-1).reshape(-1, 2).astype(np.float32)
    extra = [centres]
    for d in (1, -1, 2, -2):
        extra.append(np.nextafter(centres, np.float32(d * 10)) if abs(d) == 1 else
                     np.nextafter(np.nextafter(centres, np.float32(d * 10)), np.float32(d * 10)))
    near = np.concatenate(extra)
    near = np.resize(near, (n, 2))
    return {"one": one.astype(np.float32), "tiled": tiled.astype(np.float32),
            "sweep": sweep.astype(np.float32), "centres": near.astype(np.float32)}


if __name__ == "__main__":
    w = int(sys.argv[1])
    sets = probe_sets(w)
    np.concatenate(list(sets.values())).astype(np.float32).tofile(sys.argv[2])
