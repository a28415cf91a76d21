#!/usr/bin/env bash
# Install Chromium from the system's packages, for the report page's test
# (tests/test_report_page.py opens out/demo/index.html in headless Chromium and checks that every
# image loads and the page shows no error).
#
#   chromium   Debian's Chromium (/usr/bin/chromium); on Ubuntu the same name is a snap
#              wrapper, so a chromium or chromium-browser already on PATH is left alone
#
# Idempotent and quick when Chromium is there (one `command -v`, no network); otherwise
# tools/apt_packages.sh installs it (apt-get, about 100 MB with its libraries). Never fails its
# caller: whatever goes wrong is printed and the script exits 0, so that the page's test fails
# with this script's name in its message instead.
set -u

for cand in chromium chromium-browser; do
  command -v "$cand" >/dev/null 2>&1 && exit 0
done
bash "$(dirname "$0")/apt_packages.sh" install_chromium \
  "the report page's test (tests/test_report_page.py) will fail" chromium
if command -v chromium >/dev/null 2>&1; then
  echo "install_chromium: $(chromium --version 2>/dev/null || echo 'chromium is on PATH')" >&2
fi
exit 0
