#!/usr/bin/env bash
# Install what the bpy wheel needs to render with EEVEE on a machine without a GPU: Mesa's
# software OpenGL (llvmpipe) behind EGL, which Blender uses headless (no display, no X).
#
#   libegl1          libEGL.so.1, the GL vendor-neutral dispatch (glvnd) that Blender loads
#   libegl-mesa0     Mesa's EGL vendor library and its glvnd registration (pulls libgbm1,
#                    libglapi-mesa, libdrm2, libwayland-*, libxcb-*)
#   libgl1-mesa-dri  the driver itself: swrast_dri.so with llvmpipe (pulls libllvm15)
#
# bpy's own import needs libgl1, libx11-6 and friends, which every bpy test needs anyway; this
# script adds only what EEVEE needs on top. Debian/Ubuntu packages, installed with apt-get.
#
# Idempotent and quick when the packages are there (one dpkg-query, no network). Runs
# `apt-get update` only when the install cannot find a package without it. Never fails its
# caller: whatever goes wrong is printed and the script exits 0, so that the EEVEE test
# (tests/test_eevee.py) skips with the reason instead.
set -u

PACKAGES=(libegl1 libegl-mesa0 libgl1-mesa-dri)

say() { echo "install_eevee_deps: $*" >&2; }

if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then
  say "no dpkg/apt-get here (not Debian or Ubuntu); install Mesa's EGL and DRI drivers" \
      "(${PACKAGES[*]} on Debian) yourself to render with EEVEE"
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
        "EEVEE tests will be skipped. As root: apt-get install -y ${missing[*]}"
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
    say "apt-get update failed; EEVEE tests will be skipped. Its last lines:"
    tail -n 5 "$log" >&2
    exit 0
  fi
  if ! install; then
    say "apt-get install ${missing[*]} failed; EEVEE tests will be skipped. Its last lines:"
    tail -n 5 "$log" >&2
    exit 0
  fi
fi
say "installed ${missing[*]}"
exit 0
