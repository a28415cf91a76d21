"""Facts about Blender 5.0.1's Cycles that surfgrad's shader node groups rely on, pinned by
Cycles CPU bakes (EMIT, 1 sample, float image) on small triangle meshes against numpy models
written independently from the mesh arrays (helpers and models: tests/support/facts_probe.py).

Meshes: a 16 x 8 lat-long sphere of triangles ("sphere"), the same under a rotated,
non-uniformly scaled, translated object matrix (scale (1.7, 0.6, 1.1), "xform"), a 4 x 4
plane. Two UV maps: "UVMap" (active, the bake target) and "Detail" (UVMap rotated 30 degrees,
tiled twice). Bakes are 64 x 64 unless said otherwise; numbers are maxima over all covered
texels. The whole file runs in about 3 s.

1. Bump-node inversion gives the surface gradient. With Strength 1, Distance D, Normal input N
   = the shading normal (Geometry > Normal) and a Height that is linear on each triangle,
   g = (N - n / (n . N)) / D, computed in nodes from the Bump output n, is the exact surface
   gradient of that height relative to N: g . N = 0 and g . v = the height's change along
   every v in the triangle's plane (for the UV map's s: g . dP/ds = 1, g . dP/dt = 0), smooth
   or flat shading, any object matrix. Independent of Filter Width up to float32 rounding;
   relative error |g - gs| / |gs| on sphere / xform:
     fw 0.1: 6.5e-5 / 7.2e-5   fw 1: 6.5e-6 / 7.4e-6   fw 2: 5.6e-6 / 4.4e-6
     fw 10:  2.0e-6 / 3.1e-6   fw 100: 2.0e-6 / 3.0e-6
   (direction: 0.0035 deg at fw 0.1, 0.0002 deg at fw >= 10). Best: fw >= 10 (flat up to
   1e5), with D |g| ~ 1-10 (|gs| is 0.1-0.7 here; D = 0.01 gives 3e-4, D = 100 7e-6). The
   default fw 0.1 is ~30x worse than fw 10 (cancellation in h_x - h_c).
   Shifted in the Bump node's copies (exact gradients to 3e-6, fw 10, xform): Texture
   Coordinate UV / Generated / Object, UV Map node (any map by name), Attribute node (UV map
   by name, Vector output), Geometry Position. NOT shifted: Geometry Normal (g = 2e-7).
   Texture Coordinate Normal IS shifted (g up to 1.6). Generated = (object position -
   texspace location) / texspace size * 0.5 + 0.5.
2. An unlinked vector group input "Normal" of a shader node group is exactly (0, 0, 0).
   Routed into a Bump node's Normal with no Height linked (inside the group) it gives the
   shading normal when unlinked (5e-5 deg, unit length) and, when linked, the linked vector
   passed through as is (NOT normalised; 5e-7 absolute). bpy 5.0 has
   `NodeTreeInterfaceSocketVector.default_input`, but for a shader tree its only item is
   'VALUE' (setting 'NORMAL' or 'POSITION' raises TypeError; it is a Geometry Nodes feature).
   So the Bump trick is the way: one node, no cost.
3. Geometry > Normal, smooth: the normalised interpolated vertex normal, unit to 2e-7. A
   single-user mesh is synced with its object transform APPLIED: each vertex normal goes to
   world by the normal matrix and is normalised BEFORE interpolation (5e-5 deg); a mesh shared
   by two objects is interpolated in object space, then transformed (5e-5 deg). Under the
   xform scale the two differ by 4.9 deg (TexelData.normal is the second). Flat: Ng (8e-5 deg).
   Normal Map node (tangent space, UV map by name): in OBJECT space, the interpolated,
   unnormalised MikkTSpace tangent T (= Mesh.calc_tangents) and sign, the unnormalised
   interpolation of the unit vertex normals N (smooth) or Ng (flat); B = sign * cross(N, T);
   out = normalize(c.x T + c.y B + c.z N) taken to world by the NORMAL matrix M^-T (7e-5 deg;
   normalising T or N first is 4-9 deg off). So colour (1, .5, .5) gives normalize(M^-T T)
   and (.5, 1, .5) normalize(M^-T sign N x T): the normalised world tangent / signed
   bitangent only without non-uniform scale (sphere: 3e-5 deg); under the xform scale
   M^-T T is 48-51 deg away from M T.
   Tangent node (UV map): normalize(M^-T T) projected onto the shading normal's plane, unit,
   no sign (8e-5 deg; with M T instead: > 30 deg off under xform).
4. In a bake the Bump node (and its shifted copies) uses dPdx, dPdy = r * make_orthonormals(Ng)
   (Cycles' normalize((1,1,1) x Ng) and Ng x that: diagonals unrelated to the texel axes),
   r = 0.25 * (|dP/ds| / W + |dP/dt| / H): Blender passes half-texel barycentric
   differentials, Cycles compacts them to their mean length. Shifted copies read the height at
   uv + fw * (change of uv along dPdx or dPdy). `cycles_bake_bump_image` (svm/displace.h's
   formula + the reference's sample_image) reproduces a baked Bump node over a Linear Image
   Texture on plane, sphere, xform smooth and flat, 64 x 64 and 64 x 32, fw 0.1 / 1 / 2, tilts
   up to 84 deg, to 0.0035 deg max (median <= 1.5e-4 deg). Wrong models are far off: r
   doubled 11-16 deg, half-texel steps along the texel axes 13-27 deg.
   Texture-space forward differences built in nodes (three Image Texture taps at st,
   st + (1/w, 0), st + (0, 1/h); dH/ds = w (h_r - h_c), dH/dt = h (h_u - h_c)) times the
   Bump-inverted gradients gs, gt of that UV map reproduce the reference's one-texel forward
   difference surface gradient to 5e-6 relative (and that equals methods.height_map_surfgrad
   'one-texel' to 4e-9 where the reference's base normal is Cycles').
"""

