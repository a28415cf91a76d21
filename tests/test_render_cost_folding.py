"""folded_cost (harness/bench/folded_cost.py): what each SG material runs after Cycles' constant
folding, read from Cycles' own SVM count (svm_counts) in a child, on every line.

The options: one left at its default must cost nothing, so its route is gone from the program;
one switched on costs what its nodes cost. The proof builds the groups a second time without
the route (a child whose builders have the route's helper replaced by its plain side) and
compares the same materials' counts. Counts compare within the line only (int4 records up to
5.1, 32-bit words from 5.2)."""

import os

import pytest

pytestmark = pytest.mark.tier("child")

pytest.importorskip("bpy")

from surfgrad_addon.harness.bench import folded_cost  # noqa: E402
from surfgrad_addon.harness.bench import svm_counts as S  # noqa: E402
from surfgrad_addon.reference.decals import DECAL_SHAPES  # noqa: E402


@pytest.fixture(scope="module")
def svm():
    return {r["key"]: r for r in folded_cost.counts()}


# The child's side: the groups built without a route, then folded_cost's materials ----------

def _without_far():
    """precise_far_route(b, plain, precise) -> plain: the groups as if the route never existed."""
    from surfgrad_addon.addon.groups import common, volume
    from surfgrad_addon.reference.socket_specs import PRECISE_FAR

    def plain_only(b, plain, precise):
        b.input(PRECISE_FAR)            # declared, so looked up; its value goes nowhere
        return plain
    common.precise_far_route = volume.precise_far_route = plain_only


def _without_directx():
    """No DirectX switch: decode and SG Normal Map build no flip at all."""
    from surfgrad_addon.addon.groups import common, projection, tangent_space
    from surfgrad_addon.reference.socket_specs import DIRECTX

    def no_switch(b):
        b.input(DIRECTX)                # declared, so looked up; its value goes nowhere
    common.directx_input = projection.directx_input = tangent_space.directx_input = no_switch


ONLY_SHAPE = "SURFGRAD_TEST_ONLY_SHAPE"


def build_one_shape():
    """SG Decal built with only the shape that the environment names."""
    from surfgrad_addon.addon.groups import projection
    full, only = projection.decal_weight, int(os.environ[ONLY_SHAPE])
    projection.decal_weight = lambda b, q, shape, falloff: full(b, q, shape, falloff, (only,))
    folded_cost.build_materials()


ONLY_BLEND = "SURFGRAD_TEST_ONLY_BLEND"


def build_one_blend():
    """SG Blend Normals built with only the method that the environment names."""
    from surfgrad_addon.addon.groups import tangent_space
    only = int(os.environ[ONLY_BLEND])

    def one(b, method, candidates):
        # A Menu keeps its Menu Switch (its items name the choices the material sets), each
        # item fed the one blend.
        if method.type == "MENU":
            return tangent_space.choose(b, method, [candidates[only]] * len(candidates))
        return candidates[only]
    tangent_space.select_blend = one
    folded_cost.build_materials()


def build_with_integers():
    """The groups as lines without Menu sockets build them: each enumeration an integer
    feeding a chain of Mix nodes (enum_input)."""
    import dataclasses
    from surfgrad_addon.addon import node_builder
    line = node_builder.running_line()
    node_builder.running_line = lambda: dataclasses.replace(line, menu_sockets=False)
    folded_cost.build_materials()


def build_without_far():
    _without_far()
    folded_cost.build_materials()


def build_without_strength():
    """No Strength product: the groups' by_strength returns the gradient as it is."""
    from surfgrad_addon.addon.groups import common, projection
    common.by_strength = projection.by_strength = lambda b, v, strength: v
    folded_cost.build_materials()


def build_without_directx():
    _without_directx()
    folded_cost.build_materials()


