"""Faces where a tangent-space bake and Cycles' Normal Map node build their frames on different
normals, so the map, read back through a Normal Map node, does not render as the material did
(red team 54f). No bpy: the arrays come from bake_uvs.baked_mesh.

Blender's bake turns Cycles' shading normal into tangent space on Blender's corner normals (and
MikkTSpace tangents); Cycles' Normal Map node decodes on the normal Cycles shades with. They
differ in two cases (measured on a curved 8 x 8 grid, 32^2, render of the baked map against
the render of the source material, both through Cycles):

1. A face marked flat (Shade Flat, `sharp_face`) whose corner normals are not its own normal:
   custom normals on flat faces (glTF's importer marks a face flat where its quantized NORMALs
   are equal and keeps them as custom normals). Cycles shades such a triangle flat (its
   geometric normal), the bake converts on the custom ones: faces 2.0 degrees off, max 1.27
   (5.2) / 1.38 (4.5, 5.0) degrees off; on 4.2 the import's flat corners are the face's own.
   Non-planar quads shaded flat likewise (corner normals: the polygon's; Cycles: each
   triangle's): a twisted all-flat grid rendered max 30.5 / mean 9.8 degrees off, every line.
2. Up to 5.0, a mesh mixing flat and smooth faces without custom normals or sharp edges:
   Cycles shades its smooth faces with vertex normals (the flat faces' normals averaged in),
   Blender's corner normals leave the flat faces out: max 2.0 degrees (5.2 shades with corner
   normals: 0.03).

Shade Smooth on every face removes both (0.03 degrees on every line).

3. On 5.2, smooth triangles whose corner normals spread far apart: their interpolated normal
   is short (length L at the centre), and 5.2's Normal Map node normalises it while Blender's
   bake encodes on it as it is (`LineFacts.normal_map_unit_normal`): about 0.5 (1/L - 1)
   radians off at worst (a bumpy triangle grid, L 0.950: 1.28 degrees; L 0.981: 0.49; up to
   5.0: 0.03). Subdividing does not remove it (a Subdivision Surface, levels 1 to 3: max 2.6
   to 2.0); an object-space map reads back within 0.08.
"""

import numpy as np

# Corner normals this far (degrees) from the normal Cycles decodes on: the baked map renders
# about 0.65 x as far off (2.09 -> 1.35 / 1.46 degrees measured).
LIMIT_DEGREES = 0.5


def _off(a, b):
    """Per row: whether unit-ish vectors a and b (N, 3) are more than the limit apart."""
    a = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-30)
    b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-30)
    with np.errstate(invalid="ignore"):
        return (a * b).sum(-1) < np.cos(np.radians(LIMIT_DEGREES))


# A triangle whose height is below this share of its longest edge has no normal of its own
# (three corners on a line, a doubled vertex) and covers no texel of its face: it is not
# judged. Judged, its zero normal was "off" every corner normal: a planar quad shaded flat with
# a vertex on a straight edge (Blender splits it 0-2, one triangle of no area), or with a
# doubled vertex, was warned of as a frame mismatch (fix named: Triangulate Faces) where the
# map renders as the material did (rt56a).
DEGENERATE = 1e-5


def _degenerate(p, own):
    """Per triangle (corners p (t, 3, 3), cross product own (t, 3)): of no area to speak of."""
    edges = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], 1)
    longest = (edges ** 2).sum(-1).max(1)
    return np.linalg.norm(own, axis=-1) <= DEGENERATE * longest


def frame_mismatch_faces(positions, triangles, triangle_faces, triangle_corners, flat_faces,
                         corner_normals, vertex_normals, vertex_normals_shaded):
    """The faces (sorted, unique) where the bake's frame normal and the Normal Map node's differ:
    flat faces whose corner normals are not their triangles' own normal, and, where
    `vertex_normals_shaded` (up to 5.0, no custom normals nor sharp edges, flat and smooth
    mixed), smooth faces whose corner normals are not the vertex normals.
    triangles (T, 3) vertex indices, triangle_corners (T, 3) corner indices, flat_faces (F,)
    bool, corner_normals (C, 3), vertex_normals (V, 3)."""
    if not len(triangles):
        return ()
    flat = np.asarray(flat_faces, bool)[triangle_faces]
    bad = np.zeros(len(triangles), bool)
    if flat.any():
        p = positions[triangles[flat]]
        own = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        corners = corner_normals[triangle_corners[flat]]               # (t, 3, 3)
        off = _off(np.repeat(own, 3, axis=0), corners.reshape(-1, 3)).reshape(-1, 3).any(1)
        bad[flat] = off & ~_degenerate(p, own)
    if vertex_normals_shaded and flat.any() and (~flat).any():
        smooth = ~flat
        corners = corner_normals[triangle_corners[smooth]].reshape(-1, 3)
        verts = vertex_normals[triangles[smooth]].reshape(-1, 3)
        bad[smooth] = _off(corners, verts).reshape(-1, 3).any(1)
    return tuple(np.unique(triangle_faces[bad]).tolist())


def frame_mismatch_warning(what, faces, vertex_normals_shaded):
    """A warning naming `faces` of `what` for a tangent-space bake, or None."""
    if not len(faces):
        return None
    shown = ", ".join(map(str, faces[:8])) + (f" and {len(faces) - 8} more"
                                              if len(faces) > 8 else "")
    why = ("faces marked flat carry normals other than their triangles' own: custom normals "
           "on flat faces, as glTF imports leave them, or flat quads that are not planar")
    if vertex_normals_shaded:
        why += ("; or, flat and smooth faces mixed, Cycles on this Blender line shades the "
                "smooth ones with vertex normals that average the flat faces in")
    return (f"{len(faces)} face(s) of {what} (faces {shown}): the tangent-space map is "
            f"encoded on Blender's corner normals there, but Cycles' Normal Map node decodes on "
            f"other normals ({why}), so the map read back through a Normal Map node renders off "
            f"the material there (1 to 2 degrees for 2-degree custom normals, 30 for twisted "
            f"quads). Fix: for custom normals or mixed faces, select all faces and Shade Smooth "
            f"(it keeps custom normals); for flat quads that are not planar, Face > Triangulate "
            f"Faces (the flat look stays)")