import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

pytest.importorskip("bpy")

from support import bake_probe as base  # noqa: E402
from support import facts_probe as fp  # noqa: E402
from surfgrad_addon.reference.blender_lines import LINES  # noqa: E402
from surfgrad_addon.reference.height_map import deriv_from_height_map  # noqa: E402
from surfgrad_addon.reference.methods import height_map_surfgrad  # noqa: E402

W = 64
# The Normal Map and Tangent nodes against the frame model: 8e-5 deg up to 5.0; 5.2 leaves an
# unexplained 0.0004-0.003 deg in the tangent (not its storage: packing it, in any space,
# fits worse; measured on the 16 x 8 sphere, 0.0011 plain, 0.0022 under XFORM).
FRAME_BAR = 4e-3 if fp.LINE.packed_normals else 2e-4
OTHER_LINE = LINES["5.0"] if fp.LINE.line == "5.2" else LINES["5.2"]
XFORM = fp.trs_matrix((0.3, -0.2, 0.5), (30.0, -20.0, 50.0), (1.7, 0.6, 1.1))
MESHES = {"sphere": (fp.add_sphere, None), "xform": (fp.add_sphere, XFORM),
          "plane": (fp.add_plane, None)}


def _scene(kind="sphere", smooth=True, width=W, height=W, tangent_maps=("UVMap", "Detail")):
    base.new_scene()
    maker, mw = MESHES[kind]
    obj = maker(matrix_world=mw, smooth=smooth)
    td = fp.rasterize(fp.mesh_arrays(obj, tangent_maps), "UVMap", width, height)
    return obj, fp.Graph(obj), td


def _bake(graph, td, socket):
    return fp.texels(td, graph.bake(socket, td.width, td.height))[:, :3]


def _rel(got, ref):
    return np.linalg.norm(got - ref, axis=-1) / np.linalg.norm(ref, axis=-1)


# --------------------------------------------------------------------------------------------
# 1. Bump-node inversion = surface gradient of a height that is linear on each triangle

FILTER_WIDTHS = (0.1, 1.0, 2.0, 10.0, 100.0)
# Measured maxima (sphere / xform): 6.5e-5 / 7.2e-5, 6.5e-6 / 7.4e-6, 5.6e-6 / 4.4e-6,
# 2.0e-6 / 3.1e-6, 2.0e-6 / 3.0e-6.
REL_BOUND = {0.1: 1.5e-4, 1.0: 1.5e-5, 2.0: 1.2e-5, 10.0: 6e-6, 100.0: 6e-6}


