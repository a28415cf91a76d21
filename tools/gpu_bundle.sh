#!/usr/bin/env bash
# The main line's Python and bpy, trimmed, for a lent GPU machine that has neither (issue 21,
# item 4): the device tool carries at most 64 MiB a call with the repository, so the bundle
# travels in parts, one call each, and is put together on the card by the last one.
#   bash tools/gpu_bundle.sh [PART_BYTES]        (default: what fits beside the tracked files)
# Reads PYTHON (default .venv/bin/python); no matplotlib travels, so bench charts are left out.
# Writes GPU_BUNDLE_OUT (default .gpu_bundle, git-ignored)/part<i>/, each
# holding one part; the last also holds unpack.sh, which joins the parts copied to /tmp/gpu_parts,
# checks them by SHA-256, unpacks them into DEST (default /tmp/gpu_py) and writes DEST/env.sh.
# On the card, per part i of n:
#   run(command="mkdir -p /tmp/gpu_parts && cp .gpu_bundle/part<i>/part* /tmp/gpu_parts/",
#       carry=[".gpu_bundle/part<i>"])                       (seconds each, machine kept warm)
# then, carrying the last part:
#   bash .gpu_bundle/part<n>/unpack.sh && . /tmp/gpu_py/env.sh && bash tools/gpu_check.sh $OUT
# Trimmed: AMD and Intel GPU kernels, the prebuilt CUDA cubins (tools/cycles_gpu_kernel.sh
# builds the card's own from the PTX, which stays), OIDN's device plug-ins, USD's and
# MaterialX's Python bindings, the CJK font and add-ons no bake uses. Added: the X and GL
# libraries bpy links that a bare CUDA image lacks (an H100 image had libX11 alone).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
# (PY_HOME, SITE: the interpreter's prefix and the venv's site-packages, as read from PYTHON.)
read -r ver home site < <("$PY" -c "import sys, sysconfig; print('%d.%d' % sys.version_info[:2],
    sys.base_prefix, sysconfig.get_paths()['purelib'])")
home=${PY_HOME:-$home}
site=${SITE:-$site}
if [ -z "${1:-}" ]; then            # 2 MiB left for unpack.sh and slack
  tracked=$(git ls-files -z | xargs -0 cat 2>/dev/null | wc -c)
  part=$(( 64 * 1024 * 1024 - tracked - 2 * 1024 * 1024 ))
  [ "$part" -gt $(( 1024 * 1024 )) ] || { echo "gpu_bundle: no room beside $tracked tracked bytes"; exit 1; }
else
  part=$1
fi
out=${GPU_BUNDLE_OUT:-.gpu_bundle}
[ -n "${GPU_BUNDLE_OUT:-}" ] || grep -qx "/$out/" .git/info/exclude 2>/dev/null \
  || echo "/$out/" >> .git/info/exclude
stage=$(mktemp -d); trap 'rm -rf "$stage"' EXIT
py=$stage/py
mkdir -p "$py/bin" "$py/lib/python$ver/site-packages" "$py/syslib"
cp -L "$home/bin/python$ver" "$py/bin/"
cp -L "$home/lib/libpython$ver.so.1.0" "$py/lib/" 2>/dev/null || true     # (a static build has none)
(cd "$home/lib" && tar cf - --exclude="python$ver/test" --exclude="python$ver/idlelib" \
  --exclude="python$ver/site-packages" --exclude='config-*' --exclude=__pycache__ \
  --exclude=tkinter --exclude=turtledemo --exclude=ensurepip --exclude=lib2to3 "python$ver") \
  | tar xf - -C "$py/lib"
keep=(bpy numpy numpy.libs zstandard PIL pillow.libs)
present=(); for k in "${keep[@]}"; do [ -e "$site/$k" ] && present+=("$k"); done
(cd "$site" && tar cf - --exclude=__pycache__ --exclude=tests --exclude='kernel_*gfx*' \
  --exclude='kernel_rt_*' --exclude='kernel_sm_*.cubin.zst' --exclude='libOpenImageDenoise_device_*' \
  --exclude=pxr --exclude=MaterialX --exclude='Noto Sans CJK*' --exclude=rigify \
  --exclude=io_scene_gltf2 "${present[@]}") | tar xf - -C "$py/lib/python$ver/site-packages"
# The system libraries bpy links, less the C and C++ runtimes every Linux has.
so=$(ls "$site"/bpy/__init__*.so 2>/dev/null | head -1 || true)
if [ -n "$so" ]; then
  LD_LIBRARY_PATH="$site/bpy/lib" ldd "$so" 2>/dev/null | awk '$3 ~ /^\/(usr\/)?lib/ {print $3}' \
    | grep -vE '/(libc|libm|libdl|librt|libpthread|libutil|libstdc\+\+|libgcc_s|ld-linux[^/]*)\.so' \
    | while read -r lib; do cp -L "$lib" "$py/syslib/"; done
fi

rm -rf "$out"; mkdir -p "$out"
tar cf - -C "$stage" py | xz -T0 -6 > "$stage/bundle.tar.xz"
sum=$(sha256sum "$stage/bundle.tar.xz" | cut -d' ' -f1)
split -b "$part" -d -a 2 "$stage/bundle.tar.xz" "$stage/part"
n=0
for p in "$stage"/part[0-9]*; do
  n=$((n + 1)); mkdir -p "$out/part$n"; mv "$p" "$out/part$n/"
done
cat > "$out/part$n/unpack.sh" <<EOF
#!/usr/bin/env bash
# Join the $n parts of tools/gpu_bundle.sh's bundle (copied to /tmp/gpu_parts, this part too),
# check them, unpack them into DEST and write DEST/env.sh (PYTHON, PYTHONHOME, LD_LIBRARY_PATH).
set -euo pipefail
here=\$(cd "\$(dirname "\$0")" && pwd)
parts=\${PARTS:-/tmp/gpu_parts}; dest=\${DEST:-/tmp/gpu_py}
mkdir -p "\$parts"; cp "\$here"/part[0-9]* "\$parts/"
got=\$(ls "\$parts"/part[0-9]* | wc -l)
[ "\$got" -eq $n ] || { echo "gpu_bundle: \$got of $n parts in \$parts"; exit 1; }
cat \$(ls "\$parts"/part[0-9]* | sort) > "\$parts/bundle.tar.xz"
echo "$sum  \$parts/bundle.tar.xz" | sha256sum -c --quiet - || { echo "gpu_bundle: parts differ"; exit 1; }
rm -rf "\$dest"; mkdir -p "\$dest"
xz -d -T0 < "\$parts/bundle.tar.xz" | tar xf - -C "\$dest" --strip-components=1
rm -f "\$parts/bundle.tar.xz"
cat > "\$dest/env.sh" <<ENV
export PYTHON=\$dest/bin/python$ver PYTHONHOME=\$dest PYTHONUNBUFFERED=1
export LD_LIBRARY_PATH=\$dest/lib:\$dest/syslib\\\${LD_LIBRARY_PATH:+:\\\$LD_LIBRARY_PATH}
ENV
echo "gpu_bundle: unpacked into \$dest"
EOF
chmod +x "$out/part$n/unpack.sh"
echo "gpu_bundle: $n parts of at most $part bytes in $out/ (SHA-256 $sum)"
du -b "$out"/part*/part* | sed 's/^/  /'
