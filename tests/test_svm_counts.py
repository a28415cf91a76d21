"""svm_counts (harness/bench/svm_counts.py): Cycles' own count of what a material runs after
constant folding, read from its compilation summary in a child, on every line this suite runs on.

The graphs are built here (build_materials runs in the child): a 60-node Vector Math chain on
the position (the branch), put behind a Mix whose factor is a constant 0 or 1, a per-sample
value, a Boolean or Float group input left at a constant, or a Math COMPARE of constants;
chains of Math and Vector Math nodes whose inputs are all constants; products by 1 and by -1.
Each count is checked against the same graph without the branch (or with the constant typed
in), so the facts hold in whatever unit the line counts in (int4 records up to 5.1, 32-bit
words from 5.2). Every line (4.2, 4.5, 5.0, 5.2) reports counts; a line that could not would
fail here with svm_counts' SvmCountError saying why, never skip.
"""

import pytest

from surfgrad_addon.addon.node_vocabulary import Math, VMath
from surfgrad_addon.harness.bench import svm_counts as S

pytestmark = pytest.mark.tier("child")

BRANCH = 60


# The child's side: materials whose Diffuse BSDF Normal is build(g, position) ----------------

def _chain(g, v, n):
    """n Vector Math nodes on v, alternating + c and * (1 + c/10); no two alike and no
    identity (an add of 0 or a product by 1 would be folded away by itself)."""
    for i in range(n):
        c = 0.01 * (i + 1)
        v = g.vmath(VMath.ADD, v, (c, c, c)) if i % 2 == 0 else \
            g.vmath(VMath.MULTIPLY, v, (1 + c / 10,) * 3)
    return v


def _gate_group(kind, default):
    """A group: Result = Mix(factor = its `kind` input "Use", A = V, B = the branch on V)."""
    import bpy

    from surfgrad_addon.harness.graph import Graph
    tree = bpy.data.node_groups.new(f"gate_{kind}", "ShaderNodeTree")
    socket = {"BOOLEAN": "NodeSocketBool", "FLOAT": "NodeSocketFloat"}[kind]
    tree.interface.new_socket("Result", in_out="OUTPUT", socket_type="NodeSocketVector")
    tree.interface.new_socket("Use", in_out="INPUT", socket_type=socket).default_value = default
    tree.interface.new_socket("V", in_out="INPUT", socket_type="NodeSocketVector")
    g = Graph(tree.nodes, tree.links)
    gin, gout = g.node("NodeGroupInput"), g.node("NodeGroupOutput")
    g.link(g.mix_vector(gin.outputs["Use"], gin.outputs["V"], _chain(g, gin.outputs["V"],
                                                                       BRANCH)),
           gout.inputs["Result"])
    return tree


def _gated(kind, value):
    def build(g, p):
        node = g.group(_gate_group(kind, not value if kind == "BOOLEAN" else 1.0 - value),
                       V=p)
        node.inputs["Use"].default_value = value          # the group node's own constant
        return node.outputs["Result"]
    return build


def _math_chain(g, p):
    s = 0.5
    for i in range(20):
        s = g.math(Math.ADD if i % 2 == 0 else Math.MULTIPLY, s, 0.01 * (i + 1) + 1.0)
    return g.scale(p, s)


def _vmath_chain(g, p):
    w = (0.1, 0.2, 0.3)
    for i in range(20):
        c = 0.01 * (i + 1) + 1.0
        w = g.vmath(VMath.ADD if i % 2 == 0 else VMath.MULTIPLY, w, (c, c, c))
    return g.add(p, w)


def _compare(a, b):
    def build(g, p):
        return g.mix_vector(g.math(Math.COMPARE, a, b, 0.1), p, _chain(g, p, BRANCH))
    return build


