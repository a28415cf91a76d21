"""Red team 54f: round 54b's glTF lead narrowed (a KHR_mesh_quantization glTF, imported by
Blender's glTF importer, whose tangent-space map was up to 1.33 degrees off the image on 5.2,
1.44 on 5.0 and 4.5, 0.13 on 4.2, in two columns of texels). Bisected on the imported mesh
(5.2): not the positions' scale (scaled to 1: 1.33), not the UVs (rounded to k/8: 1.33), not
the triangulation (joined to quads: 1.39), not custom normals differing from the smooth ones
(custom normals set to the mesh's own smooth normals, 0.0008 degrees apart: 1.55). The
importer marks 32 faces flat (`sharp_face`: the four columns of triangles at u 0.17 to 0.21
and 0.79 to 0.83, where the int8 NORMALs of a face are equal) and keeps the NORMALs as custom
normals, 1.98 degrees off those faces' own normal (4.2 gives flat faces their own normal:
0.00). All faces smooth: 0.14; custom normals cleared: 0.13 on 5.2 (1.95 on 4.2-5.0: finding 2).

What an artist sees: the baked map read back through the same Normal Map node, rendered
(Cycles, baked in object space) against the source material rendered the same way. It is off
as far as the map is off the image, so a readback does not cancel it: imported, 5.2 max 1.27
/ mean 0.20 degrees; 5.0 and 4.5 1.38 / 0.21; 4.2 0.03. Blender's bake encodes on Blender's
corner normals; Cycles' Normal Map node decodes on the normal Cycles shades with (kernel
svm/tex_coord.h svm_node_normal_map: `sd->Ng` on a flat triangle, on every line; 5.2's
triangle_smooth_normal_unnormalized_object_space reads corner normals only where the object
has them). Rebuilt here by code (an 8 x 8 curved quad grid, two columns of faces flat):

1. Custom normals on flat faces (2.09 degrees off the faces' own): render-vs-render max 1.35 /
   mean 0.22 degrees (5.2), 1.46 / 0.22 (5.0, 4.5, 4.2), exit 0 and no word. Now the bake
   warns, naming the faces and the fix (Shade Smooth: 0.03 on every line). Not corrected: the
   map is Blender's own conversion.
2. Flat and smooth faces mixed, no custom normals nor sharp edges, on 4.2, 4.5 and 5.0 (Cycles
   there shades the smooth faces with vertex normals that average the flat faces in; Blender's
   corner normals leave them out): max 2.01 / mean 0.46 degrees, exit 0 and no word; 5.2 0.03.
   Now the bake warns on those lines (not on 5.2), with the same fix.

3. Every face flat, quads not planar (a grid with heights jittered by up to 0.08 on 0.25
   cells; no custom normals): Blender's corner normals are the polygon's, Cycles shades each
   triangle with its own: max 30.5 / mean 9.8 degrees, on 5.2 and 4.2 alike, exit 0 and no
   word. Now the bake warns; shaded smooth, 0.22 (5.2) / 0.03 (4.2).

4. On 5.2, smooth triangles whose corner normals spread far apart (a triangulated grid with
   every 7th vertex lifted 0.2; interpolated normal 0.950 long at a centre): 5.2's Normal Map
   node makes the frame normal unit length, Blender's bake encodes on it as it is (as
   MikkTSpace's decoder does: engines read the map as baked): max 1.28 / mean 0.13 degrees in
   5.2 (up to 5.0: 0.03). A warning for it (estimate 0.5 (1/L - 1) radians) fired on most
   low-poly smooth meshes (demo.blend's torus, rock and displaced grids: 1 to 3 degrees
   estimated), so the coordinator took it out: a known limit (docs/pipelines.md), pinned here
   per line. Subdividing does not help (levels 1 to 3: max 2.6 to 2.0, mean 0.11 to 0.02).

Fine (no warning, within 0.1 degrees on every line): custom normals on smooth faces only;
every face smooth. 54b's morph target at 1.0 (2.3 degrees off the image on 5.2 only;
render-vs-render 2.12) is finding 4, not the shape key nor the custom normals: the mix applied
to the mesh and the keys removed, 2.12 (5.2) / 0.03 (5.0); custom normals cleared, 2.12; its
triangles' normals are 0.92 long at the centre (estimate 2.4). Left alone: smooth
quads that are not planar render off on every line (the same grid as quads: lift 0.2, 3.1
degrees; 0.1, 0.87; 0.05, 0.16), cause not found, not warned; 4.2's 4.3-degree object-space
map of the quantized import was not looked at.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from test_faults_gltf54b import N_IMAGE, _frame, _grid  # noqa: E402,F401

pytestmark = pytest.mark.tier("bake")

SIZE = 32
FLAT_COLUMNS = (1, 6)


def _read(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    img.colorspace_settings.name = "Non-Color"
    px = np.empty(SIZE * SIZE * 4, np.float32)
    img.pixels.foreach_get(px)
    got = px.reshape(SIZE, SIZE, 4)[..., :3] * 2.0 - 1.0
    return img, got / np.linalg.norm(got, axis=-1, keepdims=True)


def _render_vs_render(obj, tmp_path, tag="a"):
    """Degrees between the source material's shading normal and the shading normal of the
    baked tangent map read back through the same Normal Map node (both baked in object space,
    which is Cycles' shading normal as rendered); and the bake's warnings."""
    from surfgrad_addon import api
    import contextlib
    import io
    tmp_path = tmp_path / tag
    tmp_path.mkdir()
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        api.bake_normal_map(obj, str(tmp_path / "t.exr"), resolution=SIZE, margin=0,
                            samples=1, log=None)
    api.bake_normal_map(obj, str(tmp_path / "src.exr"), space="object", resolution=SIZE,
                        margin=0, samples=1, log=None)
    tangent_map, _ = _read(tmp_path / "t.exr")
    _, source = _read(tmp_path / "src.exr")
    tex = next(n for n in obj.active_material.node_tree.nodes
               if n.bl_idname == "ShaderNodeTexImage")
    source_image, tex.image = tex.image, tangent_map
    api.bake_normal_map(obj, str(tmp_path / "back.exr"), space="object", resolution=SIZE,
                        margin=0, samples=1, log=None)
    tex.image = source_image
    _, back = _read(tmp_path / "back.exr")
    off = np.degrees(np.arccos(np.clip((source * back).sum(-1), -1.0, 1.0)))
    return off, err.getvalue()


def _flat_columns(obj, custom):
    """Two columns of faces flat; custom normals (set after, so they hold on the flat faces):
    the curved surface's at each vertex (2.09 degrees off a flat face's own), or none."""
    me = obj.data
    for p in me.polygons:
        p.use_smooth = p.index % 8 not in FLAT_COLUMNS
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        bpy.ops.mesh.customdata_custom_splitnormals_clear()
    if custom:
        x = np.array([v.co.x for v in me.vertices])
        me.normals_split_custom_set_from_vertices(_frame(x)[2].tolist())
    me.update()
    return sorted(p.index for p in me.polygons if not p.use_smooth)


def _vertex_normals_shaded():
    from surfgrad_addon.reference.blender_lines import facts_for
    return not facts_for(bpy.app.version).sharp_faces_give_corner_normals


def test_custom_normals_on_flat_faces_warn_and_shade_smooth_fixes(tmp_path):
    """1: the map renders > 1 degree off the source (1.35 on 5.2, 1.46 up to 5.0) and the bake
    warns naming flat faces; after Shade Smooth, within 0.1 degrees and no warning."""
    obj = _grid()
    flat = _flat_columns(obj, custom=True)
    off, err = _render_vs_render(obj, tmp_path)
    assert off.max() > 1.0, off.max()
    assert "16 face(s)" in err and f"faces {flat[0]}, {flat[1]}," in err, err
    assert "Shade Smooth" in err
    for p in obj.data.polygons:
        p.use_smooth = True
    obj.data.update()
    off, err = _render_vs_render(obj, tmp_path, "smooth")
    assert off.max() < 0.1, off.max()
    assert "Normal Map node decodes" not in err, err


def test_flat_and_smooth_mixed_without_custom_normals_is_the_line_fact(tmp_path):
    """2: up to 5.0 the map renders > 1.5 degrees off (2.01) and the bake warns; 5.2 shades
    with corner normals: within 0.1 degrees, no warning."""
    obj = _grid()
    _flat_columns(obj, custom=False)
    off, err = _render_vs_render(obj, tmp_path)
    if _vertex_normals_shaded():
        assert off.max() > 1.5, off.max()
        assert "vertex normals" in err and "Shade Smooth" in err, err
    else:
        assert off.max() < 0.1, off.max()
        assert "Normal Map node decodes" not in err, err


def test_custom_normals_on_smooth_faces_are_fine(tmp_path):
    """Fine: the importer's custom normals with every face smooth (54b's rebuild)."""
    obj = _grid()
    assert obj.data.has_custom_normals
    off, err = _render_vs_render(obj, tmp_path)
    assert off.max() < 0.1, off.max()
    assert "Normal Map node decodes" not in err, err


def test_object_space_bakes_do_not_warn(tmp_path):
    """The warning is the tangent frame's: an object-space bake of finding 1's mesh has none."""
    from surfgrad_addon import api
    import contextlib
    import io
    obj = _grid()
    _flat_columns(obj, custom=True)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        api.bake_normal_map(obj, str(tmp_path / "o.exr"), space="object", resolution=SIZE,
                            margin=0, samples=1, log=None)
    assert "Normal Map node decodes" not in err.getvalue()


def test_non_planar_flat_quads_warn(tmp_path):
    """3: twisted quads, all flat: > 5 degrees off (30.5) and warned; triangulated (the fix the
    warning names for them; the flat look stays): < 0.5, no word."""
    obj = _grid()
    me = obj.data
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        bpy.ops.mesh.customdata_custom_splitnormals_clear()
    for v in me.vertices:
        v.co.z += 0.04 * ((v.index * 7919) % 5 - 2)
    for p in me.polygons:
        p.use_smooth = False
    me.update()
    off, err = _render_vs_render(obj, tmp_path, "flat")
    assert off.max() > 5.0, off.max()
    assert "flat quads that are not planar" in err and "Triangulate Faces" in err, err
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(me)
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    bm.to_mesh(me)
    bm.free()
    me.update()
    off, err = _render_vs_render(obj, tmp_path, "triangulated")
    assert off.max() < 0.5, off.max()
    assert "Normal Map node decodes" not in err, err


def _bumpy_triangles(cuts=0):
    """The grid triangulated, every 7th vertex lifted 0.2, smooth, no custom normals."""
    import bmesh
    obj = _grid()
    me = obj.data
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        bpy.ops.mesh.customdata_custom_splitnormals_clear()
    for v in me.vertices:
        if v.index % 7 == 0:
            v.co.z += 0.2
    bm = bmesh.new()
    bm.from_mesh(me)
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    if cuts:
        bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=cuts, use_grid_fill=True,
                                  smooth=1.0)
        bmesh.ops.triangulate(bm, faces=bm.faces[:])
    bm.to_mesh(me)
    bm.free()
    for p in me.polygons:
        p.use_smooth = True
    me.update()
    return obj


def test_short_interpolated_normals_are_the_line_fact(tmp_path):
    """4: a known limit, not warned: 5.2 renders the map read back 1 to 2 degrees off (1.28);
    up to 5.0 within 0.1."""
    from surfgrad_addon.reference.blender_lines import facts_for
    off, err = _render_vs_render(_bumpy_triangles(), tmp_path)
    if facts_for(bpy.app.version).normal_map_unit_normal:
        assert 1.0 < off.max() < 2.0, off.max()
    else:
        assert off.max() < 0.1, off.max()