@pytest.mark.parametrize("kind", ["sphere", "xform"])
def test_bump_inversion_is_uv_surface_gradient_for_every_filter_width(kind):
    obj, g, td = _scene(kind)
    n = fp.shading_normal(td)
    gs, gt = fp.uv_surface_gradients(td, n)
    # The expectation is the surface gradient: tangent to N, dual to dP/ds, dP/dt.
    dp_ds, dp_dt, _ = td.derivatives()
    np.testing.assert_allclose(np.sum(gs * dp_ds, -1), 1.0, atol=1e-9)
    np.testing.assert_allclose(np.sum(gs * dp_dt, -1), 0.0, atol=1e-9)
    np.testing.assert_allclose(np.sum(gs * n, -1), 0.0, atol=1e-9)
    s, t, _ = g.separate(g.texcoord().outputs["UV"])
    results = {}
    # 4.2's Bump node has no Filter Width: it steps one differential (as fw 1).
    widths = FILTER_WIDTHS if fp.LINE.bump_filter_width else (1.0,)
    for fw in widths:
        got = _bake(g, td, g.inverted_bump_gradient(s, 1.0, fw))
        rel = _rel(got, gs)
        assert rel.max() < REL_BOUND[fw], (fw, rel.max())
        assert fp.angle_deg(got, gs).max() < (0.006 if fw < 1 else 0.001)
        results[fw] = (got, rel.max())
    if fp.LINE.bump_filter_width:
        # Independent of Filter Width (linear heights), and fw >= 10 is the most accurate.
        for fw in FILTER_WIDTHS[1:]:
            assert _rel(results[fw][0], results[10.0][0]).max() < 1.5e-4
        assert results[10.0][1] < results[0.1][1] / 10
        assert results[10.0][1] < results[1.0][1]
    # t as well (fw 10).
    got = _bake(g, td, g.inverted_bump_gradient(t, 1.0, 10.0))
    assert _rel(got, gt).max() < (6e-6 if fp.LINE.bump_filter_width else REL_BOUND[1.0])


def test_bump_inversion_flat_shading_and_distance():
    """Flat shading (N = Ng, the gradient lies in the triangle's plane) and other Distances:
    D |g| near 1 is best; D = 0.01 loses two digits (measured 3e-4), D = 100 keeps 1e-5."""
    obj, g, td = _scene("xform", smooth=False)
    n = fp.shading_normal(td, smooth=False)
    gs, _ = fp.uv_surface_gradients(td, n)
    s = g.separate(g.texcoord().outputs["UV"])[0]
    # 4.2 (no Filter Width, fw 1 precision): measured 1e-3 / 1.0e-5 / 3e-5.
    bars = ((0.01, 6e-4), (1.0, 6e-6), (100.0, 2e-5)) if fp.LINE.bump_filter_width else \
        ((0.01, 2e-3), (1.0, 1.5e-5), (100.0, 6e-5))
    for distance, bound in bars:
        got = _bake(g, td, g.inverted_bump_gradient(s, distance, 10.0))
        assert _rel(got, gs).max() < bound, (distance, _rel(got, gs).max())


def _corner_values(td, obj, what):
    m = td.mesh
    p_obj = np.asarray(m.positions)[m.triangles]
    if what == "Generated":
        me = obj.data
        assert me.use_auto_texspace
        loc, size = np.array(me.texspace_location), np.array(me.texspace_size)
        return (p_obj - loc) / size * 0.5 + 0.5
    return {"UVMap": lambda: m.uv("UVMap"), "Detail": lambda: m.uv("Detail"),
            "Object": lambda: p_obj, "Position": lambda: m.corner_positions_world}[what]()


INPUTS = {
    # label: (socket builder, corner values key, component)
    "TexCoord UV.y": (lambda g: g.texcoord().outputs["UV"], "UVMap", 1),
    "UV Map node Detail.x": (lambda g: g.uv_map_node("Detail"), "Detail", 0),
    "Attribute Detail.x": (lambda g: g.attribute("Detail"), "Detail", 0),
    "Attribute Detail.y": (lambda g: g.attribute("Detail"), "Detail", 1),
    "Attribute UVMap.x": (lambda g: g.attribute("UVMap"), "UVMap", 0),
    "TexCoord Generated.x": (lambda g: g.texcoord().outputs["Generated"], "Generated", 0),
    "TexCoord Object.y": (lambda g: g.texcoord().outputs["Object"], "Object", 1),
    "Geometry Position.x": (lambda g: g.geometry().outputs["Position"], "Position", 0),
}