def build_listings():
    """Materials made of the listings' nodes alone, with the groups' named extras (Listing 2's
    clamp before the Normal Map node, Listing 5's facing-away branch, SG Resolve's guard, the
    inverted Bump node's floor for steep heights) and nothing else: what the SG materials
    should fold down to."""
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.addon.groups import common as C
    from surfgrad_addon.harness.bench import render_materials as M
    from surfgrad_addon.addon.node_vocabulary import Math, VMath
    from surfgrad_addon.reference.vecmath import FLT_EPSILON

    def guard(g, v):
        return g.group(G.safe_normal_group(), Vector=v).outputs[0]

    def nm(g, ctx):
        color = C.listing2_colour(g, g.image(ctx["normal"], g.uv("UVMap")), None)
        n = ns = g.geometry("Normal")
        v = g.normal_map(color, "TANGENT", 1.0, "UVMap")
        return guard(g, g.sub(n, C.surfgrad_reaching(g, n, v, ns)))

    def forward(g, ctx):
        n = g.geometry("Normal")
        nb = g.bump(M.noise_texture(g), n, G.FORWARD_FILTER_WIDTH)
        k = g.math(Math.MAXIMUM, g.dot(nb, n), FLT_EPSILON)     # steep heights' floor
        grad = g.vmath(VMath.MULTIPLY_ADD, nb, g.math(Math.DIVIDE, -1.0, k), n)
        sg = g.scale(grad, M.BUMP_DISTANCE)
        return guard(g, g.sub(n, sg))

    def triplanar(g, ctx):
        x, y, z = g.separate(g.geometry("Position"))
        tri = g.group(G.triplanar_group())
        for axis, (u, v) in zip("XYZ", ((z, y), (x, z), (x, y))):
            g.link(g.image(ctx["normal"], g.combine(u, v)), tri.inputs[f"Color {axis}"])
        return g.resolve(tri.outputs[0])
    ctx = M.images(normal_size=16, height_size=16)
    for key, build in (("nm-listing", nm), ("bump-listing", forward), ("tri-listing", triplanar)):
        M.material(key, build, ctx)


def test_the_sg_materials_fold_to_their_listings(svm):
    """SG Normal Map + SG Resolve, SG Height Map Forward + SG Resolve and SG Coordinates + SG
    Triplanar + SG Resolve (Precise Far From Origin off) compile to exactly their listings'
    nodes with the named extras: the unlinked Normal's fallback, DirectX off, Strength 1 and
    the far route leave nothing behind."""
    found = S.svm_counts(["nm-listing", "bump-listing", "tri-listing"],
                         build="test_render_cost_folding:build_listings",
                         paths=[S.ROOT / "tests"])
    assert {k: found[f"{k}-listing"].nodes for k in ("nm", "bump", "tri")} == \
        {k: svm[f"{k}-sg"]["svm"] for k in ("nm", "bump", "tri")}


def _counts_without(route, keys):
    found = S.svm_counts(keys, build=f"test_render_cost_folding:build_without_{route}",
                         paths=[S.ROOT / "tests"])
    return {k: v.nodes for k, v in found.items()}


def _present(svm, keys):
    return [k for k in keys if k in svm]          # the Sampler materials from 5.0


FAR_KEYS = ["tri-sg", "tri-sampler", "triheight-image", "triheight-sampler", "decal",
            "decal:shape1", "decal:overwrite", "noise", "noise:octaves1", "noise:turbulence"]
DIRECTX_KEYS = ["nm-sg", "tri-sg", "tri-sampler", "uv2-sg", "decal", "layers4-sg"]


def test_precise_far_off_is_the_group_without_the_route(svm):
    """Precise Far From Origin off (the default): every material with SG Triplanar (three
    images, Sampler, height), SG Projector Coordinates or SG Noise compiles to exactly the
    program of the same groups built without the precise route; on, the route runs."""
    keys = _present(svm, FAR_KEYS)
    assert _counts_without("far", keys) == {k: svm[k]["svm"] for k in keys}
    for key in ("tri-sg", "decal", "noise"):
        assert svm[f"{key}:precise"]["svm"] > svm[key]["svm"], key


