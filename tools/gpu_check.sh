#!/usr/bin/env bash
# surfgrad on Cycles' GPU devices (issue 21, item 4), in one run of a few minutes:
#   bash tools/gpu_check.sh [OUT_DIR]                      (default out/gpu)
# Needs an NVIDIA GPU and the main line's Python with bpy (PYTHON, default .venv/bin/python).
# Writes OUT_DIR/:
#   compare-<kind>/   every method baked on the GPU against the numpy reference (compare-all:
#                     compare.md / compare.json, heat maps), for the kind in COMPARE_KIND (OPTIX)
#   check-<kind>.json one method baked with each kind in CHECK_KINDS (CUDA): the other backend
#                     bakes the same normals
#   bench_render/     render cost against Blender's own nodes on the GPU (render_cost.md/.json,
#                     chart), BENCH_SIZE^2 pixels and BENCH_SAMPLES samples (1024, 128: a GPU
#                     renders the CPU bench's 320^2 x 64 in milliseconds, where timing is noise)
#   gpu_check.log     the devices, each step's command, seconds and exit status, and the last
#                     step's verdict: every GPU bake within the CPU's bars (p99 0.1, max 0.5 deg;
#                     a GPU compare's reference weights Linear lookups as the texture unit does)
# Each step has STEP_TIMEOUT seconds (240), the first bake (kernel compilation) WARM_TIMEOUT
# (600). Exit 0 only when every step succeeded.
set -uo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-.venv/bin/python}
OUT_DIR=${1:-out/gpu}
COMPARE_KIND=${COMPARE_KIND:-OPTIX}
CHECK_KINDS=${CHECK_KINDS:-CUDA}
BENCH_SIZE=${BENCH_SIZE:-1024}
BENCH_SAMPLES=${BENCH_SAMPLES:-128}
STEP_TIMEOUT=${STEP_TIMEOUT:-240}
WARM_TIMEOUT=${WARM_TIMEOUT:-600}
mkdir -p "$OUT_DIR"
LOG=$OUT_DIR/gpu_check.log
: > "$LOG"
failed=0

step() {        # step NAME COMMAND...: run it under the timeout, log its time and status
  local name=$1; shift
  local t0=$SECONDS
  echo "== $name: $*" | tee -a "$LOG"
  timeout "$STEP_TIMEOUT" "$@" 2>&1 | tee -a "$LOG"
  local rc=${PIPESTATUS[0]}
  echo "== $name: exit $rc after $((SECONDS - t0)) s" | tee -a "$LOG"
  [ "$rc" -eq 0 ] || failed=1
}

command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total \
  --format=csv,noheader | tee -a "$LOG"

# Where the wheel has no CUDA kernel for the card (an H100 or H200 with 5.2.3), build it on every
# core with the CUDA toolkit's ptxas first (tools/cycles_gpu_kernel.sh, a minute or so on 16 cores);
# without ptxas the warm-up below has the driver compile it on one core.
echo "== kernel: tools/cycles_gpu_kernel.sh" | tee -a "$LOG"
bash tools/cycles_gpu_kernel.sh "$PY" 2>&1 | tee -a "$LOG"

# Cycles compiles its GPU kernels on first use (OptiX's modules; CUDA's PTX where the wheel has
# no binary for the card): minutes once, then cached on disk. One small bake pays for it here.
STEP_TIMEOUT=$WARM_TIMEOUT step warm-up-"$COMPARE_KIND" "$PY" -m surfgrad_addon compare \
  --object Sphere --method normal-map --resolution 64 --cycles-device "$COMPARE_KIND" \
  --json "$OUT_DIR/warm-${COMPARE_KIND,,}.json"
step compare-all-"$COMPARE_KIND" "$PY" -m surfgrad_addon compare-all \
  --cycles-device "$COMPARE_KIND" --out "$OUT_DIR/compare-${COMPARE_KIND,,}" --overwrite
step bench-render-"$COMPARE_KIND" "$PY" -m surfgrad_addon bench-render --no-eevee \
  --cycles-device "$COMPARE_KIND" --size "$BENCH_SIZE" --samples "$BENCH_SAMPLES" \
  --out "$OUT_DIR/bench_render" --overwrite

for kind in $CHECK_KINDS; do
  step check-"$kind" "$PY" -m surfgrad_addon compare --object Sphere --method normal-map \
    --resolution 256 --cycles-device "$kind" --json "$OUT_DIR/check-${kind,,}.json"
done
# Every GPU bake is held to the CPU's bars (tests/test_bake_compare.py): p99 0.1, max 0.5 deg.
step bars "$PY" - "$OUT_DIR"/compare-*/compare.json "$OUT_DIR"/check-*.json <<'PY'
import json, sys
from pathlib import Path
reports = []
for name in sys.argv[1:]:
    if Path(name).is_file():
        got = json.loads(Path(name).read_text())
        reports += got if isinstance(got, list) else [got]
over = [f"{r['method']} ({r['variant']}) on {r['object']}: p99 {r['p99_deg']}, max "
        f"{r['max_deg']}" for r in reports
        if r["p99_deg"] is None or r["p99_deg"] > 0.1 or r["max_deg"] > 0.5]
print("no bake reports to check" if not reports else f"{len(reports)} bakes; " + (
      "every one within the bars (p99 0.1, max 0.5 degrees)" if not over else
      f"{len(over)} over the bars: " + "; ".join(over)))
sys.exit(1 if over or not reports else 0)
PY
echo "gpu_check: $([ $failed -eq 0 ] && echo 'every step succeeded' || echo 'a step failed'); \
log in $LOG" | tee -a "$LOG"
exit $failed
