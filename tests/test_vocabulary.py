"""One vocabulary for node graphs (issue 23): no node operation is spelled as a string
anywhere in surfgrad's code; every Math and Vector Math operation goes through the enums of
addon/node_vocabulary.py, whose members are Blender's own identifiers (checked against the
running Blender's enum items, so a renamed operation on some line fails here, not in a
render)."""

import ast
from pathlib import Path

import pytest

from surfgrad_addon.addon.node_vocabulary import Math, VMath

pytestmark = pytest.mark.tier("numpy")

SOURCE = Path(__file__).resolve().parents[1] / "surfgrad_addon"
OPS = {"math", "vmath"}


def string_operations(tree):
    """(line, what) for every operation written as a string literal: a `math("ADD", ...)` or
    `vmath(...)` call, an `operation="..."` keyword, or `node.operation = "..."`."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            name = getattr(node.func, "attr", getattr(node.func, "id", None))
            if name in OPS and node.args and isinstance(node.args[0], ast.Constant):
                found.append((node.lineno, f"{name}({node.args[0].value!r})"))
            for kw in node.keywords:
                if kw.arg == "operation" and isinstance(kw.value, ast.Constant):
                    found.append((node.lineno, f"operation={kw.value.value!r}"))
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant):
            for target in node.targets:
                if getattr(target, "attr", None) == "operation":
                    found.append((node.lineno, f".operation = {node.value.value!r}"))
    return sorted(found)


def test_the_checker_finds_each_string_form():
    code = ("b.math('ADD', 1, 2)\nb.vmath(\"SCALE\", v, 2)\nn = g.node('X', operation='MINIMUM')\n"
            "m.operation = 'SINE'\nb.math(Math.ADD, 1, 2)\n")
    assert [w for _, w in string_operations(ast.parse(code))] == [
        "math('ADD')", "vmath('SCALE')", "operation='MINIMUM'", ".operation = 'SINE'"]


def test_no_operation_is_a_string():
    files = sorted(SOURCE.rglob("*.py"))
    assert len(files) > 80
    bad = [f"{path.relative_to(SOURCE)}:{line}: {what}" for path in files
           for line, what in string_operations(ast.parse(path.read_text(), str(path)))]
    assert bad == [], "\n".join(bad)


@pytest.mark.tier("blender")
def test_every_member_is_an_operation_of_the_running_blender():
    bpy = pytest.importorskip("bpy")
    for enum, rna in ((Math, bpy.types.ShaderNodeMath), (VMath, bpy.types.ShaderNodeVectorMath)):
        items = {item.identifier for item in rna.bl_rna.properties["operation"].enum_items}
        assert {m.value for m in enum} <= items, (enum.__name__, {m.value for m in enum} - items)
