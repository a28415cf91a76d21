#!/usr/bin/env bash
# Install Debian/Ubuntu packages that are missing, for a part of the suite that needs them:
#
#   bash tools/apt_packages.sh NAME CONSEQUENCE PACKAGE...
#
# NAME prefixes every message ("install_chromium"); CONSEQUENCE says what happens without the
# packages ("the report page's test will fail"). The install_*.sh scripts call it.
#
# Idempotent and quick when the packages are there (one dpkg-query each, no network). Runs
# `apt-get update` only when the install cannot find a package without it. Never fails its
# caller: whatever goes wrong is printed and the script exits 0.
set -u

name=$1 consequence=$2
shift 2
PACKAGES=("$@")

say() { echo "$name: $*" >&2; }

if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then
  say "no dpkg/apt-get here (not Debian or Ubuntu); install the equivalent of" \
      "${PACKAGES[*]} yourself, or $consequence"
  exit 0
fi

missing=()
for pkg in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2>/dev/null || true)
  [ "$status" = "installed" ] || missing+=("$pkg")
done
[ ${#missing[@]} -eq 0 ] && exit 0

sudo=()
if [ "$(id -u)" != 0 ]; then
  if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
    sudo=(sudo -n)
  else
    say "missing ${missing[*]}, and installing needs root (no password-less sudo);" \
        "$consequence. As root: apt-get install -y ${missing[*]}"
    exit 0
  fi
fi

export DEBIAN_FRONTEND=noninteractive
apt_opts=(-y -q --no-install-recommends -o DPkg::Lock::Timeout=120)

install() {
  "${sudo[@]}" apt-get install "${apt_opts[@]}" "${missing[@]}" >"$log" 2>&1
}

log=$(mktemp)
trap 'rm -f "$log"' EXIT
say "installing ${missing[*]}"
# Try from the package lists already on the machine first; update them only when that fails
# (no lists yet, or the lists name versions the mirror no longer has).
if ! install; then
  say "apt-get install failed without fresh package lists; running apt-get update"
  if ! "${sudo[@]}" apt-get update -q -o DPkg::Lock::Timeout=120 >"$log" 2>&1; then
    say "apt-get update failed; $consequence. Its last lines:"
    tail -n 5 "$log" >&2
    exit 0
  fi
  if ! install; then
    say "apt-get install ${missing[*]} failed; $consequence. Its last lines:"
    tail -n 5 "$log" >&2
    exit 0
  fi
fi
say "installed ${missing[*]}"
exit 0
