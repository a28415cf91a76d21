"""Red team 56a: a review of round 55's checks (normal_sources, flat_frames) on structures an
artist or TD has.

1. A node group with two Group Output nodes (an artist's alternative kept beside the one in
   use; only one is active, the one Blender flattens the group through): a missing normal map
   feeding only the inactive output refused the bake (exit 2, "image 'Alt' reads
   '/nonexistent/...', which does not exist: Cycles would bake its magenta 'missing'
   colour"), though the map cannot hold it: the bake through the active output is the normal
   fed in (measured here, 60 degrees off the surface: 0.00 degrees off it). normal_sources
   and image_checks walked every Group Output of a group. Now only the active one
   (material_inputs.group_outputs: all of them where none is flagged, as freeze.py already
   did): the image is not listed, the map is written; the same image into the active output
   is still refused.
2. flat_frames warned of a planar quad shaded flat whose third vertex lies on the line of the
   first two (a vertex on a straight edge; likewise a doubled vertex): Blender splits the quad
   0-2, and the triangle of no area has a zero normal, "off" every corner normal ("1 face(s)
   ... the map read back through a Normal Map node renders off the material there ... Face >
   Triangulate Faces"). Its other triangle's normal is the corner normals' to 0.00 degrees,
   and the empty one covers no texel. Now a triangle below 1e-5 of its longest edge in
   height is not judged; a twisted flat quad is still warned of.
3. The render-mode pass (render_mesh.py, every bake, Freeze or compare of an object with a
   modifier) ran the session's frame_change_pre and _post handlers, twice each a pass (5.2;
   the bake itself runs none: 0 calls without a modifier); round 55 took out only the render
   handlers. A pipeline's handler stepping a simulation on each frame change (here a shear
   step of the mesh, z += 0.1 x) ran twice: the artist's mesh was left sheared (z 0.2 at the
   corners) and the object-space map of the plane was 11.31 degrees off its normal, exit 0.
   Now they are taken out for the pass and put back: 0 calls, the mesh unchanged, 0.00 off.

Probed and fine: reroutes, muted nodes, a muted BSDF (its Normal not read), groups nested and
unused group inputs (rounds 54c, 55a pin them).
"""

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon.bake_request import BakeRequestError, mesh_problems  # noqa: E402
from surfgrad_addon.addon.bake_uvs import baked_mesh, one_read  # noqa: E402
from surfgrad_addon.addon.image_checks import image_problems  # noqa: E402
from support.baked_normals import baked_normals, degrees_between  # noqa: E402
from support.blender import missing_image  # noqa: E402
from support.materials import plane_with_output  # noqa: E402

pytestmark = pytest.mark.tier("blender")

RES = 16
TILT = math.radians(60.0)
NORMAL = np.array([math.sin(TILT), 0.0, math.cos(TILT)])


