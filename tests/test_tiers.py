"""The suite's tiers (tests/support/tiers.py): every test is in exactly one, every test file
declares its tier, `-m` picks a tier, the guard fails a test that does more than its tier
allows (imports bpy in the numpy tier, bakes in the blender tier, starts a process below the
child tier), and the durations per tier are written for the lines' summary."""

import ast
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from support.child import run_python
from support.tiers import TIERS

pytestmark = pytest.mark.tier("numpy")

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent


def test_every_collected_test_has_exactly_one_tier_marker(request):
    items = request.session.items
    assert items
    for item in items:
        tiers = [m.name for m in item.iter_markers() if m.name in TIERS]
        assert len(tiers) == 1, (item.nodeid, tiers)


def _declarations(path):
    """(module-level tiers, every tier named anywhere) of a test file, read with ast."""
    tree = ast.parse(path.read_text())

    def tiers_in(node):
        return [c.args[0].value for c in ast.walk(node) if isinstance(c, ast.Call)
                and isinstance(c.func, ast.Attribute) and c.func.attr == "tier"
                and c.args and isinstance(c.args[0], ast.Constant)]

    module = [n for n in tree.body if isinstance(n, ast.Assign)
              and any(getattr(t, "id", None) == "pytestmark" for t in n.targets)]
    return [t for n in module for t in tiers_in(n)], tiers_in(tree)


def test_every_test_file_declares_its_tier():
    files = sorted(TESTS.glob("test_*.py"))
    assert len(files) > 40
    for f in files:
        module, named = _declarations(f)
        assert len(module) == 1, f"{f.name}: pytestmark must declare one pytest.mark.tier(...)"
        assert set(named) <= set(TIERS), (f.name, named)
        # tier markers go through the declaration, never by hand
        src = f.read_text()
        for t in TIERS:
            assert f"pytest.mark.{t}" not in src.replace("pytest.mark.tier", ""), (f.name, t)


def test_the_summary_shows_the_durations_per_tier(tmp_path):
    import sys
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import lines_summary
    finally:
        sys.path.pop(0)
    for line, seconds in (("5.2", 10), ("4.2", 20)):
        (tmp_path / f"run-{line}.json").write_text(json.dumps(
            {"line": line, "exit": 0, "seconds": seconds}))
        (tmp_path / f"durations-{line}.json").write_text(json.dumps(
            {"line": line, "markexpr": "", "wall_seconds": seconds,
             "tiers": {"numpy": {"tests": 3, "seconds": 1.5, "passed": 3, "failed": 0,
                                 "skipped": 0},
                       "bake": {"tests": 2, "seconds": 7.0 * seconds / 10, "passed": 1,
                                "failed": 0, "skipped": 1}}}))
    assert lines_summary.main([str(tmp_path), "5.2", "4.2"]) == 0
    text = (tmp_path / "summary.md").read_text()
    assert "| 5.2 | 3 / 1.5 s | - | 2 / 7.0 s | - | - | 10.0 s |" in text
    assert "| 4.2 | 3 / 1.5 s | - | 2 / 14.0 s | - | - | 20.0 s |" in text


def test_the_summary_compares_menus_with_the_integers_of_older_lines(tmp_path):
    """5.2's Menu sockets against 4.2's integers: the documented difference, not a problem;
    any other difference still is."""
    import sys
    from surfgrad_addon.reference.group_interfaces import expected_signatures
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import lines_summary
    finally:
        sys.path.pop(0)
    dumps = {"5.2": expected_signatures(), "4.2": expected_signatures(menu_sockets=False)}
    for line, groups in dumps.items():
        (tmp_path / f"interfaces-{line}.json").write_text(json.dumps({"groups": groups}))
    assert lines_summary._interfaces_note(tmp_path, ["5.2", "4.2"]) == ([], ["4.2", "5.2"])
    dumps["4.2"]["SG Resolve"]["description"] += "!"
    (tmp_path / "interfaces-4.2.json").write_text(json.dumps({"groups": dumps["4.2"]}))
    assert lines_summary._interfaces_note(tmp_path, ["5.2", "4.2"])[0] == [
        "SG Resolve: 4.2 differs from 5.2"]


# The guard and the collection rules, in a child pytest on a made-up test file --------------

FAKE = '''
import subprocess, sys
import pytest

pytestmark = pytest.mark.tier("numpy")


def test_numpy_ok():
    import numpy
    assert numpy.zeros(2).sum() == 0


def test_numpy_imports_bpy():
    import bpy  # noqa: F401


def test_numpy_skips_without_bpy():
    pytest.importorskip("bpy")


@pytest.mark.tier("blender")
def test_blender_ok():
    import bpy
    assert bpy.app.version >= (4, 2, 0)


@pytest.mark.tier("blender")
def test_blender_spawns():
    subprocess.run([sys.executable, "-c", "pass"], check=True)


@pytest.fixture(scope="module")
def spawned():
    return subprocess.run([sys.executable, "-c", "print(7)"], capture_output=True,
                          text=True).stdout


@pytest.mark.tier("bake")
def test_bake_fixture_spawns(spawned):
    assert spawned.strip() == "7"


@pytest.mark.tier("child")
def test_child_ok(spawned):
    assert spawned.strip() == "7"


def _bake():
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add()
    ob = bpy.context.active_object
    mat = bpy.data.materials.new("m")
    if mat.node_tree is None:
        mat.use_nodes = True
    ob.data.materials.append(mat)
    node = mat.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = bpy.data.images.new("i", 8, 8)
    mat.node_tree.nodes.active = node
    bpy.context.scene.render.engine = "CYCLES"
    bpy.context.scene.cycles.samples = 1
    assert bpy.ops.object.bake(type="NORMAL") == {"FINISHED"}


@pytest.mark.tier("blender")
def test_blender_bakes():
    _bake()


@pytest.mark.tier("bake")
def test_bake_ok():
    _bake()
'''

