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
# tools/apt_packages.sh installs what is missing: idempotent and quick when the packages are
# there (one dpkg-query each, no network); `apt-get update` only when the install cannot find a
# package without it. Never fails its caller: whatever goes wrong is printed and the script
# exits 0, so that the EEVEE test (tests/test_eevee.py) skips with the reason instead.
set -u

bash "$(dirname "$0")/apt_packages.sh" install_eevee_deps "EEVEE tests will be skipped" \
  libegl1 libegl-mesa0 libgl1-mesa-dri
exit 0