@pytest.mark.parametrize("label", sorted(INPUTS))
def test_bump_copies_shift_these_inputs(label):
    obj, g, td = _scene("xform")
    build, key, comp = INPUTS[label]
    corner = _corner_values(td, obj, key)[..., comp]
    ref = fp.linear_surface_gradient(td, corner, fp.shading_normal(td))
    height = g.separate(build(g))[comp]
    got = _bake(g, td, g.inverted_bump_gradient(height, 1.0, 10.0))
    bar = 1e-5 if fp.LINE.bump_filter_width else 2.5e-5            # 4.2: fw 1 precision
    assert _rel(got, ref).max() < bar, _rel(got, ref).max()      # measured <= 3e-6 (fw 10)


def test_generated_coordinates_model():
    """Generated = (object position - texspace location) / texspace size * 0.5 + 0.5."""
    obj, g, td = _scene("xform")
    me = obj.data
    got = _bake(g, td, g.texcoord().outputs["Generated"])
    ref = (td.position_object - np.array(me.texspace_location)) \
        / np.array(me.texspace_size) * 0.5 + 0.5
    assert np.abs(got - ref).max() < 1e-6


def test_bump_copies_do_not_shift_geometry_normal_but_shift_texcoord_normal():
    obj, g, td = _scene("xform")
    nx = g.separate(g.geometry().outputs["Normal"])[0]
    got = _bake(g, td, g.inverted_bump_gradient(nx, 1.0, 10.0))
    assert np.abs(got).max() < 1e-6                   # measured 2.4e-7: not shifted
    tx = g.separate(g.texcoord().outputs["Normal"])[0]
    got = _bake(g, td, g.inverted_bump_gradient(tx, 1.0, 10.0))
    if fp.LINE.line == "4.2":
        # 4.2 shifts no normal in the Bump node's copies (the groups use neither output).
        assert np.abs(got).max() < 1e-6
    else:
        assert np.median(np.linalg.norm(got, axis=-1)) > 0.1  # shifted (measured up to 1.6)


# --------------------------------------------------------------------------------------------
# 2. The default of a "Normal" group input

def _normal_group(name, via_bump):
    bpy = base.bpy
    ng = bpy.data.node_groups.new(name, "ShaderNodeTree")
    ng.interface.new_socket("Normal", in_out="INPUT", socket_type="NodeSocketVector")
    ng.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketVector")
    gi, go = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
    if via_bump:
        b = ng.nodes.new("ShaderNodeBump")              # no Height linked
        ng.links.new(gi.outputs["Normal"], b.inputs["Normal"])
        ng.links.new(b.outputs["Normal"], go.inputs["Out"])
    else:
        ng.links.new(gi.outputs["Normal"], go.inputs["Out"])
    return ng


@pytest.mark.parametrize("via_bump", [False, True])
def test_group_normal_input_unlinked_and_linked(via_bump):
    obj, g, td = _scene("xform")
    ng = _normal_group("NormalDefault", via_bump)
    unlinked = g.node("ShaderNodeGroup", node_tree=ng)
    got = _bake(g, td, unlinked.outputs["Out"])
    if via_bump:
        assert fp.angle_deg(got, fp.shading_normal(td)).max() < 1e-3      # measured 3e-5
        assert np.abs(np.linalg.norm(got, axis=-1) - 1).max() < 1e-6
    else:
        assert np.all(got == 0.0)
    linked = g.node("ShaderNodeGroup", node_tree=ng)
    vec = g.vmath("ADD", g.geometry().outputs["Position"], (0.3, -2.0, 0.7))
    g.links.new(vec, linked.inputs["Normal"])
    got = _bake(g, td, linked.outputs["Out"])
    ref = td.position + np.array([0.3, -2.0, 0.7])
    assert np.abs(got - ref).max() < 2e-6             # passed through, NOT normalised
    assert np.abs(np.linalg.norm(ref, axis=-1) - 1).min() > 0.1


@pytest.mark.tier("blender")
def test_default_input_normal_is_geometry_nodes_only():
    bpy = base.bpy
    base.new_scene()
    ng = bpy.data.node_groups.new("G", "ShaderNodeTree")
    sock = ng.interface.new_socket("Normal", in_out="INPUT", socket_type="NodeSocketVector")
    assert sock.default_input == "VALUE"
    for value in ("NORMAL", "POSITION"):
        with pytest.raises(TypeError):
            sock.default_input = value
    geo = bpy.data.node_groups.new("GN", "GeometryNodeTree")
    gsock = geo.interface.new_socket("Normal", in_out="INPUT", socket_type="NodeSocketVector")
    gsock.default_input = "NORMAL"                    # the property is meant for Geometry Nodes
    assert gsock.default_input == "NORMAL"


