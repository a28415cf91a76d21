"""The import graph, read from the source (tests/support/imports.py, lazy imports included):
no cycle among surfgrad's modules; the reference imports nothing of ours and no Blender module;
the add-on imports only the reference (and itself); what the extension ships (harness/package.py
SHIPPED) imports only what it ships, never the harness. The built zip is checked the same way
in tests/test_extension.py."""

import pytest

from support import imports as I
from surfgrad_addon.harness import package

pytestmark = pytest.mark.tier("numpy")


OURS = "surfgrad_addon"
EDGES = I.graph()


def _under(module, *parts):
    return any(module == f"{OURS}.{p}" or module.startswith(f"{OURS}.{p}.") for p in parts)


def test_the_graph_sees_every_module_and_its_lazy_imports():
    assert len(EDGES) > 80
    # a module-level import, a function-level one and a `from package import module` one
    assert f"{OURS}.reference.raster" in EDGES[f"{OURS}.harness.compare"] or \
        f"{OURS}.reference" in EDGES[f"{OURS}.harness.compare"]
    assert f"{OURS}.addon.operators" in EDGES[f"{OURS}.api"]          # inside a function
    assert f"{OURS}.harness.compare" in EDGES[f"{OURS}.harness.api"]


def test_no_import_cycle():
    assert I.cycles(EDGES) == []


def test_the_cycle_check_finds_a_cycle_and_the_old_api_compare_one(tmp_path):
    """The checker fails where it should: two modules importing each other lazily, and the
    shape this issue removed (api.compare -> harness.compare -> api)."""
    pkg = tmp_path / OURS
    (pkg / "harness").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "harness" / "__init__.py").write_text("")
    (pkg / "api.py").write_text("def compare():\n    from .harness import compare\n")
    (pkg / "harness" / "compare.py").write_text("def run():\n    from .. import api\n")
    (pkg / "harness" / "plain.py").write_text("import numpy\nfrom . import compare\n")
    found = I.cycles(I.graph(root=tmp_path))
    assert found == [[f"{OURS}.api", f"{OURS}.harness.compare"]]


def test_the_reference_imports_nothing_of_ours_and_no_blender():
    third = I.third_party()
    reference = [m for m in EDGES if _under(m, "reference")]
    assert len(reference) > 20
    for m in reference:
        assert all(_under(t, "reference") for t in EDGES[m]), (m, EDGES[m])
        assert not third[m] & I.BLENDER_MODULES, (m, third[m])


def test_the_addon_imports_only_the_reference():
    addon = [m for m in EDGES if _under(m, "addon")]
    assert len(addon) > 20
    for m in addon:
        assert all(_under(t, "addon", "reference") for t in EDGES[m]), (m, EDGES[m])


def test_what_the_extension_ships_imports_only_what_it_ships():
    """SHIPPED (__init__, api, addon, reference) read as files, without building the zip."""
    shipped = [package.PACKAGE_DIR / f for f in package.expected_files() if f.endswith(".py")]
    edges = I.graph(root=package.ROOT, files=shipped)
    assert f"{OURS}.api" in edges and f"{OURS}.addon.ui" in edges
    assert not [m for m in edges if _under(m, "harness")]
    missing = {m: sorted(t for t in targets if t not in edges) for m, targets in edges.items()}
    assert not {m: t for m, t in missing.items() if t}, missing
