"""Two layers, one direction: the add-on (surfgrad_addon.addon: groups, node builder, menu,
operators, the TD bake and commands) and the numpy reference never import the proving harness
(surfgrad_addon.harness: bake, compare, bench, demo, main job, CLI); the reference never imports
bpy or the add-on; and registering the add-on loads no harness module."""

import ast
from pathlib import Path

import pytest

from support.lines import main_line_only

pytestmark = pytest.mark.tier("child")

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "surfgrad_addon"


def _imports(path):
    """Absolute module names a file imports, relative imports resolved against its package."""
    tree = ast.parse(path.read_text())
    package = path.relative_to(ROOT).with_suffix("").parts[:-1]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = list(package[:len(package) - node.level + 1]) if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            out.add(module)
            out.update(f"{module}.{alias.name}" for alias in node.names)
    return out


def _files(*parts):
    return sorted(PACKAGE.joinpath(*parts).rglob("*.py"))


@pytest.mark.tier("numpy")
def test_addon_and_reference_never_import_the_harness():
    files = _files("addon") + _files("reference") + [PACKAGE / "__init__.py",
                                                      PACKAGE / "api.py"]
    assert len(files) > 20
    offenders = {f.relative_to(ROOT).as_posix(): sorted(m for m in _imports(f)
                                                        if m.startswith("surfgrad_addon.harness"))
                 for f in files}
    assert not {f: m for f, m in offenders.items() if m}


@pytest.mark.tier("numpy")
def test_reference_imports_neither_bpy_nor_the_addon():
    for f in _files("reference"):
        bad = [m for m in _imports(f) if m.split(".")[0] in ("bpy", "mathutils")
               or m.startswith(("surfgrad_addon.addon", "surfgrad_addon.harness"))]
        assert not bad, (f, bad)


def test_registering_the_addon_loads_no_harness_module():
    code = ("import sys, surfgrad_addon\n"
            "surfgrad_addon.register()\n"
            "loaded = sorted(m for m in sys.modules if m.startswith('surfgrad_addon'))\n"
            "surfgrad_addon.unregister()\n"
            "print('LOADED', ' '.join(loaded))\n")
    from support.child import run_python
    out = run_python(["-c", code], timeout=120)
    if "No module named 'bpy'" in out.stderr:
        import pytest
        pytest.skip("needs bpy")
    assert out.returncode == 0, out.stderr
    loaded = next(line for line in out.stdout.splitlines() if line.startswith("LOADED"))
    modules = loaded.split()[1:]
    assert "surfgrad_addon.addon.ui" in modules and "surfgrad_addon.addon.commands" in modules
    assert not [m for m in modules if m.startswith("surfgrad_addon.harness")], modules


def test_the_method_registry_and_the_main_jobs_reference_stage_need_no_bpy():
    """The registry's names and references, and the main job's table built from it, import in
    an interpreter that refuses bpy (its graphs and gates import the add-on when used)."""
    from support.child import run_without_bpy
    stdout = run_without_bpy(
        "import numpy as np\n"
        "from surfgrad_addon.harness import main_job, methods\n"
        "table = main_job.method_table(np.zeros((8, 8, 3)) + 0.5, np.zeros((8, 8, 3)) + 0.5,"
        " np.zeros((8, 8)))\n"
        "assert 'bpy' not in sys.modules\n"
        "print('METHODS', len(methods.METHODS), 'TABLE', ' '.join(table))\n")
    line = next(x for x in stdout.splitlines() if x.startswith("METHODS"))
    names = line.split()[3:]
    assert line.split()[1] == "23"
    # Every registry method with a scene-free reference, each variant, then the baselines;
    # the Sampler methods share their per-image twins' references and maps.
    assert {"normal-map", "height-map-forward", "height-map-hq", "decal-box", "decal-cone",
            "decal-overwrite", "blend-rnm", "baseline-geiss-triplanar"} <= set(names)
    assert "displace-bump" not in names and not [n for n in names if "sampler" in n]


@main_line_only("which modules import bpy is this project's code, the same on every "
                "line; each line runs the numpy tier itself")
def test_the_numpy_tier_runs_where_bpy_cannot_be_imported():
    """`pytest -m numpy` (README: the tiers) in an interpreter that refuses bpy: every
    numpy-tier test passes there. In the whole suite a numpy-tier test can import a module
    that an earlier test already loaded with bpy behind it, which the tier guard cannot see
    (scale_limits once took a constant from the bpy-built groups, and test_compare_kernels
    failed when run alone)."""
    from support.child import NO_BPY, run_python
    code = NO_BPY + ("import pytest\n"
                     "sys.exit(pytest.main(['-m', 'numpy', '-q', '-p', 'no:cacheprovider', "
                     "'-x', 'tests']))\n")
    out = run_python(["-c", code], env={"SURFGRAD_REPORT_DIR": ""}, timeout=900)
    summary = out.stdout.strip().splitlines()[-1] if out.stdout.strip() else ""
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert " passed" in summary and "failed" not in summary and "error" not in summary, summary
