"""Red team 35c: `compare` and the bake request on meshes as other tools write them.

1. A UV corner dragged far out of the UDIM grid (u = 1e5 on one corner of one face: a stray
   vertex in an importer's UVs, a typo in a script): Blender's bake scan-converts in float32,
   where a UV that large is rounded to a fifth of a texel at 32^2, so which of two faces takes
   a texel beside that face's long edges is decided by rounding. The reference's edge band
   assumed UVs on the UDIM grid: a correct SG Normal Map was called wrong, p99 0.0006 / max
   23.6 deg at 32^2 on 5.2 (the neighbour's tangent frame against the stretched face's). Now
   the band grows with a triangle's farthest UV (reference/raster.py), those texels are left
   out as "edge".
2. A corner at u = 1e30 (finite, so no check refused it): the reference's raster and the bake
   request's overlap count cast 3e31 texels to an integer, and numpy's "invalid value
   encountered in cast" RuntimeWarning reached the user's terminal from compare and from
   bake-normal-map's checks. Now the bounds are clipped before the cast.
3. A NaN or Inf UV: refused as before, but the tiles and overlap counts the request reads
   before its finiteness check cast NaN to integers: four numpy RuntimeWarnings, with their
   source lines, above the refusal on stderr; and so did NaN in a 2D attribute on face
   corners that the bake does not read (an importer's extra channel, which Blender lists as
   a UV map: the request reads every UV map's tiles). Now such a triangle covers no tile.
4. Faces in an empty material slot (an importer's or an artist's leftover slot, a material
   unlinked; a material index past the slots counts as the last): Blender's bake writes each
   face into its material's image node, and such a face has none. Before, bake-normal-map
   baked with exit 0 and left those faces out: half of a grid whose second slot was empty
   had no texel at --margin 0 (98 of 196 at 16^2, 5.2 and 4.2), and the default margin
   filled the hole from the neighbours, a plausible but wrong map; with every face there,
   a blank map. Now the request refuses it, naming the faces and the slot
   (addon/empty_slots.py). compare puts its material in every slot, so it was not affected.
5. A bent n-gon (an OBJ's or Alembic's, two quads of a bumped grid merged) whose long side
   runs straight in UV through a middle corner: one of its triangles lies on a line in UV,
   and the warning of red team 34 (faces whose UVs collapsed) named the face, "so the bake
   writes no texel for them; unwrap them", though the face has UV area and is baked whole.
   Now a face is named only when none of its triangles has UV area.
6. Free normals that are not numbers (NaN at a corner: a Set Mesh Normal node fed NaN, a
   script, an importer writing free normals; 4.5 and later store them as given): compare
   refused the mesh, bake-normal-map baked it with exit 0, Cycles shading a stand-in there
   (3 texels of a 16^2 object-space map off by up to 0.2 in 0..1 on 5.2; on 4.5 and 5.0 the
   map of the normals whole). Now the request refuses it on every line, as NaN positions and
   UVs, naming the corners' count and the fix.
"""

import dataclasses
import warnings

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import bake_request  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_unseen_meshes31 import P99, MAX, empty_file  # noqa: E402,F401
from test_faults_unseen_meshes32 import _grid, _object, _set_free_normals  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 32


def _dragged(u, corners=1):
    """The bumped 8 x 8 grid over UVs 0.05..0.65, the first `corners` corners of face 0
    moved to u (4: the whole face, a line in UV space)."""
    verts, faces, uvs = _grid()
    obj = _object("Dragged", [(verts, faces, uvs)])
    layer = obj.data.uv_layers["UVMap"].uv
    corner = np.empty(len(layer) * 2)
    layer.foreach_get("vector", corner)
    corner[0:2 * corners:2] = u
    layer.foreach_set("vector", corner)
    obj.data.update()
    return obj


@pytest.mark.parametrize("u,corners", [(1e5, 1), (1e30, 1), (1e30, 4)])
def test_a_uv_corner_dragged_far_out_is_compared_within_the_bar(empty_file, u, corners):
    """1 and 2. Within the bar with texels of the dragged face left out as on an edge
    (before, 1e5: p99 3.1 deg), and no RuntimeWarning from compare or the request's checks
    (before, 1e30: "invalid value encountered in cast" from each)."""
    obj = _dragged(u, corners)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        report = compare.compare(obj, "normal-map", RES)
        bake_request.mesh_problems(obj, "UVMap", [], tiles=[1001], resolution=RES)
    assert report["texels_compared"] > 250, report
    assert report["p99_deg"] <= P99 and report["max_deg"] <= MAX, report
    if corners == 1:     # the face's sliver in the 0..1 square, decided by float32 rounding
        assert report["excluded"]["edge"] > 20, report


