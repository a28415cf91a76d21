"""Whether input data can be baked at all: finite numbers, faces with area (no bpy).

One place for the checks `compare` and the bake request both make, so a NaN pixel or a
collapsed mesh is refused with the same words on either path.
"""

import numbers

import numpy as np

# A triangle whose area is below this share of its own longest edge squared is taken as zero
# area: collapsed to a line or a point (as a share of its own size, so a mesh's far-flung or
# small parts do not change it).
RELATIVE_AREA_EPS = 1e-12
_CHUNK = 1 << 24            # values per slice when counting non-finite ones (bounded memory)
# A pixel value beyond this is refused as NaN and Inf are: a shader's float32 length of a
# colour read as a vector (2 v - 1, squared and summed) overflows to Inf from ~5e18, and Cycles
# then gives its fallback normal (flat; a zero vector from 4.2's Normal Map node) while the
# float64 reference tilts the normal as the value points (red team 41: 55 deg apart).
OVERFLOWING = 1e18


def plain_number(value):
    """A numpy integer or float (a script's array arithmetic: np.int64(2048), np.float32(2))
    as the int or float it is, which the requests' checks (and JSON) take; any other value as
    given, for the checks to judge."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return value


def all_finite(values):
    """True when every value is finite. A float64 sum is NaN/Inf if any value is, and needs
    no temporary array; only a sum that overflows (finite values near 1e308) looks closer."""
    a = np.asarray(values)
    if a.size == 0 or not np.issubdtype(a.dtype, np.floating):
        return True
    if np.isfinite(np.add.reduce(a.ravel(), dtype=np.float64)):
        return True
    return nonfinite_count(a) == 0


def nonfinite_count(values):
    """How many values are NaN or +-Inf (counted slice by slice)."""
    flat = np.asarray(values).ravel()
    return int(sum(int(np.count_nonzero(~np.isfinite(flat[i:i + _CHUNK])))
                   for i in range(0, flat.size, _CHUNK)))


def finite_problem(label, values, fix="fix the mesh data before baking"):
    """None when `values` are all finite, else a message naming them and the fix."""
    if all_finite(values):
        return None
    return f"{label} contain non-finite values (NaN or Inf); {fix}"


def pixels_problem(label, pixels):
    """None when an image's pixels are all finite and within OVERFLOWING, else what is wrong
    and the fix."""
    if not all_finite(pixels):
        return nonfinite_pixels_problem(label, nonfinite_count(pixels))
    return nonfinite_pixels_problem(label, 0, *overflowing(pixels))


def overflowing(values):
    """(how many finite values lie beyond +-OVERFLOWING, the largest magnitude of those or 0),
    counted slice by slice."""
    flat = np.asarray(values).ravel()
    count, largest = 0, 0.0
    for i in range(0, flat.size, _CHUNK):
        part = flat[i:i + _CHUNK]
        if part.size and max(float(part.max()), -float(part.min())) > OVERFLOWING:
            big = np.abs(part[np.abs(part) > OVERFLOWING])
            count += big.size
            largest = max(largest, float(big.max()))
    return count, largest


def nonfinite_pixels_problem(label, n, beyond=0, largest=0.0):
    """The refusal of an image with `n` non-finite pixel values, or else `beyond` values past
    +-OVERFLOWING (the largest magnitude `largest`), or None where both are 0."""
    fix = "fix or clamp them before using it (e.g. re-save it from an image editor, or a Math "\
          "node clamp)"
    if n:
        return f"{label} has non-finite pixels (NaN or Inf, {n} value(s)); {fix}"
    if beyond:
        return (f"{label} has {beyond} pixel value(s) beyond +-{OVERFLOWING:.0e} (up to "
                f"{largest:.3g}), which overflow a shader's float32 arithmetic to Inf (Cycles "
                f"shades its fallbacks there, not what the image holds); {fix}")
    return None


def triangle_areas(positions, triangles):
    """(T,) areas of the triangles (vertex indices (T, 3)) of the positions (V, 3)."""
    p = np.asarray(positions, dtype=np.float64)[np.asarray(triangles)]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=-1)


def zero_area_mask(positions, triangles):
    """(T,) True where a triangle has no area (collapsed to a line or a point), measured
    against its own size (its longest edge). Against the extent of the mesh, a separate face
    or a loose vertex far out (a bad import, a stray part) made small faces elsewhere "no
    area": a 2 m grid beside a 1 m face 1000 km out was refused by the bake and compare as
    collapsed everywhere, and beside a face 100 km out its texels were left out of compare.
    Rounding is float32_slivers' test (harness/no_area.py)."""
    p = np.asarray(positions, dtype=np.float64)
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(p) == 0 or len(tris) == 0:
        return np.ones(len(tris), bool)
    return _collapsed(p[tris])


