"""What each supported Blender line does that the reference must reproduce (no bpy here).

The reference is compared with one Blender at a time, so it reads that line's facts:
`facts_for(bpy.app.version)` on the Blender side, `MAIN_LINE` when no Blender is involved.
Every fact is pinned by a test that runs on every line (tests/test_blender_facts.py,
tests/test_blender_pins.py, tests/test_line_facts.py); docs/versions.md has the evidence.
"""

from dataclasses import dataclass

import numpy as np

from .vecmath import normalize


@dataclass(frozen=True)
class LineFacts:
    line: str
    # A bake hands Cycles' Bump node dPdx, dPdy = r * make_orthonormals(Ng) with
    # r = bake_differential_scale * (|dP/ds| / W + |dP/dt| / H): Blender's per-texel
    # barycentric differentials averaged to one length. Half-texel differentials up to 5.0
    # (0.25), whole-texel ones in 5.2 (0.5): at the same Filter Width a 5.2 bake steps twice as
    # far. Renders are unchanged (camera differentials).
    bake_differential_scale: float
    # The Bump node has a Filter Width input (4.4 and later); without it the shifted copies step
    # one differential, as if Filter Width were 1.
    bump_filter_width: bool
    # Cycles stores vertex normals octahedral-encoded in 2 x 16 bits (5.1 and later): the
    # shading normal interpolates the decoded normals (up to ~0.005 degrees from float32), and
    # MikkTSpace reads them decoded; up to 5.0 it reads them as Blender gave them.
    packed_normals: bool
    # The Normal Map node (tangent space, smooth) builds its frame on a unit normal: the stored
    # corner normals back in object space, interpolated and normalised (5.2); up to 5.0 on the
    # unnormalised interpolation of the object's corner normals.
    normal_map_unit_normal: bool
    # The Normal Map node replaces a zero OR non-finite result by the shading normal (5.0 and
    # later); 4.2 and 4.5 replace only zero, so NaN and Inf pass through it.
    normal_map_replaces_non_finite: bool
    # The Normal Map node has the `convention` property (OpenGL / DirectX), 5.2 and later.
    normal_map_convention: bool
    # Geometry Nodes modifier inputs live in mod.properties.inputs (5.1 and later) rather than
    # in ID properties.
    modifier_properties: bool
    # A bake into a float image encodes the result into the image's colour space (5.2); up to
    # 5.0 float bakes are written as computed. surfgrad's bakes use Non-Color images.
    bake_applies_target_colorspace: bool
    # EEVEE's render engine id.
    eevee_engine: str
    # Which normals Cycles shades with (measured, tests/test_raster_rules.py). Every line: a
    # flat face shades each of its triangles with the triangle's own geometric normal (not the
    # polygon's, which differs on a non-planar quad), unless Blender's normals are per corner:
    # then 5.2 shades with the corner normals, mixed smooth and flat faces included, while up
    # to 5.0 only sharp edges or custom normals give corner normals (otherwise smooth faces
    # shade with vertex normals and flat faces with their triangle's normal).
    sharp_faces_give_corner_normals: bool = True
    # Which normal MikkTSpace sees on a flat face where Cycles shades with corner normals
    # (custom normals, sharp edges; on 5.2 also flat and smooth faces mixed): 5.2 keeps the
    # face flat, so its triangles give their own geometric normal; up to 5.0 Cycles takes
    # every triangle as smooth there, and MikkTSpace gets the corner normals (measured: custom
    # split normals on flat faces, a correct SG Normal Map p99 7.7 / max 17.9 deg before).
    corner_normals_keep_flat_faces: bool = True
    # Custom corner normals that differ at one vertex (free ones, or encoded ones in fans that
    # Blender splits across no sharp edge): 5.2 splits the vertices where they differ; 5.0 to
    # 4.2 only at sharp edges and flat faces, and each vertex then shades with the normal of
    # its corner written last (harness/free_normal_fans.py).
    free_corner_normals_split: bool = True
    # Custom normals can be free floats (a float 'custom_normal' corner attribute, 4.5 and
    # later); 4.2 encodes them in each smooth fan's normal space, so the reference's MikkTSpace
    # input passes through that encoding (harness/mesh_data.triangle_mikktspace).
    free_normals: bool = True
    # An EXR holding two of R, G and B loads into R and G; 4.2 fills B with 0, 4.5 and later
    # leave it uninitialised (other values on each load: tests/test_exr_channels.py). So
    # are R, G and B of an EXR with alpha and no colour (tests/test_faults_images33.py).
    exr_two_colours_fill_zero: bool = False
    # The Alpha modes under which Cycles multiplies an image's colour by its alpha where the
    # image is read in the working colour space (not data, which is never multiplied), for a
    # byte image (PNG, TGA) and a float one (EXR): 5.2 under Straight only; up to 5.0 a byte
    # image under Straight and Premultiplied, a float one never (measured on every line with
    # a Normal Map node: tests/test_faults_pixels59f.py).
    byte_alpha_multiplied: tuple = ("STRAIGHT",)
    float_alpha_multiplied: tuple = ("STRAIGHT",)
    # A shader node group can have Menu sockets and a Menu Switch node (5.0 and later); 4.2 and
    # 4.5 refuse NodeSocketMenu in a shader tree, so an enumeration is an integer there.
    menu_sockets: bool = True
    # Cycles renders through a muted Material Output as through a live one (5.0 and later);
    # 4.2 and 4.5 render nothing through it (no closure: an EMIT bake gives black, a normal
    # bake the flat normal), and take no other output in its place.
    muted_output_renders: bool = True
    # Where a bake shades texel (i, j): ((i + x) / W, (j + y) / H). Same on every line.
    bake_texel_offset: tuple = (0.501, 0.502)
    # MikkTSpace tangents come from Cycles' own triangles (not the quads Blender's
    # calc_tangents sees). Same on every line.
    tangents_on_triangles: bool = True
    # How Cycles scales a flat triangle's normal (its cross product) to unit length for
    # MikkTSpace: 5.2 divides by the length; up to 5.0 it multiplies by the reciprocal, which
    # differs in the last bit on some triangles (MikkTSpace welds only bitwise equal normals).
    triangle_normal_divides: bool = True

    def bump_step_scale(self, filter_width):
        """How many differentials a Bump node with this Filter Width shifts its copies."""
        return float(filter_width) if self.bump_filter_width else 1.0