# --------------------------------------------------------------------------------------------
# 3. Geometry Normal, Normal Map node, Tangent node

@pytest.mark.parametrize("smooth", [True, False])
def test_geometry_normal(smooth):
    obj, g, td = _scene("xform", smooth=smooth)
    got = _bake(g, td, g.geometry().outputs["Normal"])
    assert np.abs(np.linalg.norm(got, axis=-1) - 1).max() < 1e-6
    assert fp.angle_deg(got, fp.shading_normal(td, smooth)).max() < 2e-4    # measured 8e-5
    if smooth:
        # Single-user mesh: transform applied, corner normals normalised in world space before
        # the interpolation. Interpolating in object space is degrees off under this scale.
        assert fp.angle_deg(got, fp.shading_normal(td, True, False)).max() > 2.0
        # A mesh shared by two objects keeps its object space: then it is the other model.
        bpy = base.bpy
        twin = bpy.data.objects.new("Twin", obj.data)
        twin.location = (5.0, 0.0, 0.0)
        bpy.context.scene.collection.objects.link(twin)
        got = _bake(g, td, g.geometry().outputs["Normal"])
        assert fp.angle_deg(got, fp.shading_normal(td, True, False)).max() < 2e-4
        assert fp.angle_deg(got, fp.shading_normal(td, True, True)).max() > 2.0


@pytest.mark.parametrize("kind,smooth", [("sphere", True), ("xform", True), ("xform", False)])
@pytest.mark.parametrize("uv_map", ["UVMap", "Detail"])
def test_normal_map_node_unit_colours_give_tangent_and_bitangent(kind, smooth, uv_map):
    obj, g, td = _scene(kind, smooth=smooth)
    t, sign, n = fp._object_frame(td, uv_map, smooth)
    nm3 = td.mesh.normal_matrix
    m3 = td.mesh.matrix_world[:3, :3]
    for colour, vec in (((1.0, 0.5, 0.5, 1.0), t),
                        ((0.5, 1.0, 0.5, 1.0), sign[:, None] * np.cross(n, t))):
        node = g.node("ShaderNodeNormalMap", space="TANGENT", uv_map=uv_map)
        node.inputs["Color"].default_value = colour
        got = _bake(g, td, node.outputs["Normal"])
        assert fp.angle_deg(got, fp._normalize(vec @ nm3.T)).max() < FRAME_BAR
        np.testing.assert_allclose(got, fp.cycles_normal_map(td, colour, uv_map, smooth),
                                   atol=3e-6 if FRAME_BAR < 1e-3 else 1e-4)
        as_direction = fp.angle_deg(got, fp._normalize(vec @ m3.T)).max()
        if kind == "xform":
            assert as_direction > 30.0                 # measured 48-51 deg: NOT M @ T
        else:
            assert as_direction < FRAME_BAR


def test_normal_map_node_uses_unnormalised_interpolated_frame():
    """A coarse 8 x 4 sphere (|T| down to 0.93, |N| to 0.87 between vertices): the tangent is
    interpolated unnormalised on every line; the normal is unnormalised up to 5.0 and unit in
    5.2 (LineFacts.normal_map_unit_normal). The other line's model is degrees off, and so is
    normalising the tangent."""
    base.new_scene()
    obj = fp.add_sphere(matrix_world=XFORM, segments=8, rings=4)
    g = fp.Graph(obj)
    td = fp.rasterize(fp.mesh_arrays(obj, ("UVMap",)), "UVMap", W, W)
    colour = (0.9, 0.25, 0.7, 1.0)
    node = g.node("ShaderNodeNormalMap", space="TANGENT", uv_map="UVMap")
    node.inputs["Color"].default_value = colour
    got = _bake(g, td, node.outputs["Normal"])
    assert fp.angle_deg(got, fp.cycles_normal_map(td, colour)).max() < FRAME_BAR
    other = fp.angle_deg(got, fp.cycles_normal_map(td, colour, line=OTHER_LINE)).max()
    assert other > 2.0, other                                  # measured 9.0 (5.2), 4.0 (5.0)
    t, sign, n = fp._object_frame(td, "UVMap", True)
    c = 2.0 * (np.array(colour[:3]) - 0.5)
    tt = fp._normalize(t)
    v = c[0] * tt + c[1] * sign[:, None] * np.cross(n, tt) + c[2] * n
    assert fp.angle_deg(got, fp._normalize(v @ td.mesh.normal_matrix.T)).max() > 1.0


