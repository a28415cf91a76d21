#!/usr/bin/env bash
# surfgrad's two commands (and two optional ones). Each creates the virtual environments it
# needs once, installs the pinned requirements into them (pip's cache makes reinstalls quick)
# and reuses them:
#   bash run.sh main [ARGS]   the main job on Blender 5.2 LTS: writes out/demo
#   bash run.sh test [ARGS]   the test suite on every supported line: 5.2 LTS (the main line,
#                             Python 3.13, .venv), then 5.0, 4.5 LTS and 4.2 LTS (Python 3.11,
#                             .venv-bpy50/45/42); a table of the lines in out/lines/summary.md.
#                             SURFGRAD_LINES="5.2 4.2" bash run.sh test -k decal picks lines
#                             (LINES too, where it holds lines, not the terminal's height); ARGS
#                             go to pytest on each line (-m numpy|blender|bake|child|eevee picks
#                             tiers: README, The two commands); seconds per tier in the summary.
#   bash run.sh bench [ARGS]  speed against accuracy of every method, stability: out/bench
#   bash run.sh bench-reference  throughput of the numpy reference: out/bench_reference.json
#   bash run.sh bench-render [--quick]  render cost against Blender's own nodes: out/bench_render
# Needs Python 3.13 (for 5.2) and, for the older lines' tests, Python 3.11: on PATH
# (python3.13 / python3.11), under pyenv's versions, or given as PYTHON=... / PYTHON311=....
set -euo pipefail
cd "$(dirname "$0")"

ALL_LINES="5.2 5.0 4.5 4.2"

find_python() {   # $1 = 3.13 | 3.11; prints a matching interpreter
  local want=$1 explicit cand var=PYTHON
  [ "$want" = 3.13 ] || var=PYTHON311
  explicit=${!var:-}
  local roots=("${PYENV_ROOT:-$HOME/.pyenv}")
  for cand in "$explicit" "python$want" python3 \
              "${roots[0]}"/versions/"$want"*/bin/python"$want"; do
    [ -n "$cand" ] || continue
    if command -v "$cand" >/dev/null 2>&1 &&
       "$cand" -c "import sys, venv; sys.exit(sys.version_info[:2] != tuple(map(int, '$want'.split('.'))))" \
         2>/dev/null; then
      echo "$cand"; return 0
    fi
    if [ "$cand" = "$explicit" ]; then     # asked for by name: say why it is passed over
      echo "surfgrad: $var=$cand is not a Python $want with its venv module; looking for one" \
           "elsewhere" >&2
    fi
  done
  echo "surfgrad: Python $want is needed (the bpy wheels of this line exist only for $want)." >&2
  echo "  Install it with its venv module (e.g. 'pyenv install $want', or your system's" \
       "python$want and python$want-venv packages), or point $var=/path/to/python$want at one." >&2
  return 1
}

line_venv() { case "$1" in 5.2) echo .venv ;; *) echo ".venv-bpy${1/./}" ;; esac; }
line_reqs() { case "$1" in 5.2) echo requirements.txt ;; *) echo "requirements-$1.txt" ;; esac; }
line_python() { case "$1" in 5.2) echo 3.13 ;; *) echo 3.11 ;; esac; }

quiet_pip() {   # pip without the machine's notes about unreachable extra indexes
  { "$@" 2>&1; } | { grep -v "is ignored: it is neither a file nor a directory" || true; } >&2
}

bpy_version() {   # $1 = venv; the bpy version installed there (from its metadata: no import)
  "$1/bin/python" -c "import importlib.metadata as m; print(m.version('bpy'))" 2>/dev/null || true
}

setup_line() {   # $1 = line; prints the venv's python once it has the pinned requirements
  # Runs in $(...), where bash drops `set -e`: every step that can fail returns 1 itself, and
  # Ctrl-C, which pip turns into its own exit status, ends it here (as in run_tests).
  trap 'exit 130' INT
  local line=$1 venv reqs py stamp want pin
  venv=$(line_venv "$line"); reqs=$(line_reqs "$line")
  if [ -x "$venv/bin/python" ] && ! "$venv/bin/python" -c \
       "import sys; sys.exit(sys.version_info[:2] != tuple(map(int, '$(line_python "$line")'.split('.'))))"; then
    echo "surfgrad: $venv has the wrong Python for Blender $line; making it anew" >&2
    rm -rf "$venv"
  fi
  # A venv that `python -m venv` did not finish (interrupted) or whose base Python is gone has
  # no working pip: make it anew instead of failing in it on every run.
  if [ -e "$venv" ] && ! "$venv/bin/python" -c "import pip" >/dev/null 2>&1; then
    echo "surfgrad: $venv is unfinished (no working python or pip); making it anew" >&2
    rm -rf "$venv"
  fi
  if [ ! -e "$venv" ]; then
    py=$(find_python "$(line_python "$line")") || return 1
    echo "surfgrad: creating $venv with $py for Blender $line" >&2
    if ! "$py" -m venv "$venv"; then
      rm -rf "$venv"
      echo "surfgrad: '$py -m venv $venv' failed (messages above); install that Python's" \
           "venv module or point $([ "$line" = 5.2 ] && echo PYTHON || echo PYTHON311)" \
           "at another" >&2
      return 1
    fi
  fi
  stamp="$venv/.requirements.sha256"
  want=$(sha256sum "$reqs" | cut -d' ' -f1) || return 1
  pin=$(sed -n 's/^bpy==\([^ #]*\).*/\1/p' "$reqs")
  # The stamp alone would trust a venv whose bpy was removed or replaced since the install.
  if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ] ||
     [ "$(bpy_version "$venv")" != "$pin" ]; then
    echo "surfgrad: installing $reqs into $venv (bpy is large; pip's cache makes reruns quick)" >&2
    # The stamp is written only after both installs succeeded, so a failed or interrupted
    # install is retried on the next run instead of testing whatever bpy the venv had.
    # A newer pip is welcome, not needed (offline, the pinned requirements may be there).
    quiet_pip "$venv/bin/python" -m pip install --quiet --upgrade pip ||
      echo "surfgrad: could not upgrade pip in $venv; going on with the one it has" >&2
    if ! quiet_pip "$venv/bin/python" -m pip install --quiet -r "$reqs"; then
      echo "surfgrad: installing $reqs into $venv failed (pip's messages above); the next" \
           "run installs it again" >&2
      return 1
    fi
    if [ "$(bpy_version "$venv")" != "$pin" ]; then
      echo "surfgrad: $venv has bpy '$(bpy_version "$venv")' after installing $reqs, which pins" \
           "$pin; remove $venv and rerun" >&2
      return 1
    fi
    echo "$want" > "$stamp" || return 1
  fi
  echo "$venv/bin/python"
}