@pytest.mark.parametrize("u", [np.nan, np.inf])
def test_a_uv_that_is_not_a_number_is_refused_in_one_line(empty_file, u):
    """3. A NaN or Inf UV (a broken exporter): refused, as before, but without numpy's
    "invalid value encountered in cast" from the tiles and overlap counts the request reads
    first (before: four RuntimeWarning lines, with their source lines, above the refusal);
    compare's refusal reads as the request's (before: "UV map 'UVMap' contain ...")."""
    obj = _dragged(u)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        problems = bake_request.mesh_problems(obj, "UVMap", [], tiles=[1001], resolution=RES)
        with pytest.raises(ValueError) as err:
            compare.compare(obj, "normal-map", RES)
    assert problems == ["the UVs of UV map 'UVMap' of object 'Dragged' contain non-finite "
                        "values (NaN or Inf); unwrap it again (UV > Unwrap)"]
    assert str(err.value) == ("Dragged: the UVs of UV map 'UVMap' contain non-finite values "
                              "(NaN or Inf); fix the mesh data before baking")


def _slotted(indices, slots):
    """The grid with material slots `slots` (None: an empty slot, else a Diffuse material)
    and each face's material index from `indices` (a callable of the face count)."""
    verts, faces, uvs = _grid()
    obj = _object("Slotted", [(verts, faces, uvs)])
    for name in slots:
        obj.data.materials.append(None if name is None else diffuse_material(name)[0])
    obj.data.polygons.foreach_set("material_index", np.asarray(indices(len(faces)), np.int32))
    obj.data.update()
    return obj


def _object_space_map(tmp_path, obj, name):
    """A 32^2 object-space bake of obj with no margin: (texels, 3)."""
    out = tmp_path / f"{name}.exr"
    api.bake_normal_map(obj, str(out), resolution=32, space="object", depth="float", margin=0)
    img = bpy.data.images.load(str(out))
    px = np.empty(len(img.pixels), np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4)[:, :3]


def _covered(tmp_path, obj, name):
    """How many texels _object_space_map writes."""
    return int(np.count_nonzero(np.abs(_object_space_map(tmp_path, obj, name)).sum(1)))