@pytest.mark.parametrize("shape", range(len(DECAL_SHAPES)))
def test_a_decal_shape_is_the_group_with_that_shape_alone(svm, shape, monkeypatch):
    """SG Decal's Shape (a constant on the node): the material compiles to the program of SG
    Decal built with that one shape's nodes."""
    key = "decal" if shape == 0 else f"decal:shape{shape}"
    monkeypatch.setenv(ONLY_SHAPE, str(shape))
    found = S.svm_counts([key], build="test_render_cost_folding:build_one_shape",
                         paths=[S.ROOT / "tests"])
    assert found[key].nodes == svm[key]["svm"]


@pytest.mark.parametrize("method", [0, 1, 2, 3])
def test_a_blend_method_is_the_group_with_that_blend_alone(svm, method, monkeypatch):
    """SG Blend Normals' Method (a constant on the node): the material compiles to the program
    of SG Blend Normals built with that one blend."""
    key = "blend" if method == 0 else f"blend:method{method}"
    monkeypatch.setenv(ONLY_BLEND, str(method))
    found = S.svm_counts([key], build="test_render_cost_folding:build_one_blend",
                         paths=[S.ROOT / "tests"])
    assert found[key].nodes == svm[key]["svm"]


BLEND_KEYS = ["blend", "blend:method1", "blend:method2", "blend:method3"]
SHAPE_KEYS = ["decal"] + [f"decal:shape{k}" for k in range(1, len(folded_cost.DECAL_SHAPES))]


def test_a_menu_costs_what_its_integer_did(svm):
    """Where an enumeration is a Menu (5.0 and later: SG Blend Normals' Method, SG Decal's
    Shape), each item's material compiles to as many SVM nodes as the same material with the
    integer of older lines set to that index: the Menu Switch folds to the chosen branch as the
    integer's chain does."""
    from surfgrad_addon.reference.blender_lines import facts_for
    import bpy
    if not facts_for(bpy.app.version).menu_sockets:
        pytest.skip("Method is the integer on this line (the test above covers it)")
    keys = BLEND_KEYS + SHAPE_KEYS
    found = S.svm_counts(keys, build="test_render_cost_folding:build_with_integers",
                         paths=[S.ROOT / "tests"])
    menu = {k: svm[k]["svm"] for k in keys}
    print("SVM nodes, menu:", menu, "integer:", {k: found[k].nodes for k in keys})
    assert {k: found[k].nodes for k in keys} == menu
    for group in (BLEND_KEYS, SHAPE_KEYS):    # the items differ: not one branch for all
        assert len({menu[k] for k in group}) > 1


def build_generic_unlinked_basis():
    """uv2-sg with the generic SG Procedural Basis, its UV unlinked (the active render map)."""
    from surfgrad_addon.addon import groups
    generic = groups.procedural_basis_group
    groups.procedural_basis_group = lambda uv_map="": generic()
    folded_cost.build_materials()


def test_the_per_map_basis_costs_the_unlinked_generic_group(svm):
    """SG Procedural Basis [Detail] (bench-render's uv2-sg) costs no more than the generic
    group with its UV unlinked: the choice of map folds away (its UV Map node reads the map
    the image's UV Map node reads, which Cycles may merge). The generic group
    with a UV Map node linked in keeps the choice in each of the UV gradients' Bump
    evaluations: dearer."""
    found = S.svm_counts(["uv2-sg"], build="test_render_cost_folding:build_generic_unlinked_basis",
                         paths=[S.ROOT / "tests"])
    print("SVM, uv2-sg per-map:", svm["uv2-sg"]["svm"], "generic unlinked:",
          found["uv2-sg"].nodes, "generic linked:", svm["uv2-sg:linked"]["svm"])
    assert svm["uv2-sg"]["svm"] <= found["uv2-sg"].nodes
    assert svm["uv2-sg:linked"]["svm"] > svm["uv2-sg"]["svm"]


