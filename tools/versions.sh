#!/usr/bin/env bash
# surfgrad on the older Blender lines: is blender_manifest.toml's blender_version_min honest?
#
#   bash tools/versions.sh               # 4.2 LTS and 4.5 LTS
#   bash tools/versions.sh 4.5           # one line (4.2 or 4.5)
#   bash tools/versions.sh 4.2 4.5 5.0   # 5.0 as a baseline: the main .venv (bash run.sh makes it)
#   bash tools/versions.sh --setup-only  # only create / update the virtual environments
#
# For each line it creates (once) and reuses .venv-bpy42 / .venv-bpy45 with the pinned
# tests/versions/requirements-X.Y.txt (bpy is ~300 MB; pip's cache makes reinstalls quick),
# then runs tests/versions/check.py there: build every node group (groups.build_all() and
# displace_group(), or check that SG Displace is refused with a clear message where the line
# lacks Set Mesh Normal), then bake every method of compare.METHODS (each height-map variant
# separately) on the four procedural test objects at 32 x 32 and hold each to the 5.0 suite's
# bar (p99 <= 0.1 and max <= 0.5 degrees). It prints a table per line and writes
# out/versions/bpy-X.Y.json. Exits non-zero if any line fails. Needs Python 3.11 (set PYTHON
# otherwise). The 5.0 line is the main suite's (bash run.sh test). See docs/versions.md.
set -euo pipefail
cd "$(dirname "$0")/.."

find_python() {
  for cand in "${PYTHON:-}" python3.11 python3; do
    [ -n "$cand" ] || continue
    if command -v "$cand" >/dev/null 2>&1 &&
       "$cand" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
      echo "$cand"; return 0
    fi
  done
  echo "versions: Python 3.11 is required (the bpy 4.2 and 4.5 wheels are 3.11 only); set PYTHON" >&2
  return 1
}

setup_only=0
lines=()
for arg in "$@"; do
  case "$arg" in
    --setup-only) setup_only=1 ;;
    4.2|42) lines+=(4.2) ;;
    4.5|45) lines+=(4.5) ;;
    5.0|50) lines+=(5.0) ;;
    *) echo "usage: bash tools/versions.sh [--setup-only] [4.2] [4.5] [5.0]" >&2; exit 2 ;;
  esac
done
[ ${#lines[@]} -gt 0 ] || lines=(4.2 4.5)

quiet_pip() {   # pip, without the machine's notes about unreachable extra indexes
  { "$@" 2>&1; } | { grep -v "is ignored: it is neither a file nor a directory" || true; } >&2
}

setup() {   # $1 = 4.2 | 4.5 | 5.0; prints the venv's python
  if [ "$1" = 5.0 ]; then
    [ -x .venv/bin/python ] || { echo "versions: no .venv yet: run 'bash run.sh test' once" >&2; return 1; }
    echo .venv/bin/python; return 0
  fi
  local line=$1 venv=".venv-bpy${1/./}" req="tests/versions/requirements-$1.txt"
  if [ ! -x "$venv/bin/python" ]; then
    local py; py=$(find_python)
    echo "versions: creating $venv with $py" >&2
    "$py" -m venv "$venv"
  fi
  # Keep git status clean without touching the repository's .gitignore.
  [ -f "$venv/.gitignore" ] || printf '*\n' > "$venv/.gitignore"
  local stamp="$venv/.requirements.sha256" want
  want=$(sha256sum "$req" | cut -d' ' -f1)
  if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ]; then
    echo "versions: installing $req into $venv (bpy is large; pip's cache makes reruns quick)" >&2
    quiet_pip "$venv/bin/python" -m pip install --quiet --upgrade pip
    quiet_pip "$venv/bin/python" -m pip install --quiet -r "$req"
    echo "$want" > "$stamp"
  fi
  echo "$venv/bin/python"
}

mkdir -p out/versions
status=0
for line in "${lines[@]}"; do
  start=$SECONDS
  py=$(setup "$line")
  echo "versions: bpy $line environment ready in $((SECONDS - start)) s" >&2
  [ "$setup_only" = 1 ] && continue
  rm -f "out/versions/bpy-$line.json"
  if ! PYTHONPATH="$PWD" "$py" tests/versions/check.py --resolution 32 \
        --json "out/versions/bpy-$line.json"; then
    status=1
    echo "versions: bpy $line FAILED" >&2
  fi
  echo "versions: bpy $line done in $((SECONDS - start)) s" >&2
done
if [ "$setup_only" = 0 ]; then
  files=()
  for line in "${lines[@]}"; do files+=("out/versions/bpy-$line.json"); done
  "$py" tests/versions/summary.py "${files[@]}" || status=1
fi
exit $status
