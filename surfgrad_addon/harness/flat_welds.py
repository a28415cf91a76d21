"""Flat triangles whose MikkTSpace welding the reference cannot match on lines without float
corner normals (4.2), and compare's warning or refusal for them.

MikkTSpace welds two triangles across an edge where both ends' position, normal and UV are
bitwise equal. Cycles hands it each flat triangle's own float32 normal
(mesh_data.cycles_triangle_normals); on 4.2 the reference's temporary mesh can only carry
Blender's face normal (another formula). Where two flat triangles share an edge with the same
UVs and their normals are bitwise equal in one form but not the other, the reference welds
the edge differently from the bake, and the tangents there can differ by ~30 degrees
(red team 48c: a correct SG Normal Map p99 26.8-37.9 deg). Their texels are left out (counted
as outside), named in a warning; where that would leave out most of the object, compare
refuses instead.
"""

import numpy as np

from .no_area import faces_text

# compare refuses rather than leaving out more than this fraction of the covered texels.
MOST_LEFT_OUT = 0.75


def unsure_welds(triangles, uv, flat, blender_normals, cycles_normals, positions=None):
    """(T,) True on the flat triangles (`flat` (T,)) of a pair sharing an edge with the same
    UV bits at both ends (`uv` (T, 3, 2)) whose normals are bitwise equal under one form
    ((T, 3) float32: Blender's face normals, Cycles') and not under the other. `positions`
    (V, 3): vertices of the same float32 bits are one (MikkTSpace welds by value, not by
    index: the split vertices of a flat-shaded glTF or STL import)."""
    tris = np.asarray(triangles, dtype=np.int64)
    if positions is not None and len(tris):
        bits = np.ascontiguousarray(positions, dtype=np.float32).view(np.uint32)
        _, same = np.unique(bits.reshape(len(bits), -1), axis=0, return_inverse=True)
        tris = np.asarray(same, dtype=np.int64).reshape(-1)[tris]
    t = len(tris)
    out = np.zeros(t, dtype=bool)
    if flat is None or not np.any(flat):
        return out
    corner = np.array([[0, 1], [1, 2], [2, 0]])
    owner = np.repeat(np.arange(t), 3)
    ends = tris[:, corner].reshape(-1, 2)
    uv_bits = np.ascontiguousarray(uv, dtype=np.float32).view(np.uint32).reshape(t, 3, 2)
    end_uv = uv_bits[:, corner].reshape(-1, 2, 2)
    swap = ends[:, 0] > ends[:, 1]                      # each edge as (lower, higher) vertex
    ends = np.where(swap[:, None], ends[:, ::-1], ends)
    end_uv = np.where(swap[:, None, None], end_uv[:, ::-1], end_uv)
    order = np.lexsort((ends[:, 1], ends[:, 0]))
    a, b = order[:-1], order[1:]                        # neighbours in edge order
    pair = (np.all(ends[a] == ends[b], axis=1) & np.all(end_uv[a] == end_uv[b], axis=(1, 2))
            & flat[owner[a]] & flat[owner[b]] & (owner[a] != owner[b]))
    ta, tb = owner[a][pair], owner[b][pair]

    def equal(normals):
        bits = np.ascontiguousarray(normals, dtype=np.float32).view(np.uint32)
        return np.all(bits[ta] == bits[tb], axis=1)

    differ = equal(blender_normals) != equal(cycles_normals)
    out[ta[differ]] = True
    out[tb[differ]] = True
    # MikkTSpace sums a corner's tangent over the triangles welded around its vertex, so an
    # edge welded otherwise changes the tangents at both its ends, not on its two triangles
    # alone: every flat triangle there is left out (red team 53b: a subdivided flat quad on
    # 4.2, its other triangles compared a correct SG Normal Map 3.8 to 10.3 degrees off; only
    # the triangles welded to the two under either form were not enough, 3.8 degrees).
    ends_differ = np.unique(ends[a][pair][differ])
    out |= flat & np.isin(tris, ends_differ).any(axis=1)
    return out


def unsure_problem(obj_name, uv_map, texels, kept, line):
    """compare's refusal where the texels left out (`texels`, beside `kept` still compared)
    would be most of the object's, or None."""
    covered = texels + kept
    if texels <= MOST_LEFT_OUT * covered:
        return None
    return (f"{obj_name!r}: {texels} of its {covered} texels (UV map {uv_map!r}) lie on flat "
            f"faces whose MikkTSpace tangents the reference cannot reproduce on Blender "
            f"{line} (no float corner normals: Cycles welds their triangles by its own "
            f"triangle normals, the reference can only give Blender's face normals, and the "
            f"two disagree in the last bit), too many to leave out; nothing was compared. "
            f"Compare on Blender 4.5 or later")


def unsure_warning(mesh, unsure, texels, line):
    """A warning naming the flat faces whose texels were left out for their welds, or None."""
    if not texels:
        return None
    return (f"{mesh.name!r}: {texels} texels of {int(unsure.sum())} flat triangles (faces "
            f"{faces_text(mesh, np.flatnonzero(unsure))}) are not compared (counted as "
            f"outside): on Blender {line} the reference cannot weld their MikkTSpace tangents "
            f"as Cycles does (Cycles' own triangle normals and Blender's face normals differ "
            f"in the last bit there, and no float corner normal carries Cycles' bits). Compare "
            f"on Blender 4.5 or later to check them.")
