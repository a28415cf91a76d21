#!/usr/bin/env bash
# Install Chromium from the system's packages, for the report page's test
# (tests/test_report_page.py opens out/demo/index.html in headless Chromium and checks that every
# image loads and the page shows no error).
#
#   chromium   Debian's Chromium (/usr/bin/chromium); on Ubuntu the same name is a snap
#              wrapper, so a chromium or chromium-browser already on PATH is left alone
#
# Idempotent and quick when Chromium is there (one `command -v`, no network). Runs
# `apt-get update` only when the install cannot find the package without it. Never fails its
# caller: whatever goes wrong is printed and the script exits 0, so that the page's test fails
# with this script's name in its message instead.
set -u

PACKAGES=(chromium)

say() { echo "install_chromium: $*" >&2; }

for cand in chromium chromium-browser; do
  if command -v "$cand" >/dev/null 2>&1; then
    exit 0
  fi
done

if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then
  say "no dpkg/apt-get here (not Debian or Ubuntu); install Chromium yourself (a" \
      "'chromium' on PATH) for the report page's test"
  exit 0
fi

sudo=()
if [ "$(id -u)" != 0 ]; then
  if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
    sudo=(sudo -n)
  else
    say "Chromium is missing, and installing it needs root (no password-less sudo);" \
        "the report page's test will fail. As root: apt-get install -y ${PACKAGES[*]}"
    exit 0
  fi
fi

export DEBIAN_FRONTEND=noninteractive
apt_opts=(-y -q --no-install-recommends -o DPkg::Lock::Timeout=120)

install() {
  "${sudo[@]}" apt-get install "${apt_opts[@]}" "${PACKAGES[@]}" >"$log" 2>&1
}

log=$(mktemp)
trap 'rm -f "$log"' EXIT
say "installing ${PACKAGES[*]} (about 100 MB with its libraries)"
# Try from the package lists already on the machine first; update them only when that fails
# (no lists yet, or the lists name versions the mirror no longer has).
if ! install; then
  say "apt-get install failed without fresh package lists; running apt-get update"
  if ! "${sudo[@]}" apt-get update -q -o DPkg::Lock::Timeout=120 >"$log" 2>&1; then
    say "apt-get update failed; the report page's test will fail. Its last lines:"
    tail -n 5 "$log" >&2
    exit 0
  fi
  if ! install; then
    say "apt-get install ${PACKAGES[*]} failed; the report page's test will fail." \
        "Its last lines:"
    tail -n 5 "$log" >&2
    exit 0
  fi
fi
if command -v chromium >/dev/null 2>&1; then
  say "installed: $(chromium --version 2>/dev/null || echo chromium)"
else
  say "apt-get installed ${PACKAGES[*]} but no chromium is on PATH"
fi
exit 0