_UP_TO_5_0 = dict(bake_differential_scale=0.25, bump_filter_width=True, packed_normals=False,
                 normal_map_unit_normal=False, normal_map_replaces_non_finite=True,
                 normal_map_convention=False,
                 modifier_properties=False, bake_applies_target_colorspace=False,
                 sharp_faces_give_corner_normals=False, corner_normals_keep_flat_faces=False,
                 free_corner_normals_split=False,
                 triangle_normal_divides=False,
                 byte_alpha_multiplied=("STRAIGHT", "PREMUL"), float_alpha_multiplied=())
LINES = {
    "4.2": LineFacts(line="4.2", eevee_engine="BLENDER_EEVEE_NEXT",
                     **{**_UP_TO_5_0, "bump_filter_width": False,
                        "normal_map_replaces_non_finite": False, "menu_sockets": False,
                        "free_normals": False, "exr_two_colours_fill_zero": True,
                        "muted_output_renders": False}),
    "4.5": LineFacts(line="4.5", eevee_engine="BLENDER_EEVEE_NEXT",
                     **{**_UP_TO_5_0, "normal_map_replaces_non_finite": False,
                        "menu_sockets": False, "muted_output_renders": False}),
    "5.0": LineFacts(line="5.0", eevee_engine="BLENDER_EEVEE", **_UP_TO_5_0),
    "5.2": LineFacts(line="5.2", eevee_engine="BLENDER_EEVEE", bake_differential_scale=0.5,
                     bump_filter_width=True, packed_normals=True, normal_map_unit_normal=True,
                     normal_map_replaces_non_finite=True, normal_map_convention=True, modifier_properties=True,
                     bake_applies_target_colorspace=True),
}
MAIN_LINE = LINES["5.2"]
OLDEST = (4, 2, 0)


def facts_for(version):
    """The facts of the line a Blender version (a tuple like bpy.app.version) belongs to:
    the newest supported line not newer than it. 5.1 and 4.3/4.4 are not tested: they get the
    facts of the line below, which the tests would show wrong before a release claims them."""
    v = tuple(version)[:3]
    if v < OLDEST:
        raise ValueError(f"Blender {'.'.join(map(str, v))} is older than the oldest supported "
                         f"line, 4.2 LTS")
    best = None
    for key, facts in LINES.items():
        major, minor = (int(x) for x in key.split("."))
        if (major, minor) <= v[:2]:
            best = facts
    return best


def octahedral_unit_vectors(v):
    """Unit vectors (..., 3) after Cycles' 2 x 16-bit octahedral encoding and decoding
    (Cigolle et al., JCGT 2014: project onto the octahedron |x| + |y| + |z| = 1, fold the lower
    half over, quantise each coordinate to 16 bits with rounding, and back)."""
    v = np.asarray(v, dtype=np.float64)
    f32 = np.float32
    mu = 65535
    hmu = f32(mu / 2.0)
    x, y, z = (v[..., k].astype(f32) for k in range(3))
    l1 = f32(1.0) / (np.abs(x) + np.abs(y) + np.abs(z) + f32(1e-6))
    px, py = x * l1, y * l1
    fx = (f32(1.0) - np.abs(py)) * np.copysign(f32(1.0), px)
    fy = (f32(1.0) - np.abs(px)) * np.copysign(f32(1.0), py)
    px, py = np.where(z >= 0, px, fx), np.where(z >= 0, py, fy)
    qx = np.clip(px * hmu + (hmu + f32(0.5)), 0, mu).astype(np.uint32)
    qy = np.clip(py * hmu + (hmu + f32(0.5)), 0, mu).astype(np.uint32)
    inv = f32(2.0 / mu)
    nx = qx.astype(f32) * inv - f32(1.0)
    ny = qy.astype(f32) * inv - f32(1.0)
    nz = f32(1.0) - np.abs(nx) - np.abs(ny)
    t = np.maximum(-nz, f32(0.0))
    nx = nx + np.where(nx > 0, -t, t)
    ny = ny + np.where(ny > 0, -t, t)
    return normalize(np.stack([nx, ny, nz], -1).astype(np.float64))
