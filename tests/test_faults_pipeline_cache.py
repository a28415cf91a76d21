"""Fault injection, red team 30b: numba's kernel cache on a disk that will not take it. A
full disk or a file-size limit where numba writes its cache (on a line whose cache is cold)
raised numba's OSError out of the reference's first call, from deep in type inference; a
cache folder nobody can write stopped the reference's import with numba's RuntimeError ('no
locator available'). Now either is one warning line naming the folder and the fix, and the
kernels run uncached with the same numbers."""

import os
import resource
import subprocess
import sys

import numpy as np
import pytest

from surfgrad_addon.reference import compiled
from support.child import ROOT

pytestmark = [pytest.mark.tier("child"),
              pytest.mark.skipif(not compiled.AVAILABLE,
                                 reason="numba is not installed: nothing is cached")]

# Listing 16's three taps: a kernel that calls another (linear_at) compiles it inside its own
# type inference, where the failed write surfaced before.
CODE = ("import numpy as np, surfgrad_addon.reference as R\n"
        "rng = np.random.default_rng(2)\n"
        "h, st = rng.uniform(size=(16, 16)), rng.uniform(size=(50, 2))\n"
        "assert R.compiled.enabled()\n"
        "print(R.deriv_from_height_map(h, st, hq=False, lod=0.0).tobytes().hex())\n")


def _numpy_answer():
    import surfgrad_addon.reference as R
    rng = np.random.default_rng(2)
    h, st = rng.uniform(size=(16, 16)), rng.uniform(size=(50, 2))
    old = os.environ.get(compiled.ENV)
    os.environ[compiled.ENV] = "0"
    try:
        return R.deriv_from_height_map(h, st, hq=False, lod=0.0).tobytes().hex()
    finally:
        if old is None:
            del os.environ[compiled.ENV]
        else:
            os.environ[compiled.ENV] = old


def _run(env, file_limit=None):
    full = {k: v for k, v in os.environ.items()
            if k not in ("PYTHONPATH", "NUMBA_CACHE_DIR", "NUMBA_CACHE_LOCATOR_CLASSES",
                         compiled.ENV)}
    full.update(env, PYTHONPATH=str(ROOT))

    def limit():
        if file_limit is not None:      # Python ignores SIGXFSZ: a write past it fails
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_limit, file_limit))

    return subprocess.run([sys.executable, "-c", CODE], cwd=str(ROOT), env=full,
                          capture_output=True, text=True, timeout=300, preexec_fn=limit)


def _warning(stderr):
    lines = stderr.strip().splitlines()
    assert "Traceback" not in stderr and len(lines) == 1, stderr[-3000:]
    assert lines[0].startswith("surfgrad: warning: the reference's compiled kernels could not "
                               "be cached in "), stderr
    assert "set NUMBA_CACHE_DIR to a folder that takes files" in lines[0]
    return lines[0]


def test_a_cold_cache_on_a_full_disk_is_one_warning_and_the_same_numbers(tmp_path):
    """A cold cache folder where no file may pass 2 kB (as a full disk): numba's index fits,
    its compiled code does not. Before: a traceback (OSError: File too large), exit 1."""
    cold = tmp_path / "cold"
    cold.mkdir()
    run = _run({"NUMBA_CACHE_DIR": str(cold)}, file_limit=2048)
    assert run.returncode == 0, run.stderr[-3000:]
    line = _warning(run.stderr)
    assert f"in {str(cold)!r}"[:-1] in line and "(File too large)" in line, line
    assert run.stdout.strip() == _numpy_answer()        # bit for bit the numpy reference
    # Again on the half-written cache (an index naming code that was never written).
    again = _run({"NUMBA_CACHE_DIR": str(cold)}, file_limit=2048)
    assert again.returncode == 0 and again.stdout == run.stdout, again.stderr[-3000:]
    _warning(again.stderr)


def test_a_cache_folder_nobody_can_write_is_one_warning_and_the_same_numbers(tmp_path):
    """The only cache folder numba may use cannot be made (a file stands where a folder
    should; a read-only checkout alike; the tests run as any user, so not chmod). Before:
    numba's RuntimeError 'cannot cache function ...: no locator available' from the
    reference's import."""
    (tmp_path / "afile").write_text("")
    folder = tmp_path / "afile" / "cache"
    run = _run({"NUMBA_CACHE_DIR": str(folder),
                "NUMBA_CACHE_LOCATOR_CLASSES": "UserProvidedCacheLocator"})
    assert run.returncode == 0, run.stderr[-3000:]
    line = _warning(run.stderr)
    assert f"in {str(folder)!r} (no folder numba tried takes files)" in line, line
    assert run.stdout.strip() == _numpy_answer()


def test_a_cache_that_takes_files_is_written_without_a_word(tmp_path):
    """The guard changes nothing where the cache works: no warning, the kernels' code is on
    disk, and a second process loads it and gives the same numbers."""
    cold = tmp_path / "cold"
    first = _run({"NUMBA_CACHE_DIR": str(cold)})
    assert first.returncode == 0 and first.stderr == "", first.stderr[-3000:]
    assert any(cold.rglob("height_map_kernels.three_tap_derivative-*.nbc"))
    second = _run({"NUMBA_CACHE_DIR": str(cold)})
    assert second.returncode == 0 and second.stderr == "" and second.stdout == first.stdout
    assert first.stdout.strip() == _numpy_answer()
