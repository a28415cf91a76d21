#!/usr/bin/env bash
# Cycles' CUDA kernel for this machine's NVIDIA card, where the bpy wheel has none:
#   bash tools/cycles_gpu_kernel.sh [PYTHON]          (default .venv/bin/python)
# The 5.2.3 wheel carries kernels for sm_50 to sm_86 and sm_120, none for an H100 or H200
# (sm_90): Cycles then has the driver compile the wheel's PTX on first use, on one core (an
# earlier try on an H200 did not see that finish within its time). ptxas from a CUDA toolkit
# builds the same kernel from the same PTX on every core (a minute or so on a 16-core H100
# machine) into the wheel's cycles/lib, where Cycles looks before the PTX. Remove
# kernel_sm_XY.cubin.zst there to go back to the wheel as shipped.
# CUDA_HOME names the toolkit (default: ptxas on the PATH, else /usr/local/cuda*).
# Exit 0 when the kernel is there (built now or before) or not needed; 1 when it cannot be built.
set -uo pipefail
cd "$(dirname "$0")/.."
PY=${1:-.venv/bin/python}

cc=$(nvidia-smi --query-gpu=compute_cap --format=csv,noheader 2>/dev/null | head -1 | tr -d ' .')
[ -n "$cc" ] || { echo "cycles_gpu_kernel: no NVIDIA card (nvidia-smi)"; exit 1; }
# Found without importing bpy: once imported, bpy.__file__ can name the copy inside the wheel's
# scripts/modules, and Blender's start-up lines on stdout would hide the answer.
lib=$("$PY" -c "import importlib.util as u, pathlib; print(next(pathlib.Path(u.find_spec(
    'bpy').origin).parent.glob('*/scripts/addons_core/cycles/lib')))" 2>/dev/null | tail -1)
[ -d "$lib" ] || { echo "cycles_gpu_kernel: no Cycles kernel folder in $PY's bpy"; exit 1; }
out=$lib/kernel_sm_$cc.cubin.zst
[ -f "$out" ] && { echo "cycles_gpu_kernel: $out is there"; exit 0; }
ptx=$(ls "$lib"/kernel_compute_*.ptx.zst 2>/dev/null | sort -V | tail -1)
[ -n "$ptx" ] || { echo "cycles_gpu_kernel: no PTX in $lib"; exit 1; }
if [ -n "${CUDA_HOME:-}" ]; then          # the toolkit named, else the PATH's or the usual place
  ptxas=$(ls "$CUDA_HOME/bin/ptxas" 2>/dev/null)
else
  ptxas=$(command -v ptxas || ls /usr/local/cuda*/bin/ptxas 2>/dev/null | head -1)
fi
[ -n "$ptxas" ] || { echo "cycles_gpu_kernel: no ptxas (a CUDA toolkit); Cycles will compile" \
  "the PTX on first use instead (minutes)"; exit 1; }
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
split=; "$ptxas" --help 2>&1 | grep -q split-compile && split=--split-compile=0
t0=$SECONDS
unzstd() {
  "$PY" - "$1" "$2" <<'PY'
import sys, zstandard
with open(sys.argv[1], "rb") as f, open(sys.argv[2], "wb") as o:
    zstandard.ZstdDecompressor().copy_stream(f, o)
PY
}
tozstd() {     # one frame written whole records its size, which Cycles' reader needs
  "$PY" - "$1" "$2" <<'PY'
import os, sys, zstandard
data = open(sys.argv[1], "rb").read()
open(sys.argv[2] + ".part", "wb").write(zstandard.ZstdCompressor(level=3).compress(data))
os.replace(sys.argv[2] + ".part", sys.argv[2])
PY
}
if ! unzstd "$ptx" "$work/k.ptx" || ! "$ptxas" -arch="sm_$cc" $split "$work/k.ptx" -o "$work/k.cubin" \
   || ! tozstd "$work/k.cubin" "$out"; then
  echo "cycles_gpu_kernel: building sm_$cc failed"; exit 1
fi
echo "cycles_gpu_kernel: built $out from $(basename "$ptx") in $((SECONDS - t0)) s"
