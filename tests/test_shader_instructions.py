"""The shader-instruction bench (harness/bench/shader_instructions.py): valgrind's count inside
Cycles' shader interpreter is the same on every run of a material, grows with what the material
runs, and its table's ratios are the counts' own."""

import shutil
import sys

import pytest

from surfgrad_addon.harness.bench import shader_instructions as SI
from support.lines import main_line_only

pytestmark = pytest.mark.tier("child")

# The bench's figures (docs/performance.md) are counted on the main line; a count under
# valgrind takes minutes, and what these tests pin is the tool's own arithmetic and errors.
ON_THE_MAIN_LINE = main_line_only("the instruction bench runs on the main line; its counts "
                                  "take minutes under valgrind")

CASES = [("none", "no perturbation", None, None),
         ("nm-builtin", "Normal Map node", None, None),
         ("nm-sg", "SG Normal Map", None, "nm-builtin"),
         ("lonely", "a material whose twin was not counted", None, "absent")]


def test_rows_are_the_counts_ratios():
    now = {"none": 100, "nm-builtin": 150, "nm-sg": 190, "lonely": 7}
    before = {"none": 100, "nm-builtin": 150, "nm-sg": 250}
    rows = {r["key"]: r for r in SI.rows_of(CASES, now, before)}
    sg = rows["nm-sg"]
    assert sg["ratio"] == 190 / 150 and sg["ratio_before"] == 250 / 150
    assert sg["overhead_ratio"] == (190 - 100) / (150 - 100)
    assert sg["instructions_before"] == 250
    assert "ratio" not in rows["lonely"] and "ratio" not in rows["none"]


def test_summary_line_is_read_and_its_absence_named(tmp_path):
    out = tmp_path / "callgrind.out"
    out.write_text("version: 1\nevents: Ir\nsummary: 12345\n\ntotals: 12345\n")
    assert SI.summary_of(out) == 12345
    out.write_text("version: 1\nevents: Ir\n")
    with pytest.raises(SI.InstructionCountError, match="no summary"):
        SI.summary_of(out)


@ON_THE_MAIN_LINE
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_counts_repeat_exactly_and_grow_with_the_material():
    """Two renders of the scene without perturbation count the same; a Normal Map node with its
    image lookup counts more (bpy is imported by the children only)."""
    pytest.importorskip("bpy")
    first = SI.counts(["none", "nm-builtin"], jobs=2)
    again = SI.count("none")
    assert first["none"] == again > 0
    assert first["nm-builtin"] > first["none"]


def test_an_unknown_material_is_refused_before_any_child(capsys, tmp_path):
    pytest.importorskip("bpy")
    out = tmp_path / "si.json"
    assert SI.main(["--keys", "no-such", "--out", str(out)]) == 2
    assert "no bench-render material ['no-such']" in capsys.readouterr().err
    assert not out.exists()


def test_a_before_root_that_is_no_checkout_is_refused(capsys, tmp_path):
    pytest.importorskip("bpy")
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind is not installed")
    out = tmp_path / "si.json"
    assert SI.main(["--keys", "none", "--before-root", str(tmp_path), "--out", str(out)]) == 2
    assert "is no surfgrad checkout" in capsys.readouterr().err
    assert not out.exists()


@ON_THE_MAIN_LINE
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_a_failing_child_is_named_with_its_own_last_line(tmp_path):
    """A checkout whose bench cannot run: the error names the material and the child's own
    error, not valgrind's summary."""
    root = tmp_path / "broken"
    (root / "surfgrad_addon").mkdir(parents=True)
    with pytest.raises(SI.InstructionCountError) as caught:
        SI.count("none", root, python=sys.executable, timeout=300)
    text = str(caught.value)
    assert text.startswith("none: the child failed (exit 1): ") and "==" not in text, text
    assert "Error" in text, text