MATERIALS = {
    "plain": lambda g, p: p,
    "branch30": lambda g, p: _chain(g, p, BRANCH // 2),
    "branch60": lambda g, p: _chain(g, p, BRANCH),
    "mix0": lambda g, p: g.mix_vector(0.0, p, _chain(g, p, BRANCH)),
    "mix1": lambda g, p: g.mix_vector(1.0, _chain(g, p, BRANCH), p),
    "mix_per_sample": lambda g, p: g.mix_vector(g.separate(p)[0], p, _chain(g, p, BRANCH)),
    "group_bool_off": _gated("BOOLEAN", False),
    "group_bool_on": _gated("BOOLEAN", True),
    "group_float_0": _gated("FLOAT", 0.0),
    "group_float_1": _gated("FLOAT", 1.0),
    "compare_false": _compare(0.25, 0.75),
    "compare_true": _compare(0.5, 0.55),
    "math_chain": _math_chain,
    "math_typed": lambda g, p: g.scale(p, 2.5),
    "vmath_chain": _vmath_chain,
    "vmath_typed": lambda g, p: g.add(p, (0.7, 0.8, 0.9)),
    "scale_x": lambda g, p: g.scale(p, g.separate(p)[0]),
    "scale_x_times_1": lambda g, p: g.scale(p, g.math(Math.MULTIPLY, g.separate(p)[0], 1.0)),
    "scale_x_times_-1": lambda g, p: g.scale(p, g.math(Math.MULTIPLY, g.separate(p)[0], -1.0)),
    "times_111": lambda g, p: g.vmath(VMath.MULTIPLY, p, (1.0, 1.0, 1.0)),
    "times_1-11": lambda g, p: g.vmath(VMath.MULTIPLY, p, (1.0, -1.0, 1.0)),
}


def build_materials():
    """In the child: one material per MATERIALS entry, named after it."""
    from surfgrad_addon.addon.compat import new_material
    from surfgrad_addon.harness.graph import Graph
    for name, build in MATERIALS.items():
        mat = new_material(name)
        g = Graph(mat.node_tree.nodes, mat.node_tree.links)
        g.nodes.clear()
        bsdf = g.node("ShaderNodeBsdfDiffuse")
        g.link(bsdf.outputs["BSDF"], g.node("ShaderNodeOutputMaterial").inputs["Surface"])
        g.link(build(g, g.geometry("Position")), bsdf.inputs["Normal"])


# The tests ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def counts():
    return S.svm_counts(MATERIALS, build="test_svm_counts:build_materials",
                        paths=[S.ROOT / "tests"])


def test_counts_come_in_the_lines_unit(counts):
    import bpy                 # the child ran this interpreter, so this line
    unit = S.unit_for(bpy.app.version)
    assert {c.unit for c in counts.values()} == {unit}
    assert all(c.nodes > 0 and c.peak_stack >= 0 for c in counts.values())


def test_the_branch_costs_its_size(counts):
    """60 nodes cost twice what 30 of the same nodes cost, the same whole number of units
    each (4 int4 records up to 5.1, 13 words on 5.2)."""
    base = counts["plain"].nodes
    b30, b60 = counts["branch30"].nodes - base, counts["branch60"].nodes - base
    assert b60 == 2 * b30 and b60 >= BRANCH and b60 % BRANCH == 0, (b30, b60)


def test_a_constant_factor_removes_the_unused_side(counts):
    base = counts["plain"].nodes
    assert counts["mix0"].nodes == base                    # factor 0: A, the branch gone
    assert counts["mix1"].nodes == base                    # factor 1: B, the branch gone


def test_a_per_sample_factor_runs_both_sides(counts):
    base, b60 = counts["plain"].nodes, counts["branch60"].nodes
    extra = counts["mix_per_sample"].nodes - b60           # the Mix and the Separate XYZ
    assert 0 < extra <= (b60 - base) // 10, (base, b60, counts["mix_per_sample"].nodes)


@pytest.mark.parametrize("kind", ["bool", "float"])
def test_a_constant_group_input_folds_through_the_group(counts, kind):
    on = {"bool": "group_bool_on", "float": "group_float_1"}[kind]
    off = {"bool": "group_bool_off", "float": "group_float_0"}[kind]
    assert counts[off].nodes == counts["plain"].nodes
    assert counts[on].nodes == counts["branch60"].nodes


def test_compare_of_constants_folds(counts):
    assert counts["compare_false"].nodes == counts["plain"].nodes
    assert counts["compare_true"].nodes == counts["branch60"].nodes


def test_math_and_vector_math_of_constants_fold(counts):
    assert counts["math_chain"].nodes == counts["math_typed"].nodes
    assert counts["vmath_chain"].nodes == counts["vmath_typed"].nodes


def test_a_product_by_one_folds_and_by_minus_one_does_not(counts):
    """A Strength of exactly 1 costs nothing; a sign flip (DirectX's green) is a node."""
    assert counts["scale_x_times_1"].nodes == counts["scale_x"].nodes
    assert counts["scale_x_times_-1"].nodes > counts["scale_x"].nodes
    assert counts["times_111"].nodes == counts["plain"].nodes
    assert counts["times_1-11"].nodes > counts["plain"].nodes


def test_a_saved_file_counts_the_same(counts, tmp_path):
    """blend=: the same materials written to a .blend give the same counts; a name the file
    lacks is refused by name."""
    import bpy
    before, groups = set(bpy.data.materials), set(bpy.data.node_groups)
    build_materials()
    made = [m for m in bpy.data.materials if m not in before]
    try:
        assert sorted(m.name for m in made) == sorted(MATERIALS)
        bpy.data.libraries.write(str(tmp_path / "m.blend"), set(made))
    finally:
        for m in made:
            bpy.data.materials.remove(m)
        for tree in set(bpy.data.node_groups) - groups:
            bpy.data.node_groups.remove(tree)
    some = ["plain", "mix_per_sample", "group_bool_off", "branch60"]
    assert S.svm_counts(some, blend=tmp_path / "m.blend") == {k: counts[k] for k in some}
    with pytest.raises(S.SvmCountError, match=r"no material named \['nothing'\]"):
        S.svm_counts(["plain", "nothing"], blend=tmp_path / "m.blend")


def test_what_cannot_be_read_is_said():
    """The two ways a line could fail to report, each named: no such symbol in the bpy module
    (a build without it, or stripped), and a child whose log shows no summary."""
    import importlib.util
    library = importlib.util.find_spec("bpy").origin
    with pytest.raises(S.SvmCountError, match="0 data symbols named _ZN3ccl9NO_SUCH_LEVELE"):
        S._elf_symbol(library, "_ZN3ccl9NO_SUCH_LEVELE")
    import bpy
    if bpy.app.version >= (5, 0, 0):       # 4.x logs through glog: no ccl::LOG_LEVEL there
        offset, size = S._elf_symbol(library, S.CCL_LOG_LEVEL)
        assert offset > 0 and size == 4
    quiet = S.MARK + '{"version": [4, 2, 0], "version_string": "4.2.0", "error": null}'
    with pytest.raises(S.SvmCountError, match="Blender 4.2.0: Cycles logged no compilation "
                                               "summary for material 'plain'"):
        S.parse(quiet, ["plain"])
