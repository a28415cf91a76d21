"""What a compare process pays beside its bake, once: the compiled kernels it loads before its
timed passes (harness/kernel_warm_up.py load_kernels) and how it leaves (addon/command_line.py leave).
Each runs in a fresh child: kernels a process has loaded once stay loaded."""

import json

import numpy as np

import pytest

from support.child import run_python

pytest.importorskip("bpy")

pytestmark = pytest.mark.tier("child")

# The child: compare `method` at 96^2 on the test scene, listing the kernels (numba dispatchers'
# signatures) loaded by load_kernels, then by the bake, the real rasterisation and comparison.
KERNELS_LOADED = """
import json, sys
import bpy
from numba.core.registry import CPUDispatcher
import gc
from surfgrad_addon.harness import compare as C, scenes
from surfgrad_addon.reference import compiled

def loaded():
    return sorted(f"{d.py_func.__module__}.{d.__name__}{sig}" for d in gc.get_objects()
                  if isinstance(d, CPUDispatcher) for sig in d.signatures)

seen = {}
load_kernels, bake = C.load_kernels, C.B.bake_vector_in_pieces
def spy_load(*args):
    seconds = load_kernels(*args)
    seen["warm_up"] = loaded()
    return seconds
def spy_bake(*args, **kwargs):
    out = bake(*args, **kwargs)
    seen["bake"] = loaded()
    return out
C.load_kernels, C.B.bake_vector_in_pieces = spy_load, spy_bake
scenes.new_scene()
report = C.compare(bpy.data.objects["Sphere"], sys.argv[1], 96)
seen["end"] = loaded()
seen["max_deg"] = report["max_deg"]
seen["load_seconds"] = report["compiled_load_seconds"]
print(json.dumps(seen))
"""


@pytest.mark.parametrize("method", ["normal-map", "triplanar", "height-map"])
def test_the_warm_up_loads_every_kernel_the_timed_passes_run(method):
    """load_kernels runs before the bake; afterwards the real rasterisation and comparison
    load nothing (their seconds are the work alone), and the warm-up loaded kernels."""
    out = run_python(["-c", KERNELS_LOADED, method], env={"SURFGRAD_REFERENCE_COMPILED": "1"})
    assert out.returncode == 0, out.stderr
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert seen["max_deg"] < 0.05
    assert seen["load_seconds"] > 0 and len(seen["warm_up"]) >= 5
    # The bake loads no kernel, and neither does what follows it.
    assert seen["bake"] == seen["warm_up"]
    assert seen["end"] == seen["warm_up"]


def test_leave_freezes_the_heap_and_passes_the_code_on():
    """The exit code comes through, and the objects alive are in the permanent generation
    (the exit's collections skip them), in the process that leaves."""
    out = run_python(["-c", "import gc, sys\n"
                            "from surfgrad_addon.addon.command_line import leave\n"
                            "before = gc.get_freeze_count()\n"
                            "code = leave(7)\n"
                            "print(before, gc.get_freeze_count())\n"
                            "sys.exit(code)\n"])
    assert out.returncode == 7, out.stderr
    before, after = map(int, out.stdout.split())
    assert before == 0 and after > 1000


def test_the_command_line_exits_with_its_code_after_leaving(tmp_path):
    """A whole compare through `python -m surfgrad_addon` (which leaves through leave) exits 0
    with its report written; a refused one exits 2 with nothing written."""
    report = tmp_path / "r.json"
    ok = run_python(["-m", "surfgrad_addon", "compare", "--object", "Sphere", "--method",
                     "normal-map", "--resolution", "64", "--json", report])
    assert ok.returncode == 0, ok.stderr
    assert json.loads(report.read_text())["max_deg"] < 0.05
    refused = run_python(["-m", "surfgrad_addon", "compare", "--object", "Nothing",
                          "--method", "normal-map", "--resolution", "64", "--json",
                          tmp_path / "x.json"])
    assert refused.returncode == 2 and "Nothing" in refused.stderr
    assert not (tmp_path / "x.json").exists()


def test_the_warm_up_mesh_is_two_triangles_of_the_same_arrays():
    """Whatever the mesh's size, the warm-up rasterises two triangles, with the real mesh's
    array types (so the kernels it loads are the real pass's) and UVs over the whole square
    (so texels reach every kernel)."""
    from surfgrad_addon import reference as R
    from surfgrad_addon.harness.kernel_warm_up import WARM_UP, warm_up_mesh
    big = R.meshes.uv_sphere(segments=64, rings=32)
    small = warm_up_mesh(big)
    assert len(big.triangles) > 3000 and len(small.triangles) == 2
    assert small.positions is big.positions and small.matrix_world is big.matrix_world
    assert set(small.uv_maps) == set(big.uv_maps) and set(small.tangents) == set(big.tangents)
    for name in big.uv_maps:
        assert small.uv_maps[name].dtype == np.asarray(big.uv_maps[name]).dtype
        assert np.array_equal(small.tangents[name], big.tangents[name][:2])
        assert np.array_equal(small.tangent_signs[name], big.tangent_signs[name][:2])
    assert np.array_equal(small.corner_normals, big.corner_normals[:2])
    td = R.rasterize(small, "UVMap", WARM_UP, WARM_UP)
    assert td.covered.all()                     # every texel: every kernel sees texels
    one = warm_up_mesh(R.MeshArrays(positions=np.eye(3), triangles=np.array([[0, 1, 2]]),
                                    corner_normals=np.tile([0.0, 0.0, 1.0], (1, 3, 1)),
                                    uv_maps={"UV": np.zeros((1, 3, 2), dtype=np.float32)}))
    assert len(one.triangles) == 1 and one.uv_maps["UV"].dtype == np.float32