def uv_zero_area_mask(uv_triangles):
    """(T,) True where a UV triangle (T, 3, 2) has no area in UV space, by zero_area_mask's
    rule."""
    uv = np.asarray(uv_triangles, dtype=np.float64).reshape(-1, 3, 2)
    return _collapsed(np.concatenate([uv, np.zeros(uv.shape[:2] + (1,))], axis=-1))


def _collapsed(corners):
    """(T,) True where triangles of corners (T, 3, 3) have no area against their longest
    edge squared."""
    edges = corners[:, [1, 2, 0]] - corners
    longest = np.max(np.einsum("tij,tij->ti", edges, edges), axis=1)
    area = 0.5 * np.linalg.norm(np.cross(edges[:, 0], -edges[:, 2]), axis=-1)
    return area <= RELATIVE_AREA_EPS * longest


def collapsed_mesh_problem(what, world_positions, triangles):
    """None unless every face of the mesh (`what`, e.g. "mesh 'M' of object 'O'") has zero
    area in world space; then the message and the fix (the bake request and compare)."""
    if not zero_area_mask(world_positions, triangles).all():
        return None
    return (f"every face of {what} has zero area (collapsed to a point or a line, or scaled "
            f"to 0), so there is no surface to bake: fix the mesh or the object's scale")


def collapsed_uv_problem(uv_map, obj_name, uv_triangles):
    """None unless no triangle of UV map `uv_map` of object `obj_name` has area in UV
    space; then the message and the fix (the bake request and compare)."""
    if (uv_triangle_areas(uv_triangles) > 0).any():
        return None
    return (f"UV map {uv_map!r} of object {obj_name!r} has no area (every face collapsed to a "
            f"point or a line in UV space), so the bake would cover no texel: unwrap it (UV > "
            f"Unwrap)")


def collapsed_uv_faces_warning(uv_map, obj_name, uv_triangles, positions, triangles, faces):
    """None unless some faces (`faces`: each triangle's face) have area on the mesh but none
    in UV map `uv_map` (a face's UVs merged to a point or a line): the bake writes no texel
    for them, a hole in the map; then the warning naming them. A face with UV area in some
    of its triangles is no hole: a bent n-gon's triangle across a straight UV border (three
    corners on one line in UV, not on the mesh) covers no texel, its other triangles do."""
    faces = np.asarray(faces, dtype=np.int64)
    flat = uv_zero_area_mask(uv_triangles)
    hole = flat & ~zero_area_mask(positions, triangles)
    if not hole.any():
        return None
    with_uv_area = np.zeros(int(faces.max()) + 1, dtype=bool)
    with_uv_area[faces[~flat]] = True
    hole &= ~with_uv_area[faces]
    if not hole.any():
        return None
    named = np.unique(faces[hole])
    return (f"UV map {uv_map!r} of object {obj_name!r}: {len(named)} face(s) with area on the "
            f"mesh have none in UV space (their UVs collapsed to a point or a line: faces "
            f"{faces_text(named)}), so the bake writes no texel for them; unwrap them "
            f"(UV > Unwrap)")


def faces_text(faces, shown=8):
    """Face indices as a message names them: "9, 10, 30", or the first `shown` and how many
    more."""
    more = f" and {len(faces) - shown} more" if len(faces) > shown else ""
    return ", ".join(str(int(f)) for f in faces[:shown]) + more


def uv_triangle_areas(uv_triangles):
    """(T,) areas in UV space of UV triangles (T, 3, 2)."""
    uv = np.asarray(uv_triangles, dtype=np.float64).reshape(-1, 3, 2)
    a, b, c = uv[:, 0], uv[:, 1], uv[:, 2]
    return 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) -
                        (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
