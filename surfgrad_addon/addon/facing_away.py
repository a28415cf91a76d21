"""Faces whose shading normal at a corner faces away from the face (flipped or wrong custom
normals, a bad import). Cycles shades the back side where the interpolated normal does, so a
tangent-space normal map baked there does not render back as baked (red team 45b: the
lizardman of castle-engine/demo-models, frozen, one texel 178.8 degrees off). compare leaves
such texels out (harness/facing_exclusions.py); a bake warns (bake_request.mesh_problems, which
Freeze's checks share). No bpy: the numbers come from bake_uvs.baked_mesh."""

import numpy as np


def facing_away_triangles(positions, triangles, corner_normals):
    """(T,) bool: the triangles (vertex indices (T, 3) into positions) with a corner normal
    (T, 3, 3) on the back side of the triangle's plane; non-finite normals are counted
    elsewhere."""
    p = positions[triangles]
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    dots = np.einsum("tj,tcj->tc", face, corner_normals)
    with np.errstate(invalid="ignore"):
        return (dots < 0.0).any(axis=1)


def facing_away_warning(what, faces):
    """A warning naming `faces` (the mesh faces with such a corner) of `what`, or None."""
    faces = np.unique(np.asarray(faces, dtype=np.int64))
    if not len(faces):
        return None
    shown = ", ".join(map(str, faces[:8].tolist())) + (f" and {len(faces) - 8} more"
                                                       if len(faces) > 8 else "")
    return (f"{len(faces)} face(s) of {what} (faces {shown}) have a shading normal facing "
            f"away from the face at a corner (normals flipped), where Cycles shades the back "
            f"side: the baked map does not render back as baked there. If that is not meant, "
            f"recalculate the normals (Mesh > Normals > Recalculate Outside) or fix the "
            f"custom normals")
