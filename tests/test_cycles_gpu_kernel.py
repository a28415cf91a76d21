"""tools/cycles_gpu_kernel.sh, which builds Cycles' CUDA kernel for a card the bpy wheel has none
for (issue 21's GPU check on an H100: sm_90). Run here with a stub nvidia-smi and ptxas and a
stub bpy package holding the wheel's kernel folder: the kernel lands where Cycles looks, as one
zstd frame that records its size (Cycles refused a streamed frame as "File not found" on the
H100), only once, and a machine without the card or the toolkit is told so, exit 1.

Found on an H100 (this project's bundle of Python 3.13 and the 5.2.3 wheel): once imported, bpy's
``__file__`` named the copy in the wheel's scripts/modules, so the script found no kernel folder
and Cycles compiled the PTX on one core instead (a 64^2 bake still running after 250 s); the
folder is now found from the package's spec, without importing it."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.tier("child")

zstandard = pytest.importorskip("zstandard")
ROOT = Path(__file__).resolve().parents[1]
TOOLS = ("bash", "sh", "head", "tail", "tr", "ls", "sort", "mktemp", "rm", "basename", "dirname",
         "grep", "cat")
PTX = b"//\n.version 7.4\n.target sm_75\n" + bytes(range(256)) * 64


def _machine(tmp_path, card="9.0", ptxas=True, init=""):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "nvidia-smi").write_text(f"#!/bin/sh\necho '{card}'\n" if card else
                                        "#!/bin/sh\nexit 9\n")
    if ptxas:   # the "cubin" is the PTX reversed, so the test sees ptxas's own output land
        (bin_dir / "ptxas").write_text(
            "#!/bin/sh\n[ \"$1\" = --help ] && { echo ' --split-compile'; exit 0; }\n"
            f"echo \"$*\" >> {tmp_path}/ptxas.log\n"
            f"{sys.executable} -c \"import sys; d = open(sys.argv[1], 'rb').read(); "
            f"open(sys.argv[2], 'wb').write(d[::-1])\" \"$3\" \"$5\"\n")
    for f in bin_dir.iterdir():
        f.chmod(0o755)
    for tool in TOOLS:          # the PATH holds these alone: no toolkit of this machine's
        (bin_dir / tool).symlink_to(shutil.which(tool))
    lib = tmp_path / "site" / "bpy" / "5.2" / "scripts" / "addons_core" / "cycles" / "lib"
    lib.mkdir(parents=True)
    (tmp_path / "site" / "bpy" / "__init__.py").write_text(init)
    streamed = zstandard.ZstdCompressor().compressobj()       # no size recorded
    (lib / "kernel_compute_75.ptx.zst").write_bytes(streamed.compress(PTX) + streamed.flush())
    return bin_dir, lib


def _run(tmp_path, bin_dir):
    env = dict(os.environ, PATH=str(bin_dir), PYTHONPATH=str(tmp_path / "site"),
               CUDA_HOME=str(bin_dir.parent))      # (bin/ptxas, the stub, when there is one)
    return subprocess.run([str(bin_dir / "bash"), str(ROOT / "tools" / "cycles_gpu_kernel.sh"), sys.executable],
                          env=env, capture_output=True, text=True, timeout=60)


def test_the_kernel_is_built_once_where_cycles_looks(tmp_path):
    bin_dir, lib = _machine(tmp_path)
    first = _run(tmp_path, bin_dir)
    assert first.returncode == 0, first.stdout + first.stderr
    data = (lib / "kernel_sm_90.cubin.zst").read_bytes()
    assert zstandard.get_frame_parameters(data).content_size == len(PTX)
    assert zstandard.ZstdDecompressor().decompress(data) == PTX[::-1]
    assert "-arch=sm_90 --split-compile=0" in (tmp_path / "ptxas.log").read_text()
    again = _run(tmp_path, bin_dir)
    assert again.returncode == 0 and "is there" in again.stdout
    assert len((tmp_path / "ptxas.log").read_text().splitlines()) == 1
    assert sorted(p.name for p in lib.iterdir()) == ["kernel_compute_75.ptx.zst",
                                                     "kernel_sm_90.cubin.zst"]


def test_the_folder_is_found_when_importing_bpy_renames_it(tmp_path):
    # as the wheel's bpy does once imported: __file__ names scripts/modules/bpy, and Blender
    # prints start-up lines on stdout
    moved = tmp_path / "site" / "bpy" / "5.2" / "scripts" / "modules" / "bpy" / "__init__.py"
    bin_dir, lib = _machine(tmp_path, init=f"__file__ = {str(moved)!r}\n"
                            "import atexit; atexit.register(print, 'Add-on not loaded')\n")
    done = _run(tmp_path, bin_dir)
    assert done.returncode == 0, done.stdout + done.stderr
    assert zstandard.ZstdDecompressor().decompress(
        (lib / "kernel_sm_90.cubin.zst").read_bytes()) == PTX[::-1]


@pytest.mark.parametrize("card, ptxas, said", [(None, True, "no NVIDIA card"),
                                               ("9.0", False, "no ptxas")])
def test_without_the_card_or_the_toolkit_nothing_is_written(tmp_path, card, ptxas, said):
    bin_dir, lib = _machine(tmp_path, card, ptxas)
    got = _run(tmp_path, bin_dir)
    assert got.returncode == 1 and said in got.stdout
    assert [p.name for p in lib.iterdir()] == ["kernel_compute_75.ptx.zst"]