def _two_output_plane(missing_on_active):
    """A plane whose Principled BSDF's Normal comes from a group with two Group Outputs: one
    fed a constant normal 60 degrees off the surface (RGB -> Normal Map), the other a missing
    normal map (Image Texture -> Normal Map). The missing one's output is the active one when
    `missing_on_active`. Returns the object."""
    obj, tree = plane_with_output("TwoOutputs")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    tree.links.new(bsdf.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    group = bpy.data.node_groups.new("Normals", "ShaderNodeTree")
    group.interface.new_socket("Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
    constant, alternative = group.nodes.new("NodeGroupOutput"), group.nodes.new("NodeGroupOutput")
    rgb = group.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (*(NORMAL * 0.5 + 0.5), 1.0)
    fixed = group.nodes.new("ShaderNodeNormalMap")
    group.links.new(rgb.outputs[0], fixed.inputs["Color"])
    group.links.new(fixed.outputs[0], constant.inputs[0])
    tex = group.nodes.new("ShaderNodeTexImage")
    tex.image = missing_image("Alt", "rt56a")
    mapped = group.nodes.new("ShaderNodeNormalMap")
    group.links.new(tex.outputs[0], mapped.inputs["Color"])
    group.links.new(mapped.outputs[0], alternative.inputs[0])
    alternative.is_active_output = missing_on_active
    constant.is_active_output = not missing_on_active
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    tree.links.new(node.outputs[0], bsdf.inputs["Normal"])
    return obj


def test_a_missing_image_on_an_inactive_group_output_is_not_refused():
    """Finding 1: not listed at all (before: refused); on the active output: refused."""
    warned = []
    assert image_problems(_two_output_plane(False), warnings=warned) == []
    assert not any("'Alt'" in w for w in warned), warned
    problems = image_problems(_two_output_plane(True))
    assert len(problems) == 1 and "image 'Alt' reads '/nonexistent/rt56a/Alt.png', which " \
        "does not exist: Cycles would bake its magenta" in problems[0], problems


@pytest.mark.tier("bake")
def test_the_bake_reads_the_active_group_output_alone(tmp_path):
    """Finding 1: the map is the active output's normal, every texel (before: BakeRequestError,
    nothing written)."""
    got = baked_normals(_two_output_plane(False), tmp_path / "n.exr", "tangent", RES)
    assert degrees_between(got, NORMAL).max() < 0.05


@pytest.mark.tier("bake")
def test_the_missing_image_on_the_active_output_still_fails_the_bake(tmp_path):
    with pytest.raises(BakeRequestError, match="image 'Alt' reads"):
        baked_normals(_two_output_plane(True), tmp_path / "n.exr", "tangent", RES)
    assert list(tmp_path.iterdir()) == []


def _flat_quad(corners):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("Quad")
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    mesh.uv_layers.new(name="UVMap")
    mesh.polygons[0].use_smooth = False
    obj = bpy.data.objects.new("Quad", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _frame_warnings(obj):
    warnings = []
    with one_read():
        mesh_problems(obj, "UVMap", warnings)
        faces = baked_mesh(obj).frame_faces
    return faces, [w for w in warnings if "tangent-space map is encoded" in w]


@pytest.mark.parametrize("corners", [
    [(0, 0, 0), (1, 0, 0), (2, 0, 0), (1, 1, 0)],        # a vertex on a straight edge
    [(0, 0, 0), (1, 0, 0), (1, 0, 0), (0, 1, 0)],        # a doubled vertex
], ids=["vertex on an edge", "doubled vertex"])
def test_a_flat_quad_with_a_triangle_of_no_area_is_not_warned_of(corners):
    """Finding 2: (before: 1 face warned of, fix named Triangulate Faces)."""
    obj = _flat_quad(corners)
    mesh = obj.data
    mesh.calc_loop_triangles()
    areas = sorted(t.area for t in mesh.loop_triangles)
    assert areas[0] == 0.0 and areas[1] > 0.0      # Blender's split makes the empty one
    # The triangle with texels: its own normal is the face's corner normals (+z), 0 degrees.
    tri = max(mesh.loop_triangles, key=lambda t: t.area)
    p = np.array([mesh.vertices[v].co for v in tri.vertices])
    own = np.cross(p[1] - p[0], p[2] - p[0])
    own /= np.linalg.norm(own)
    corner = np.array([mesh.corner_normals[c].vector for c in tri.loops])
    assert degrees_between(corner, own).max() < 1e-3
    assert _frame_warnings(obj) == ((), [])


def test_a_twisted_flat_quad_is_still_warned_of():
    faces, warned = _frame_warnings(_flat_quad([(0, 0, 0), (1, 0, 0.2), (1, 1, 0), (0, 1, 0.2)]))
    assert faces == (0,) and len(warned) == 1


@pytest.mark.tier("bake")
def test_a_frame_change_handler_is_not_run_by_the_render_mode_pass(tmp_path):
    """Finding 3: a pipeline's frame_change_pre handler stepping a simulation (here: a shear
    of the mesh, z += 0.1 x, a step) on a plane with a modifier. The bake runs no frame change,
    so the map is the plane's own normal (+z) and the mesh stays; before, the render-mode pass
    ran the handler twice: the mesh left sheared (z = 0.2 x at the corners) and the object-space
    map 11.3 degrees off (atan 0.2), exit 0."""
    from support.materials import diffuse_material
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2)
    obj = bpy.context.active_object
    obj.data.materials.append(diffuse_material("Plain")[0])
    obj.modifiers.new("Simple", "SUBSURF").subdivision_type = "SIMPLE"
    steps = []

    def step(scene, *_):
        steps.append(scene.frame_current)
        for v in obj.data.vertices:
            v.co.z += 0.1 * v.co.x
        obj.data.update()

    bpy.app.handlers.frame_change_pre.append(step)
    try:
        got = baked_normals(obj, tmp_path / "n.exr", "object", RES)
    finally:
        bpy.app.handlers.frame_change_pre.remove(step)
    assert steps == []
    assert max(abs(v.co.z) for v in obj.data.vertices) == 0.0
    assert degrees_between(got, np.array([0.0, 0.0, 1.0])).max() < 0.05
