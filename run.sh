#!/usr/bin/env bash
# surfgrad's two commands. Each creates (once) and reuses the virtual environment .venv with
# the pinned requirements, then:
#   bash run.sh main [ARGS]   the main job: writes out/demo (maps, summary, overview picture)
#   bash run.sh test [ARGS]   the test suite (pytest ARGS)
#   bash run.sh bench [ARGS]  speed against accuracy of every method, stability: out/bench
#   bash run.sh bench-reference  throughput of the numpy reference: out/bench_reference.json
# Needs only Python 3.11 (python3.11, or python3 if that is 3.11; or set PYTHON).
set -euo pipefail
cd "$(dirname "$0")"

find_python() {
  for cand in "${PYTHON:-}" python3.11 python3; do
    [ -n "$cand" ] || continue
    if command -v "$cand" >/dev/null 2>&1 &&
       "$cand" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
      echo "$cand"; return 0
    fi
  done
  echo "surfgrad: Python 3.11 is required (bpy 5.0.1 wheels exist only for 3.11); set PYTHON" >&2
  return 1
}

VENV=.venv
if [ ! -x "$VENV/bin/python" ]; then
  py=$(find_python)
  echo "surfgrad: creating $VENV with $py" >&2
  "$py" -m venv "$VENV"
fi
stamp="$VENV/.requirements.sha256"
want=$(sha256sum requirements.txt | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ]; then
  echo "surfgrad: installing requirements into $VENV (bpy is large; pip's cache makes reruns quick)" >&2
  "$VENV/bin/python" -m pip install --quiet --upgrade pip
  "$VENV/bin/python" -m pip install --quiet -r requirements.txt
  echo "$want" > "$stamp"
fi

cmd=${1:-}
[ $# -gt 0 ] && shift
case "$cmd" in
  main) exec "$VENV/bin/python" -m surfgrad_addon demo --out out/demo --overwrite "$@" ;;
  test) bash tools/install_eevee_deps.sh || true      # Mesa EGL for the EEVEE test
        exec "$VENV/bin/python" -m pytest "$@" ;;
  bench) exec "$VENV/bin/python" -m surfgrad_addon bench --out out/bench --overwrite "$@" ;;
  bench-reference) exec "$VENV/bin/python" -m surfgrad_addon bench-reference \
           --out out/bench_reference.json --overwrite "$@" ;;
  *) echo "usage: bash run.sh main|test|bench|bench-reference [ARGS]" >&2; exit 2 ;;
esac
