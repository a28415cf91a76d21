#!/usr/bin/env bash
# Build probe.cu, look up every coordinate set on this machine's GPU, pack the results:
#   bash tools/texture_unit_probe/run.sh OUT_DIR     (writes OUT_DIR/<run>.npz)
set -euo pipefail
cd "$(dirname "$0")"
out=${1:?OUT_DIR}
work=$(mktemp -d)
nvidia-smi --query-gpu=name,driver_version,compute_cap --format=csv,noheader | tee "$out/gpu.txt"
nvcc -O2 -arch=native probe.cu -o "$work/probe"
# PROBE_RUNS: the runs, ';'-separated (at most 7 come back from a lent machine with gpu.txt).
IFS=';' read -r -a runs <<< "${PROBE_RUNS:-128 128 wrap array;128 128 wrap pitch;128 128 clamp \
array;32 32 wrap array;100 100 wrap array;128 128 wrap array random}"
for r in "${runs[@]}"; do
  set -- $r
  [ -f "$work/c$1.bin" ] || python3 coords.py "$1" "$work/c$1.bin"
  "$work/probe" "$1" "$2" "$3" "$4" "$work/c$1.bin" "$work/r_$1_$3_$4${5:+_$5}.bin" ${5:-}
done
python3 - "$work" "$out" <<'PY'
import sys, glob, os, numpy as np
work, dest = sys.argv[1:]
# One file per run (a file coming back from a lent machine is at most 16 MiB); the
# coordinates are coords.py's, made again where the results are read.
for p in sorted(glob.glob(work + "/r_*.bin")) + sorted(glob.glob(work + "/*.texels")):
    name = os.path.basename(p).replace(".bin.texels", "_texels").replace(".bin", "")
    a = np.fromfile(p, np.float32).reshape(-1, 4 if p.endswith("texels") else 2)
    np.savez_compressed(os.path.join(dest, name + ".npz"), a=a)
    print(name, a.shape, os.path.getsize(os.path.join(dest, name + ".npz")), "bytes")
PY
