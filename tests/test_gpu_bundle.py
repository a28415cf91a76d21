"""tools/gpu_bundle.sh, which packs the main line's Python and bpy for a lent GPU machine that
has neither, in parts small enough for one device call each (issue 21, item 4: on an H100 a
bundle made this way, 7 parts, ran every method's compare on OptiX). Run here on a stand-in
Python prefix and site-packages: every part within the size asked, the trimmed files left out
and the kept ones there, the parts joined and checked on the other side, and a lost or damaged
part refused before anything is unpacked."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.tier("child")

ROOT = Path(__file__).resolve().parents[1]
VER = "%d.%d" % sys.version_info[:2]
PART = 8192


def _tree(root, files):
    for name, data in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)


def _bundle(tmp_path):
    home, site = tmp_path / "home", tmp_path / "site"
    noise = os.urandom(40000)                 # (incompressible: the bundle needs several parts)
    _tree(home, {f"bin/python{VER}": b"#!python\n", f"lib/libpython{VER}.so.1.0": b"lib",
                 f"lib/python{VER}/os.py": b"# os\n", f"lib/python{VER}/test/t.py": b"t",
                 f"lib/python{VER}/site-packages/other.py": b"o",
                 f"lib/python{VER}/__pycache__/os.pyc": b"c"})
    cycles = "bpy/5.2/scripts/addons_core/cycles/lib/"
    _tree(site, {"bpy/__init__.py": noise, cycles + "kernel_compute_75.ptx.zst": b"ptx",
                 cycles + "kernel_optix.ptx.zst": b"optix", cycles + "kernel_sm_86.cubin.zst": b"c",
                 cycles + "kernel_gfx1030.fatbin.zst": b"h", cycles + "kernel_rt_gfx1100.hipfb.zst": b"r",
                 "bpy/lib/libOpenImageDenoise.so.2": b"oidn",
                 "bpy/lib/libOpenImageDenoise_device_hip.so.2.5.0": b"hip",
                 f"bpy/5.2/python/lib/python{VER}/site-packages/pxr/_sdf.so": b"usd",
                 "numpy/__init__.py": b"np", "numpy/_core/tests/test_a.py": b"t",
                 "zstandard/__init__.py": b"z", "requests/__init__.py": b"not needed"})
    out = tmp_path / "bundle"
    env = dict(os.environ, PYTHON=sys.executable, PY_HOME=str(home), SITE=str(site),
               GPU_BUNDLE_OUT=str(out))
    made = subprocess.run(["bash", str(ROOT / "tools" / "gpu_bundle.sh"), str(PART)], env=env,
                          capture_output=True, text=True, timeout=120)
    assert made.returncode == 0, made.stdout + made.stderr
    return out, noise


def _card(tmp_path, out, parts):
    """What the device calls do: each part but the last copied to PARTS, then unpack.sh."""
    dirs = sorted(out.glob("part*"), key=lambda p: int(p.name[4:]))
    (tmp_path / "parts").mkdir()
    for d in dirs[:-1]:
        for p in d.glob("part*"):
            if parts(p):
                (tmp_path / "parts" / p.name).write_bytes(parts(p))
    env = dict(os.environ, PARTS=str(tmp_path / "parts"), DEST=str(tmp_path / "dest"))
    return subprocess.run(["bash", str(dirs[-1] / "unpack.sh")], env=env, capture_output=True,
                          text=True, timeout=120)


def test_the_parts_fit_and_unpack_to_the_trimmed_tree(tmp_path):
    out, noise = _bundle(tmp_path)
    parts = sorted(out.glob("part*/part*"))
    assert len(parts) >= 4 and all(p.stat().st_size <= PART for p in parts)
    assert sum(p.stat().st_size for p in parts) > len(noise)
    done = _card(tmp_path, out, lambda p: p.read_bytes())
    assert done.returncode == 0, done.stdout + done.stderr
    dest = tmp_path / "dest"
    got = {str(p.relative_to(dest)) for p in dest.rglob("*") if p.is_file()}
    sp = f"lib/python{VER}/site-packages/"
    cycles = sp + "bpy/5.2/scripts/addons_core/cycles/lib/"
    assert got == {f"bin/python{VER}", f"lib/libpython{VER}.so.1.0", f"lib/python{VER}/os.py",
                   sp + "bpy/__init__.py", cycles + "kernel_compute_75.ptx.zst",
                   cycles + "kernel_optix.ptx.zst", sp + "bpy/lib/libOpenImageDenoise.so.2",
                   sp + "numpy/__init__.py", sp + "zstandard/__init__.py", "env.sh"}
    assert (dest / sp / "bpy/__init__.py").read_bytes() == noise
    env = (dest / "env.sh").read_text()
    assert f"PYTHON={dest}/bin/python{VER}" in env and f"PYTHONHOME={dest}" in env
    assert f"LD_LIBRARY_PATH={dest}/lib:{dest}/syslib" in env


@pytest.mark.parametrize("fault, said", [("lost", "parts in"), ("damaged", "parts differ")])
def test_a_lost_or_damaged_part_is_refused_before_unpacking(tmp_path, fault, said):
    out, _ = _bundle(tmp_path)
    first = min(out.glob("part1/part*"))

    def part(p):
        data = p.read_bytes()
        if p != first:
            return data
        return None if fault == "lost" else data[:-1] + bytes([data[-1] ^ 1])
    done = _card(tmp_path, out, part)
    assert done.returncode == 1 and said in done.stdout
    assert not (tmp_path / "dest").exists()