asked_lines() {   # prints the lines asked for and the variable that asked (or the default)
  # LINES is also the terminal's height (POSIX: a decimal integer), which some shells export:
  # a number there is the terminal's, not a list of lines. SURFGRAD_LINES comes first.
  if [ -n "${SURFGRAD_LINES:-}" ]; then
    echo "SURFGRAD_LINES $SURFGRAD_LINES"
  elif [ -n "${LINES:-}" ] && ! [[ "$LINES" =~ ^[[:space:]]*[0-9]+[[:space:]]*$ ]]; then
    echo "LINES $LINES"
  else
    echo "SURFGRAD_LINES $ALL_LINES"
  fi
}

run_tests() {
  local lines=() asked line py start status=0 rc summary_py=python3 var test_pid=
  read -r var asked <<< "$(asked_lines)"
  read -r -a asked <<< "$asked"
  for line in "${asked[@]}"; do             # the whole request is checked before any line runs
    case " $ALL_LINES " in *" $line "*) ;; *)
      echo "surfgrad: unknown line $line in $var (supported: $ALL_LINES)" >&2; return 2 ;; esac
    case " ${lines[*]} " in *" $line "*) ;; *) lines+=("$line") ;; esac
  done
  if [ ${#lines[@]} = 0 ]; then
    echo "surfgrad: $var names no line (supported: $ALL_LINES; unset for all)" >&2; return 2
  fi
  # pytest ends on Ctrl-C with its own exit status, so bash would go on to the next line; it
  # runs in the background (below), so bash waits for it to finish its own report first.
  trap '[ -z "${test_pid:-}" ] || wait "$test_pid" || true
        echo "surfgrad: interrupted; the lines after it did not run" >&2; exit 130' INT
  bash tools/install_eevee_deps.sh || true      # Mesa EGL for the EEVEE tests
  bash tools/install_chromium.sh || true        # headless Chromium for the report page test
  mkdir -p out/lines
  rm -f out/lines/*.json out/lines/summary.md    # an interrupted run leaves no older summary
  for line in "${lines[@]}"; do
    start=$SECONDS
    echo "surfgrad: ===== Blender $line =====" >&2
    if ! py=$(setup_line "$line"); then
      rc=1
    else
      summary_py=$py
      rc=0
      # In the background, waited for: bash runs no trap until a foreground command ends, so
      # a SIGTERM to bash alone (a farm's or CI runner's cancel) left pytest running. Ctrl-C
      # still reaches it (a background command would ignore SIGINT) and so does the terminal.
      ( trap - INT; export SURFGRAD_REPORT_DIR="$PWD/out/lines"; exec "$py" -m pytest "$@" ) \
        <&0 &
      test_pid=$!
      trap 'kill -TERM "$test_pid" 2>/dev/null || true; wait "$test_pid" || true
            echo "surfgrad: terminated; the lines after it did not run" >&2; exit 143' TERM
      wait "$test_pid" || rc=$?
      trap - TERM
      test_pid=
    fi
    echo "{\"line\": \"$line\", \"exit\": $rc, \"seconds\": $((SECONDS - start))}" \
      > "out/lines/run-$line.json"
    echo "surfgrad: Blender $line: $([ "$rc" = 0 ] && echo passed || echo "FAILED (exit $rc)")" \
         "in $((SECONDS - start)) s" >&2
    [ "$rc" = 0 ] || status=1
  done
  "$summary_py" tools/lines_summary.py out/lines "${lines[@]}" || status=1
  return $status
}

cmd=${1:-}
[ $# -gt 0 ] && shift
case "$cmd" in
  main) py=$(setup_line 5.2)
        exec "$py" -m surfgrad_addon demo --out out/demo --overwrite "$@" ;;
  test) run_tests "$@" ;;
  bench) py=$(setup_line 5.2)
         exec "$py" -m surfgrad_addon bench --out out/bench --overwrite "$@" ;;
  bench-render) py=$(setup_line 5.2)
         exec "$py" -m surfgrad_addon bench-render --out out/bench_render --overwrite "$@" ;;
  bench-reference) py=$(setup_line 5.2)
         exec "$py" -m surfgrad_addon bench-reference --out out/bench_reference.json \
              --overwrite "$@" ;;
  *) echo "usage: bash run.sh main|test|bench|bench-render|bench-reference [ARGS]" >&2; exit 2 ;;
esac
