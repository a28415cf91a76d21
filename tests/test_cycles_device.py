"""--cycles-device (harness/cycles_device.py) on compare, compare-all and bench-render: the CPU
changes nothing (the preferences untouched, the reports saying "CPU"); a GPU kind this machine
has no device of is refused by the command line before anything is baked or written (exit 2,
one line naming the kind and the fix, no traceback) and leaves the Cycles preferences as they
were; a kind outside CPU/CUDA/OPTIX is refused by the parser. The GPU runs themselves need a
GPU (the refusal tests skip where Cycles finds one)."""

import pytest

bpy = pytest.importorskip("bpy")

from support.child import run_python  # noqa: E402
from surfgrad_addon.addon import exit_codes  # noqa: E402
from surfgrad_addon.harness import cycles_device as D  # noqa: E402

pytestmark = pytest.mark.tier("blender")

NO_DEVICE = "no {} device found by Cycles; run on a machine with an NVIDIA GPU or leave " \
            "--cycles-device at CPU"


def _prefs():
    return bpy.context.preferences.addons["cycles"].preferences


def _snapshot():
    prefs = _prefs()
    return prefs.compute_device_type, [(e.type, e.id, e.name, e.use) for e in prefs.devices]


def _without(kind):
    """Skip where Cycles finds a device of `kind` (these tests are of the refusal)."""
    try:
        names = D.check(kind)
    except D.CyclesDeviceError:
        return
    pytest.skip(f"this machine has a {kind} device ({names})")


def test_cpu_selection_touches_nothing():
    scene = bpy.context.scene
    scene.cycles.device = "CPU"
    before = _snapshot()
    assert D.check("CPU") == ["CPU"]
    with D.selected(scene, "CPU") as chosen:
        assert (chosen.scene_device, chosen.description) == ("CPU", "CPU")
        assert scene.cycles.device == "CPU"
        assert _snapshot() == before
    assert scene.cycles.device == "CPU" and _snapshot() == before


@pytest.mark.parametrize("kind", ["CUDA", "OPTIX"])
def test_missing_gpu_is_refused_and_the_preferences_are_put_back(kind):
    _without(kind)
    scene = bpy.context.scene
    scene.cycles.device = "CPU"
    _prefs().devices.clear()           # as in fresh preferences: no device entries yet
    before = _snapshot()
    assert before[1] == []
    entered = []
    with pytest.raises(D.CyclesDeviceError) as err:
        with D.selected(scene, kind):
            entered.append(kind)
    assert str(err.value) == NO_DEVICE.format(kind)
    assert not entered
    # The look-up adds an entry per device Cycles finds (the CPU's at least): removed again.
    assert _snapshot() == before
    assert scene.cycles.device == "CPU"
    with pytest.raises(D.CyclesDeviceError, match=f"no {kind} device"):
        D.check(kind)
    assert _snapshot() == before


def test_unknown_kind_is_refused_naming_the_kinds():
    with pytest.raises(D.CyclesDeviceError, match="'METAL': use one of CPU, CUDA, OPTIX"):
        with D.selected(bpy.context.scene, "METAL"):
            pass
    with pytest.raises(D.CyclesDeviceError, match="use one of CPU, CUDA, OPTIX"):
        D.check("metal")


def _cli(*args):
    return run_python(["-m", "surfgrad_addon", *args], timeout=300)


def _refused(result, words):
    text = result.stdout + result.stderr
    assert result.returncode == exit_codes.BAD_REQUEST, text
    assert words in result.stderr, text
    assert "Traceback" not in text
    return text


@pytest.mark.tier("child")
def test_commands_refuse_a_missing_gpu_before_writing(tmp_path):
    _without("CUDA")
    _without("OPTIX")
    out = tmp_path / "compare"
    _refused(_cli("compare-all", "--out", out, "--resolution", "8", "--cycles-device", "CUDA"),
             "surfgrad: error: " + NO_DEVICE.format("CUDA"))
    report = tmp_path / "one.json"
    _refused(_cli("compare", "--object", "Sphere", "--method", "normal-map", "--resolution", "8",
                  "--json", report, "--cycles-device", "OPTIX"), NO_DEVICE.format("OPTIX"))
    bench = tmp_path / "render"
    _refused(_cli("bench-render", "--out", bench, "--quick", "--cycles-device", "OPTIX"),
             "surfgrad: error: " + NO_DEVICE.format("OPTIX"))
    assert list(tmp_path.iterdir()) == []           # no folder, report or heat map


@pytest.mark.tier("child")
def test_parser_and_bench_options_refuse_bad_values(tmp_path):
    out = tmp_path / "compare"
    text = _refused(_cli("compare-all", "--out", out, "--cycles-device", "METAL"),
                    "invalid choice: 'METAL'")
    assert "CPU" in text and "OPTIX" in text
    bench = tmp_path / "render"
    _refused(_cli("bench-render", "--out", bench, "--quick", "--size", "8"),
             "surfgrad: error: --size 8: use a whole number from 16 to 8192")
    _refused(_cli("bench-render", "--out", bench, "--samples", "0", "--no-eevee"),
             "surfgrad: error: --samples 0: use a whole number from 1 to 65536")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.tier("bake")
def test_compare_all_reports_name_the_cpu(tmp_path):
    """One case of compare-all's serial order (a shard as large as the order) at 8^2."""
    from surfgrad_addon.harness import compare_all as CA
    (tmp_path / "heat").mkdir()
    shards = len(CA.all_cases(["normal-map"])) * 4          # four test objects
    reports = CA.run_shard(tmp_path, 8, 0, shards, log=lambda *_: None,
                           methods=["normal-map"])
    assert list(reports) == [0]
    assert reports[0]["cycles_device"] == "CPU" and reports[0]["method"] == "normal-map"
    assert CA.table_markdown(list(reports.values()), 8).startswith(
        "# Bakes against the reference at 8^2\n")
    assert CA.table_markdown(list(reports.values()), 8, "CUDA", ["NVIDIA H200"]).startswith(
        "# Bakes against the reference at 8^2, Cycles on CUDA (NVIDIA H200)\n")