@pytest.mark.parametrize("kind,smooth", [("sphere", True), ("xform", True), ("xform", False)])
def test_tangent_node(kind, smooth):
    obj, g, td = _scene(kind, smooth=smooth)
    for uv_map in ("UVMap", "Detail"):
        node = g.node("ShaderNodeTangent", direction_type="UV_MAP", uv_map=uv_map)
        got = _bake(g, td, node.outputs["Tangent"])
        assert np.abs(np.linalg.norm(got, axis=-1) - 1).max() < 1e-6
        ref = fp.cycles_tangent_node(td, uv_map, smooth)
        assert fp.angle_deg(got, ref).max() < FRAME_BAR
        assert np.abs(np.sum(got * fp.shading_normal(td, smooth), -1)).max() < 1e-5
        if kind == "xform":
            t, _, _ = fp._object_frame(td, uv_map, smooth)
            n = fp.shading_normal(td, smooth)
            tm = t @ td.mesh.matrix_world[:3, :3].T
            tm = fp._normalize(tm - np.sum(tm * n, -1, keepdims=True) * n)
            assert fp.angle_deg(got, tm).max() > 30.0


# --------------------------------------------------------------------------------------------
# 4. The Bump node over an image, reproduced in numpy

def _height_image(w=16, h=12, seed=5):
    return np.random.default_rng(seed).uniform(0, 1, (h, w))


def _image_height_socket(g, himg, uv_map="UVMap"):
    h, w = himg.shape
    px = np.ones((h, w, 4), np.float32)
    px[..., 0] = himg
    px[..., 1], px[..., 2] = 0.3, 0.7
    img = base.new_float_image("height", w, h, px)
    tex = g.node("ShaderNodeTexImage", image=img, interpolation="Linear", extension="REPEAT")
    g.links.new(g.uv_map_node(uv_map), tex.inputs["Vector"])
    return g.separate(tex.outputs["Color"])[0]


@pytest.mark.parametrize("kind,smooth,size", [("plane", True, (W, W)),
                                              ("sphere", True, (W, W)),
                                              ("xform", True, (W, W)),
                                              ("xform", False, (W, W)),
                                              ("xform", True, (W, 32))])
def test_bump_node_over_image_reproduced_in_numpy(kind, smooth, size):
    obj, g, td = _scene(kind, smooth=smooth, width=size[0], height=size[1],
                        tangent_maps=())
    himg = _height_image()
    height = _image_height_socket(g, himg.astype(np.float32))
    hf = himg.astype(np.float32).astype(np.float64)
    bakes = {}
    for fw, dist in ((1.0, 1.0), (2.0, 0.05), (0.1, 0.05)):
        got = _bake(g, td, g.bump(height, None, dist, fw))
        ref = fp.cycles_bake_bump_image(td, hf, fw, dist, smooth)
        ang = fp.angle_deg(got, ref)
        assert ang.max() < 0.02, (fw, dist, ang.max())     # measured <= 0.0035 deg
        assert fp.angle_deg(ref, fp.shading_normal(td, smooth)).max() > 10.0   # real tilts
        bakes[fw, dist] = got
    # Negative controls (fw 2, D 0.05): the step length and directions matter.
    fw, dist = 2.0, 0.05
    got = bakes[fw, dist]
    dpdx, dpdy = fp.cycles_bake_bump_differentials(td)
    uv = td.uv()

    def model(dx, dy):
        h = lambda st: fp.sample_image(hf, st, "Linear", "REPEAT")  # noqa: E731
        f = fp.LINE.bump_step_scale(fw)
        return fp.cycles_bump_normal(fp.shading_normal(td, smooth), dx, dy, h(uv),
                                     h(uv + f * fp.uv_step(td, dx)),
                                     h(uv + f * fp.uv_step(td, dy)), dist, f)
    assert np.abs(model(dpdx, dpdy) - fp.cycles_bake_bump_image(td, hf, fw, dist, smooth)
                  ).max() < 1e-12
    assert fp.angle_deg(got, model(dpdx, dpdy)).max() < 0.02
    # The other line's r (half or double this one's): measured 11-16 deg max
    k = OTHER_LINE.bake_differential_scale / fp.LINE.bake_differential_scale
    assert fp.angle_deg(got, model(k * dpdx, k * dpdy)).max() > 5.0
    # half-texel steps along the texel axes instead of Cycles' diagonals: 13-27 deg max
    sx, sy, _, _ = td.texel_steps()
    assert fp.angle_deg(got, model(0.5 * sx, 0.5 * sy)).max() > 5.0