def test_strength_one_is_the_group_without_the_product(svm):
    """Strength 1 (the default) on SG Triplanar, SG Tangent Normal and SG Decal: the program
    of the groups built with no Strength product; another Strength is one node more."""
    keys = _present(svm, ["tri-sg", "tri-sampler", "uv2-sg", "decal"])
    assert _counts_without("strength", keys) == {k: svm[k]["svm"] for k in keys}
    for key in ("tri-sg", "uv2-sg"):
        assert svm[f"{key}:strength"]["svm"] > svm[key]["svm"], key


def test_directx_off_is_the_group_without_the_switch(svm):
    """DirectX off (the default): SG Normal Map, SG Triplanar, SG Tangent Normal and SG Decal
    compile to the program of the groups built with no flip; on, the flip is a node."""
    keys = _present(svm, DIRECTX_KEYS)
    assert _counts_without("directx", keys) == {k: svm[k]["svm"] for k in keys}


def test_every_material_is_counted_in_the_lines_unit(svm):
    import bpy
    assert set(svm) == {key for key, *_ in folded_cost.materials()}
    assert {r["unit"] for r in svm.values()} == {S.unit_for(bpy.app.version)}
    for key, row in svm.items():
        if "against" in row:
            assert row["ratio"] == row["svm"] / svm[row["against"]]["svm"], key
    # each twin bends the normal: more than the unperturbed material
    for twin in ("nm-builtin", "bump-builtin", "tri-builtin", "uv2-builtin"):
        assert svm[twin]["svm"] > svm["none"]["svm"], twin


def test_a_node_input_costs_nothing(svm):
    """SG Normal Map's Strength is the Normal Map node's own input: any value is free; with the
    Base Gradient unlinked (zero) SG Decal's Overwrite folds away."""
    assert svm["nm-sg:strength"]["svm"] == svm["nm-sg"]["svm"]
    assert svm["decal:overwrite"]["svm"] == svm["decal"]["svm"]


def test_directx_on_is_a_node(svm):
    """The flip is a product by -1 (it does not fold)."""
    for key in ("nm-sg", "tri-sg", "uv2-sg"):
        assert svm[f"{key}:directx"]["svm"] > svm[key]["svm"], key


def test_unused_octaves_vanish(svm):
    """Octaves 1 to 4: each octave the same gradient-noise group, so the program grows by the
    same amount per octave; an unused octave costs nothing."""
    counts = [svm[f"noise:octaves{k}"]["svm"] for k in (1, 2, 3)] + [svm["noise"]["svm"]]
    steps = {b - a for a, b in zip(counts, counts[1:])}
    assert len(steps) == 1 and steps.pop() > 0, counts


SHAPE_MARGIN = 0.05


def test_only_the_chosen_decal_shape_runs(svm):
    """Each shape alone: the sphere (one length and a ramp) is the cheapest, the box (two
    tests, a depth ramp) next, the cylinder (a ramp on the radius and the depth ramp) and the
    cone (the cylinder's with a divide by its radius) the dearest. Were the six computed
    everywhere, all six counts would be one."""
    box, sphere, cylinder, cone, wedge, capsule = (
        svm["decal"]["svm"], *(svm[f"decal:shape{k}"]["svm"] for k in range(1, 6)))
    assert sphere < box < cylinder < cone
    # The wedge (the cone's slope ramp on |x|, a test on y) and the capsule (a clamp on |z|,
    # the sphere's length and ramp) cost no more than the dearest of the first four plus a
    # node or two (SHAPE_MARGIN of the material).
    for added in (wedge, capsule):
        assert sphere < added <= cone * (1.0 + SHAPE_MARGIN), (added, cone)


def test_an_unlinked_input_is_free_and_a_linked_one_pays_its_test(svm):
    """'Unlinked' is decided by a vector's length: left unlinked (zero) the test folds; linked,
    it runs per sample."""
    for option, base in (("nm-sg:normal", "nm-sg"), ("bump-sg:normal", "bump-sg"),
                         ("noise:vector", "noise")):
        assert svm[option]["svm"] > svm[base]["svm"], option