EXPECTED = {   # test -> None (passes), "skipped", or the tier its failure asks for
    "test_numpy_ok": None, "test_numpy_imports_bpy": "blender",
    "test_numpy_skips_without_bpy": "blender", "test_blender_ok": None,
    "test_blender_spawns": "child", "test_bake_fixture_spawns": "child",
    "test_child_ok": None, "test_blender_bakes": "bake", "test_bake_ok": None,
}


def _pytest(folder, *args, env=None):
    return run_python(["-m", "pytest", "-p", "support.tiers", "-c", ROOT / "pyproject.toml",
                       "--rootdir", folder, "-p", "no:cacheprovider", *args],
                      cwd=folder, env=env, timeout=300)


def _outcomes(xml_path):
    out = {}
    for case in ET.parse(xml_path).getroot().iter("testcase"):
        failure = case.find("failure")
        if failure is None:
            failure = case.find("error")
        skipped = case.find("skipped")
        out[case.get("name")] = (("failed", failure.get("message", "") + (failure.text or ""))
                                 if failure is not None else ("skipped", "")
                                 if skipped is not None else ("passed", ""))
    return out


@pytest.mark.tier("child")
def test_the_guard_fails_a_test_that_does_more_than_its_tier(tmp_path):
    pytest.importorskip("bpy")
    (tmp_path / "test_fake.py").write_text(FAKE)
    reports = tmp_path / "reports"
    out = _pytest(tmp_path, "test_fake.py", "--junitxml", tmp_path / "r.xml",
                  env={"SURFGRAD_REPORT_DIR": str(reports)})
    assert out.returncode == 1, out.stdout[-3000:] + out.stderr[-3000:]
    got = _outcomes(tmp_path / "r.xml")
    assert set(got) == set(EXPECTED)
    for name, need in EXPECTED.items():
        outcome, message = got[name]
        if need is None:
            assert outcome == "passed", (name, message)
        else:
            assert outcome == "failed", (name, outcome)
            assert f"declare @pytest.mark.tier({need!r})" in message, (name, message)
    assert "imports bpy" in got["test_numpy_imports_bpy"][1]
    assert "subprocess.Popen" in got["test_blender_spawns"][1]
    assert "bpy.ops.object.bake" in got["test_blender_bakes"][1]
    # The durations per tier of that run, for the lines' summary.
    (report,) = reports.glob("durations-*.json")
    data = json.loads(report.read_text())
    counts = {t: (v["tests"], v["passed"], v["failed"]) for t, v in data["tiers"].items()}
    assert counts == {"numpy": (3, 1, 2), "blender": (3, 1, 2), "bake": (2, 1, 1),
                      "child": (1, 1, 0)}
    assert all(v["seconds"] >= 0 for v in data["tiers"].values())
    assert data["tiers"]["bake"]["seconds"] > 0 and data["line"] in report.name
    # -m picks a tier: the numpy ones only.
    out = _pytest(tmp_path, "test_fake.py", "-m", "numpy", "--collect-only", "-q")
    assert out.returncode == 0, out.stdout + out.stderr
    picked = sorted(x.split("::")[1] for x in out.stdout.split() if "::" in x)
    assert picked == ["test_numpy_imports_bpy", "test_numpy_ok",
                      "test_numpy_skips_without_bpy"]


@pytest.mark.tier("child")
def test_a_test_without_a_tier_or_with_a_hand_set_marker_stops_the_collection(tmp_path):
    (tmp_path / "test_plain.py").write_text("def test_a():\n    pass\n")
    (tmp_path / "test_hand.py").write_text(
        "import pytest\npytestmark = pytest.mark.tier('numpy')\n\n"
        "@pytest.mark." + "bake\ndef test_b():\n    pass\n\n"     # split: this file's own check
        "@pytest.mark.tier('gpu')\ndef test_c():\n    pass\n")
    out = _pytest(tmp_path, "test_plain.py", "test_hand.py", "--collect-only", "-q")
    assert out.returncode == 4, out.stdout + out.stderr          # pytest's usage error
    text = out.stdout + out.stderr
    assert "test_plain.py::test_a: no tier declared" in text
    assert "test_hand.py::test_b: marked bake by hand" in text
    assert "test_hand.py::test_c: unknown tier 'gpu'" in text