def test_bake_differentials_radius():
    """The model's r = k (|dP/ds| / W + |dP/dt| / H), k = 0.25 up to 5.0 and 0.5 in 5.2, and
    the pair is r * make_orthonormals(Ng). (The bakes above pin k against Cycles.)"""
    obj, g, td = _scene("xform", width=W, height=32, tangent_maps=())
    dpdx, dpdy = fp.cycles_bake_bump_differentials(td)
    dp_ds, dp_dt, _ = td.derivatives()
    k = 0.5 if fp.LINE.line == "5.2" else 0.25
    r = k * (np.linalg.norm(dp_ds, axis=-1) / W + np.linalg.norm(dp_dt, axis=-1) / 32)
    np.testing.assert_allclose(np.linalg.norm(dpdx, axis=-1), r)
    np.testing.assert_allclose(np.linalg.norm(dpdy, axis=-1), r)
    ng = td.geometric_normal
    assert np.abs(np.sum(dpdx * ng, -1)).max() < 1e-12
    assert np.abs(np.sum(dpdx * dpdy, -1)).max() < 1e-12


@pytest.mark.parametrize("kind", ["sphere", "xform"])
def test_three_tap_forward_differences_in_nodes(kind):
    """Recipe (c): three Image Texture taps at st, st + (1/w, 0), st + (0, 1/h) on a second UV
    map, dH/ds = w (h_r - h_c), dH/dt = h (h_u - h_c), combined with the Bump-inverted
    gradients gs, gt of that map: the reference's one-texel forward difference
    (deriv_from_height_map at lod 0) as a surface gradient."""
    obj, g, td = _scene(kind, tangent_maps=())
    himg = _height_image(16, 12, seed=9)
    ih, iw = himg.shape
    px = np.ones((ih, iw, 4), np.float32)
    px[..., 0] = himg
    img = base.new_float_image("height", iw, ih, px)
    st = g.uv_map_node("Detail")

    def tap(offset):
        tex = g.node("ShaderNodeTexImage", image=img, interpolation="Linear",
                     extension="REPEAT")
        g.links.new(g.vmath("ADD", st, offset), tex.inputs["Vector"])
        return g.separate(tex.outputs["Color"])[0]
    h_c, h_r, h_u = tap((0.0, 0.0, 0.0)), tap((1.0 / iw, 0.0, 0.0)), tap((0.0, 1.0 / ih, 0.0))
    dhds = g.math("MULTIPLY", g.math("SUBTRACT", h_r, h_c), float(iw))
    dhdt = g.math("MULTIPLY", g.math("SUBTRACT", h_u, h_c), float(ih))
    s, t, _ = g.separate(st)
    gs = g.inverted_bump_gradient(s, 1.0, 10.0)
    gt = g.inverted_bump_gradient(t, 1.0, 10.0)
    a = g.vmath("SCALE", gs)
    g.links.new(dhds, a.node.inputs["Scale"])
    b = g.vmath("SCALE", gt)
    g.links.new(dhdt, b.node.inputs["Scale"])
    got = _bake(g, td, g.vmath("ADD", a, b))

    n = fp.shading_normal(td)
    rgs, rgt = fp.uv_surface_gradients(td, n, "Detail")
    d = deriv_from_height_map(himg.astype(np.float32).astype(np.float64), td.uv("Detail"))
    ref = d[:, 0:1] * iw * rgs + d[:, 1:2] * ih * rgt
    err = np.linalg.norm(got - ref, axis=-1) / np.linalg.norm(ref, axis=-1).max()
    assert err.max() < 5e-5, err.max()                # measured 5e-6
    if kind == "sphere":
        # ... which is the reference's SG Height Map, 'one-texel' variant (its base normal,
        # normalize(td.normal), is Cycles' shading normal when the object matrix is identity).
        _, sg = height_map_surfgrad(td, himg.astype(np.float32).astype(np.float64),
                                    "one-texel", uv_map="Detail")
        assert np.abs(sg - ref).max() < 1e-7 * np.abs(ref).max()     # measured 4e-9
