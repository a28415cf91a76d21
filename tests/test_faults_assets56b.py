"""Red team 56b: `compare` and `bake-normal-map` on public meshes the project had not seen,
imported with Blender's own importers on 5.2: ufbx/ufbx's FBX test files (Maya, 3ds Max and
Blender exports: UV sets, tangent signs, mirrored normals, instancing, n-gons, zero-scale
pivots, 0.01 and 0.025 unit scales), three.js's verify.obj (six cubes, six materials, faces
with invalid UV indices, points and lines), libigl's tutorial OBJs and bulletphysics/bullet3's
pybullet OBJs, with drei-assets' normal JPGs as --image; each finding is built here by code,
a few faces, so no test reads a fetched file.

1. Faces stacked more than two deep in UV (a box whose six sides all map to the whole UV
   square: 3ds Max's and Maya's default box mapping, ufbx's max_geometry_transform_instances
   Box001..004 and maya_uv_sets' 'PerFace' set; verify.obj's cubes 4 and 5, twelve quads on
   the square): compare's overlap warning named the pairs the rasteriser keeps per texel, the
   winner and the claimant just before it, so the box's six faces were named as one pair,
   "Overlapping faces (1 pairs): 4/5", and verify.obj's twelve as "(1 pairs): 22/23"; the
   faces 0-3 (12-21) under them went unnamed, and the count read as the whole (bullet3's
   duck.obj, three layers deep in places: 2362 pairs named at 256^2 of 3828). Now the faces
   on each contested texel are found from their UV triangles (reference/uv_overlap.claimants,
   at the contested texels only, on a grid of at most 256^2: the duck at 2048^2 took 6.5 s on
   the full grid) and every pair of a stack of three or more is named: the box "(15 pairs):
   0/1, 0/2, 0/3, 0/4, 0/5, 1/2 and 9 more", the twelve quads 66 pairs, the duck 3828;
   two-deep stacks (mirrored halves) name the same pairs as before.

Probed and right on 5.2 (compare normal-map and triplanar at 32^2 unless said; max error in
degrees): libigl cube 0.0013, cylinder 0.0021 (with drei 151_norm.jpg as --image), sphere
0.0063; camel_b (UVs -52..73, no face in the square: refused naming Pack Islands / --tiles);
bullet3 marble_cube 0.0026, cloth 0.0008, three_cubes 0.0039, jenga, prism 0.0030, table,
duck 0.0013, sphere_smooth 0.0025, plate, torus_textured 0.0024, racecar wheel, textured cup
(8192 faces) 0.0019, banana 0.0025, textured_sphere_flat 0.0040, plane (30 m) 0.031, plane100
(200 m, UVs 0..100: triplanar 0.17, the far-out warning given), stadium part1 and kitchen part110
(no face in the square: refused); verify.obj's cube 2 (24 faces, 6 materials, 12 without UVs,
loose edges) normal-map, triplanar, height-map, volume-noise, decal (max 0.0056; the far-out
warning at 310 m), and bake-normal-map with SG stacks in 2 of its 6 materials (both warnings:
no-area faces, overlap; exit 0); ufbx tangent-sign quads FlipX/FlipY/FlipXY with a real normal
JPG 0.0027, the (-1,-1,-1)-scaled Suzanne_Flipped 0.0029, instanced Suzanne.003 (8 users of
one mesh) normal-map and decal 0.0012, Box001 at 0.025 scale, Box004 (2.5 z), Maya UV sets
'Row' (tiles 1001-1006 found and compared) and 'PerFace', the maze's flipped n-gon triangles
(233 texels left out and named), zero-scale pivots (refused naming the zero axis, exit 2, no
file), an 8030-vertex n-gon with all UVs at 0 (refused: no area); made here: n-gon with loose
verts and edges, split vertices, (-1,1,1) and (-2,-2,-2) scales, linked duplicate, custom
normals, 8 UV maps with a different active-render one, UVs on tile 1074, mirrored halves, a
three-face fin, all within 0.005. bake-normal-map of Suzanne with SG stacks in 2 of its 7
materials and of the mirrored Suzanne_Flipped (tangent and object, 64^2): every texel the UVs
cover a unit normal within 3.5e-5, the other materials' faces (0, 0, 1).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import compare  # noqa: E402
from surfgrad_addon.reference import uv_overlap  # noqa: E402
from test_faults_unseen_meshes31 import _within_bar  # noqa: E402

pytestmark = pytest.mark.tier("bake")

SQUARE = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]


def _box_mapped(name, sides):
    """A smooth box (sides of 6) or strip whose every quad maps to the whole UV square, as
    Max's and Maya's box mapping leaves it."""
    if sides == 6:
        verts = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
        faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
                 (1, 5, 7, 3)]
    else:                                   # two quads of a strip, mirrored onto each other
        verts = [(-1, -1, 0), (0, -1, 0.2), (1, -1, 0), (-1, 1, 0), (0, 1, 0.2), (1, 1, 0)]
        faces = [(0, 1, 4, 3), (2, 1, 4, 5)]
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    uv = me.uv_layers.new(name="UVMap")
    for p in me.polygons:
        p.use_smooth = True
        for k, li in enumerate(p.loop_indices):
            uv.data[li].uv = SQUARE[k]
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _named_pairs(text):
    count = int(text.split("Overlapping faces (")[1].split(" pairs")[0])
    shown = text.split("pairs): ")[1].split(" and ")[0].rstrip(".").split(", ")
    return count, [tuple(int(f) for f in p.split("/")) for p in shown]


def test_a_box_mapped_box_names_every_pair_of_its_six_faces(fresh):
    """Finding 1: before '(1 pairs): 4/5'; now C(6, 2) = 15 pairs, the six shown those of the
    lowest faces, and the compare itself within the bar as before."""
    obj = _box_mapped("BoxMapped", 6)
    report = compare.compare(obj, "normal-map", 32)
    _within_bar(report, 500)
    text = [w for w in report["warnings"] if "Overlapping faces" in w]
    assert len(text) == 1, report["warnings"]
    count, shown = _named_pairs(text[0])
    assert count == 6 * 5 // 2, text[0]
    assert shown == [(0, 1), (0, 2), (0, 3), (0, 4), (0, 5), (1, 2)], text[0]
    assert "and 9 more" in text[0]


def test_two_mirrored_quads_are_still_one_pair(fresh):
    """Two-deep stacks (mirrored halves) are named as before: one pair, faces 0 and 1."""
    obj = _box_mapped("Mirrored", 2)
    report = compare.compare(obj, "normal-map", 32)
    _within_bar(report, 500)
    text = [w for w in report["warnings"] if "Overlapping faces" in w]
    assert len(text) == 1, report["warnings"]
    assert _named_pairs(text[0]) == (1, [(0, 1)]), text[0]


@pytest.mark.tier("blender")   # (no bpy in it, but its module imports bpy)
def test_claimants_lists_every_triangle_on_a_texel():
    """uv_overlap.claimants: three triangles stacked on the square's lower half and one beside
    them; at a texel under the stack all three, at one under the fourth that one alone, and
    a texel not asked for is not listed."""
    lower = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]
    upper = [(0.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    tris = np.array([lower, lower, upper, lower])
    size = 8
    under_stack = 1 * size + 6            # x 6, y 1: below the diagonal
    under_upper = 6 * size + 1            # x 1, y 6: above it
    texel, tri = uv_overlap.claimants(tris, size, [under_stack, under_upper])
    got = {(int(t), int(k)) for t, k in zip(texel, tri)}
    assert got == {(under_stack, 0), (under_stack, 1), (under_stack, 3), (under_upper, 2)}
    claims = uv_overlap.claimed_texels(tris, size, one_side=True)
    assert claims[under_stack] == 3 and claims[under_upper] == 1
