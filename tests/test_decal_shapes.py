"""Decal shapes and modes: each shape's weight at points whose value is known by hand, add
against overwrite on the reference, and the Add Decal Projector operator's shape and display.
Bakes on curved surfaces against the reference: test_bake_compare's decal-<shape> and
decal-overwrite cases."""

import numpy as np
import pytest

from surfgrad_addon.reference import decals as D

pytestmark = pytest.mark.tier("numpy")


F = 0.2        # falloff


@pytest.mark.parametrize("shape,point,want", [
    ("box", (0.9, -0.99, 0.0), 1.0),            # inside the square, mid-depth
    ("box", (1.01, 0.0, 0.0), 0.0),             # outside the square
    ("box", (0.0, 0.0, 0.9), 0.5),              # 0.1 from the near face: half faded
    ("sphere", (0.0, 0.0, 0.0), 1.0),
    ("sphere", (0.6, 0.0, 0.7365459931), 0.25), # |q| = 0.95
    ("sphere", (0.8, 0.8, 0.0), 0.0),           # |q| > 1
    ("cylinder", (0.6, 0.6, 0.0), 0.757359313), # rho = 0.8485: (1 - rho) / 0.2
    ("cylinder", (0.0, 0.5, -0.95), 0.25),      # the far end
    ("cone", (0.45, 0.0, 0.0), 0.5),            # radius 0.5 at z = 0: 1 - 0.9 = 0.1
    ("cone", (0.0, 0.3, 0.5), 0.0),             # radius 0.25 at z = 0.5: outside
    ("cone", (0.0, 0.0, 0.95), 0.25),           # on the axis near the apex: depth fade
    ("wedge", (0.0, 0.0, 0.0), 1.0),            # the footprint's centre line
    ("wedge", (0.45, 0.0, 0.0), 0.5),           # half-width 0.5 at y = 0: 1 - 0.9 = 0.1
    ("wedge", (0.5, 0.6, 0.0), 0.0),            # half-width 0.2 at y = 0.6: outside
    ("wedge", (0.9, -1.0, 0.0), 0.5),           # on the base: half-width 1
    ("wedge", (0.0, -1.01, 0.0), 0.0),          # past the base: a hard edge
    ("wedge", (0.0, -0.5, -0.95), 0.25),        # the far end: depth fade
    ("capsule", (0.0, 0.0, 0.0), 1.0),
    ("capsule", (0.0, 0.9, 0.0), 0.5),          # 0.9 from the segment
    ("capsule", (0.6, 0.0, 0.5), 1.0),          # 0.6 from the segment's end
    ("capsule", (0.0, 0.0, 1.45), 0.25),        # in the cap, 0.95 beyond the end
    ("capsule", (0.0, 0.6, -1.1), 0.757359313), # in the cap: sqrt(0.72) from the end
    ("capsule", (0.48, 0.64, -1.1), 0.0),       # on the cap's surface: distance 1
    ("capsule", (0.95, 0.0, 0.9), 0.0),         # inside the cylinder, outside the capsule
])
def test_shape_weights(shape, point, want):
    got = D.WEIGHTS[shape](np.array([point]), F)[0]
    assert got == pytest.approx(want, abs=1e-6)


def test_every_shape_has_its_listing_named_function():
    n = np.array([[0.0, 0.0, 1.0]] * 2)
    deriv = np.array([[0.3, -0.2]] * 2)
    q = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]])        # centre, far outside
    for shape in D.DECAL_SHAPES:
        fn = getattr(D, f"surfgrad_from_decal_{shape}")
        sg = fn(n, deriv, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), q, F)
        np.testing.assert_allclose(sg[0], [0.3, -0.2, 0.0], atol=1e-12)
        np.testing.assert_allclose(sg[1], 0.0, atol=1e-12)


def test_add_sums_and_overwrite_replaces_by_the_weight():
    base = np.array([[0.2, 0.1, 0.0], [0.2, 0.1, 0.0]])
    own = np.array([[0.0, -0.4, 0.0], [0.0, -0.4, 0.0]])
    weight = np.array([1.0, 0.25])
    added = D.decal_layer(base, weight[:, None] * own, weight, overwrite=False)
    np.testing.assert_allclose(added, [[0.2, -0.3, 0.0], [0.2, 0.0, 0.0]])
    over = D.decal_layer(base, weight[:, None] * own, weight, overwrite=True)
    np.testing.assert_allclose(over, [[0.0, -0.4, 0.0], [0.15, -0.025, 0.0]])


@pytest.mark.tier("blender")
def test_the_operator_offers_every_shape_and_displays_it(fresh):
    bpy = fresh
    from surfgrad_addon.addon import operators as O
    from surfgrad_addon.addon.compat import new_material
    from surfgrad_addon.harness import scenes as test_scenes
    obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    mat = new_material("M")
    obj.data.materials.append(mat)
    prop = O.SURFGRAD_OT_add_decal_projector.__annotations__["shape"]
    shapes = [item[0] for item in prop.keywords["items"]]
    assert shapes == list(D.DECAL_SHAPES)
    # Each outline: its kind, its +Y axis and its location in the projector's space. A
    # circle's or cone's +Y (a cone's apex side) is the projector's +Z at z = +-1, except the
    # wedge's cone: upright in the projector's XY, apex at y = +1 (its triangle seen down Z).
    up, ahead = (0, 0, 1), (0, 1, 0)
    want = {"box": ("CUBE", []), "sphere": ("SPHERE", []),
            "cylinder": ("SINGLE_ARROW", [("CIRCLE", up, (0, 0, 1)), ("CIRCLE", up, (0, 0, -1))]),
            "cone": ("SINGLE_ARROW", [("CONE", up, (0, 0, -1))]),
            "wedge": ("CUBE", [("CONE", ahead, (0, -1, 0))]),
            "capsule": ("SINGLE_ARROW", [("SPHERE", up, (0, 0, 0.5)),
                                         ("SPHERE", up, (0, 0, -0.5))])}
    for shape in D.DECAL_SHAPES:
        empty, decal = O.add_decal_projector(bpy.context, mat.node_tree, shape=shape)
        from surfgrad_addon.addon.enum_input import choice_index
        assert choice_index(decal.inputs["Shape"]) == D.DECAL_SHAPES.index(shape)
        display, outlines = want[shape]
        assert empty.empty_display_type == display
        bpy.context.view_layer.update()
        kids = sorted(empty.children, key=lambda c: c.location.z, reverse=True)
        assert [c.empty_display_type for c in kids] == [kind for kind, _, _ in outlines]
        for kid, (_, axis, where) in zip(kids, outlines):
            m = np.array(kid.matrix_local)
            np.testing.assert_allclose(m[:3, 1], axis, atol=1e-6)
            np.testing.assert_allclose(m[:3, 3], where, atol=1e-6)
    with pytest.raises(O.SurfgradError, match="use one of box, sphere"):
        O.add_decal_projector(bpy.context, mat.node_tree, shape="star")