def _half(n):
    return [0] * (n // 2) + [1] * (n - n // 2)


def _past_the_slots(n):
    return [0] * (n // 2) + [5] * (n - n // 2)


@pytest.mark.parametrize("indices,slots,said", [
    (_half, ["A", None], "32 face(s) of object 'Slotted' (faces 32, 33, 34, 35, 36, 37, 38, "
     "39 and 24 more) use empty material slot 2, "),
    (_half, [None, "A"], "32 face(s) of object 'Slotted' (faces 0, 1, 2, 3, 4, 5, 6, 7 and 24 "
     "more) use empty material slot 1, "),
    (_past_the_slots, ["A", None], "32 face(s) of object 'Slotted' (faces 32, 33, 34, 35, 36, "
     "37, 38, 39 and 24 more) use empty material slot 2 (a material index past the last slot "
     "counts as the last), ")], ids=["second_empty", "first_empty", "index_past_the_slots"])
def test_faces_in_an_empty_material_slot_are_refused(empty_file, tmp_path, indices, slots,
                                                     said):
    """4. Faces whose slot is empty (an importer's leftover slot; a material index past the
    slots, which counts as the last): refused, naming them (before: baked with exit 0 and a
    hole where they lie)."""
    obj = _slotted(indices, slots)
    with pytest.raises(ValueError) as err:
        api.bake_normal_map(obj, str(tmp_path / "n.png"), resolution=16)
    assert said + ("so the bake writes nothing for them, a hole in the map: give the slot a "
                   "material, or assign those faces to a slot that has one (Material "
                   "Properties > Assign)") in str(err.value)
    assert not (tmp_path / "n.png").exists()


def test_what_the_bake_of_an_empty_slot_writes(empty_file, tmp_path, monkeypatch):
    """4. The fact the refusal rests on, on this line: with the check taken away, the faces
    of the empty slot (half the grid's) get no texel; an empty slot no face uses bakes as the
    grid with one slot, and is not refused."""
    from surfgrad_addon.addon import bake_request as request
    whole = _covered(tmp_path, _slotted(lambda n: [0] * n, ["A", None]), "unused")
    assert whole == _covered(tmp_path, _slotted(lambda n: [0] * n, ["A"]), "one_slot") > 300
    monkeypatch.setattr(request, "empty_slot_problem", lambda *a: None)
    half = _covered(tmp_path, _slotted(_half, ["A", None]), "half")
    assert abs(half - whole / 2) <= 0.1 * whole, (half, whole)


def _bent_hexagons():
    """The bumped 8 x 8 grid with each pair of quads in even rows merged into a hexagon (an
    OBJ's or Alembic's n-gons): the middle corners of its long sides lie on a straight line in
    UV, not on the bent mesh."""
    verts, quads, uvs = _grid()
    faces = []
    for j in range(8):
        row = quads[8 * j:8 * j + 8]
        if j % 2:
            faces += row
            continue
        for a, b in zip(row[::2], row[1::2]):
            faces.append([a[0], a[1], b[1], b[2], a[2], a[3]])
    return _object("Hexagons", [(verts, faces, uvs)])


def test_bent_ngons_on_a_straight_uv_border_are_not_called_collapsed(empty_file):
    """5. Before: "UV map 'UVMap' of object 'Hexagons': 5 face(s) with area on the mesh have
    none in UV space (their UVs collapsed to a point or a line: faces 1, 2, 10, 11, 18), so
    the bake writes no texel for them", though every face has UV area (compare covers them
    all); a triangle of each across its straight UV border was taken for the face."""
    obj = _bent_hexagons()
    mesh = obj.data
    mesh.calc_loop_triangles()
    uv = np.empty(len(mesh.loops) * 2)
    mesh.uv_layers["UVMap"].uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    # Independently: every face's UV polygon has area (the shoelace formula) ...
    for face in mesh.polygons:
        u, v = uv[list(face.loop_indices)].T
        assert abs(np.dot(u, np.roll(v, -1)) - np.dot(v, np.roll(u, -1))) > 1e-4
    # ... while some of Blender's triangles of them lie on a line in UV: the case is there.
    def uv_area2(t):
        (du, dv), (eu, ev) = uv[list(t.loops[1:])] - uv[t.loops[0]]
        return abs(du * ev - dv * eu)
    flat = [t for t in mesh.loop_triangles if uv_area2(t) < 1e-12]
    assert len(flat) >= 4 and all(t.area > 5e-4 for t in flat)      # (quads: 0.0625 m^2)
    warnings = []
    assert bake_request.mesh_problems(obj, "UVMap", warnings) == [] and warnings == []


def _free_normals_with_nan(obj):
    """The mesh's corner normals stored as free normals, those of corner 5 NaN (4.5 and
    later; skips 4.2, where a 'custom_normal' attribute is a plain one)."""
    mesh = obj.data
    normals = np.array([mesh.vertices[loop.vertex_index].normal for loop in mesh.loops])
    normals[5] = np.nan
    assert (~np.isfinite(_set_free_normals(mesh, normals, "CORNER")).any(1)).sum() > 0


def test_normals_that_are_not_numbers_are_refused(empty_file, tmp_path, monkeypatch):
    """6. Free normals with a NaN corner (a Set Mesh Normal node fed NaN, a script, an
    importer writing free normals): compare refused the mesh ("corner_normals contain
    non-finite values"), bake-normal-map baked it, exit 0, where Cycles shades with a
    stand-in. With the check taken away: on 5.2 texels there differ from the same mesh's map
    with its normals whole; on 4.5 and 5.0 this stand-in happens to give that map. Refused on
    every line, as NaN positions and UVs are: the data holds no normal there to bake."""
    from surfgrad_addon.addon import bake_request as request
    verts, faces, uvs = _grid()
    maps = {}
    for nan in (False, True):
        obj = _object(f"Normals {nan}", [(verts, faces, uvs)])
        obj.data.materials.append(diffuse_material("Plain")[0])
        if nan:
            _free_normals_with_nan(obj)
            with pytest.raises(ValueError) as err:
                api.bake_normal_map(obj, str(tmp_path / "n.png"), resolution=16)
            assert (f"the normals of mesh {obj.data.name!r} of object 'Normals True' are not "
                    f"numbers (NaN or Inf) at 1 face corner(s), where Cycles shades with a "
                    f"stand-in") in str(err.value)
            read = request.baked_mesh
            monkeypatch.setattr(request, "baked_mesh",
                                lambda o: dataclasses.replace(read(o), nonfinite_normals=0))
        maps[nan] = _object_space_map(tmp_path, obj, f"nan_{nan}")
    differ = np.count_nonzero(np.abs(maps[True] - maps[False]).max(-1) > 1e-3)
    if bpy.app.version >= (5, 2):       # its octahedral-packed normals: NaN packs to a stand-in
        assert 0 < differ < 20
    else:                               # 4.5, 5.0: here the map of the normals whole
        assert differ == 0


def test_a_2d_attribute_on_corners_that_is_no_uv_map_is_left_alone(empty_file):
    """3. A 2D vector attribute on face corners (an importer's extra channel: glTF custom
    attributes, USD primvars) is a UV map to Blender; the request reads every UV map's
    tiles, so its NaN values (not read by the bake of 'UVMap') gave numpy's RuntimeWarnings
    on stderr before. Now the bake of 'UVMap' sees no problem and says nothing."""
    obj = _dragged(0.05)                          # the grid as it is
    mesh = obj.data
    extra = mesh.attributes.new("Velocity", "FLOAT2", "CORNER")
    values = np.zeros(len(mesh.loops) * 2)
    values[::7] = np.nan
    extra.data.foreach_set("vector", values)
    assert "Velocity" in mesh.uv_layers
    warnings_said = []
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert bake_request.mesh_problems(obj, "UVMap", warnings_said, tiles=[1001],
                                          resolution=RES) == []
    assert warnings_said == []
