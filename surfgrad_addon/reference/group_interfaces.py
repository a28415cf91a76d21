"""Every node group's interface as data (no bpy): its description and its sockets, outputs then
inputs, each a SocketSpec (reference/socket_specs.py). The builders in addon/groups create the
interface from these (GroupBuilder.declare) and only look sockets up; `expected_signatures`
writes what Blender must report for them, the content of tests/interfaces.json
(tools/write_interfaces.py). The one documented difference between lines: an enumeration is a
Menu socket where the line has them, its integer (SocketSpec.as_int) on 4.2 and 4.5
(`for_line`, `expected_signatures(menu_sockets=False)`).

A description may hold {fields}: the groups built per image or per UV map fill them; the
golden file uses `fields`' defaults (the group built without an image or UV map).
"""

from dataclasses import dataclass, field

from . import socket_specs as S
from .socket_specs import (BOOLEAN, CLOSURE, COLOR, FLOAT, GEOMETRY, INT, MENU, SOCKET_TYPES,
                           VECTOR, SocketSpec)

FLT_MAX = 3.4028234663852886e+38
REST_ATTRIBUTE = "sg_rest_position"      # SG Displace writes the rest position there
# What Blender reports for a setting a spec leaves unset (None), per socket type; a key that is
# absent is a setting that type does not have.
BLENDER_UNSET = {
    VECTOR: {"subtype": "NONE", "default": [0.0, 0.0, 0.0], "min": -FLT_MAX, "max": FLT_MAX},
    FLOAT: {"subtype": "NONE", "default": 0.0, "min": -FLT_MAX, "max": FLT_MAX},
    INT: {"subtype": "NONE", "default": 0, "min": -2 ** 31, "max": 2 ** 31 - 1},
    COLOR: {"default": [0.0, 0.0, 0.0, 1.0]},
    BOOLEAN: {"default": False},
    GEOMETRY: {}, CLOSURE: {},
    MENU: {"default": ""},
}


@dataclass(frozen=True)
class GroupInterface:
    description: str
    outputs: tuple
    inputs: tuple = ()
    fields: dict = field(default_factory=dict)      # {field: default} of the description

    def describe(self, **values):
        return self.description.format(**{**self.fields, **values})

    def for_line(self, menu_sockets):
        """This interface as a line builds it: without Menu sockets, each enumeration is its
        integer (same order)."""
        if menu_sockets:
            return self
        def plain(specs):
            return tuple(s.as_int() if s.type == MENU else s for s in specs)
        return GroupInterface(self.description, plain(self.outputs), plain(self.inputs),
                              self.fields)


def _g(description, outputs, inputs=(), **fields):
    return GroupInterface(description, tuple(outputs), tuple(inputs), fields)


def _unlinked_uv(tooltip):
    return S.UV.but(tooltip=tooltip + S.UNLINKED_UV)


HEIGHT_UV = _unlinked_uv("Texture coordinate of the height image (link a UV Map node for "
                         "another map)")
SAMPLED_SIZE = (S.SAMPLER, S.IMAGE_WIDTH, S.IMAGE_HEIGHT)
COLOR_ON_PLANES = tuple(S.NORMAL_COLOR.but(name=f"Color {a}", tooltip="Tangent-space normal map "
                                           f"sampled at UV {a}") for a in "XYZ")
GRADIENT_NOISE = _g("One octave of gradient noise with its analytic gradient",
                    (S.VALUE_OUT, S.GRADIENT_OUT), (S.NOISE_VECTOR,))
HEIGHT_MAP = "Scale-dependent bump from a height image ({label}, Listing 16 and Listing 6)"
HEIGHT_IMAGE = HEIGHT_MAP + "; image {image}"
HEIGHT_SAMPLER = HEIGHT_MAP + ", the image given as a Sampler closure"
NO_IMAGE = "(none: use Add Height Map)"
TRIPLANAR = "Listings 13 and 14: triplanar normal mapping as a volume bump map"
TRIPLANAR_HEIGHT = "Listings 13 and 14 from a height image on all three planes"
PARALLAX = "Listings 11 and 12: parallax mapping with offset limiting and parallax occlusion"
PARALLAX_OUTPUTS = (
    SocketSpec("UV", VECTOR, "Parallax-occlusion corrected texture coordinate: sample the "
               "material's other maps here"),
    SocketSpec("UV Limited", VECTOR, "Parallax with offset limiting (cheaper, one height "
               "sample)"),
    SocketSpec("Surface Offset", VECTOR, "World offset of the corrected point along the surface "
               "(Listing 12)"),
    SocketSpec("Height", FLOAT, "Height where the view ray meets the height field"))
PARALLAX_INPUTS = (
    S.NORMAL, HEIGHT_UV,
    S.UV.but(name="View", tooltip="Unit direction toward the viewer, world space (unlinked: the "
             "Geometry node's Incoming)"),
    SocketSpec("Depth", FLOAT, "World distance of height 1 above the surface (how deep the "
               "parallax reaches; not a bump scale)", default=S.BUMP_SCALE.default, min=0.0,
               max=100.0, renamed_from=("Bump Scale",)))
TRIPLANAR_HEIGHT_INPUTS = (S.NORMAL, S.POSITION, S.TEXTURE_SCALE, S.SHARPNESS, S.BUMP_SCALE)
MIKKTSPACE_FRAME = _g("Listing 9's MikkTSpace frame", (
    S.TANGENT_OUT.but(tooltip="MikkTSpace tangent / |n| (world)"),
    S.BITANGENT_OUT.but(tooltip="MikkTSpace bitangent / |n| (world)"),
    S.NORMAL_OUT.but(tooltip="Unit interpolated vertex normal (world)")))

INTERFACES = {
    # -- hidden helpers -----------------------------------------------------------------------
    ".SG Bump Strength": _g(
        "The Bump node's Strength (a blend of normals) on a surface gradient",
        (S.SURFACE_GRADIENT_OUT.but(tooltip="Surface gradient with the Bump node's Strength "
                                    "applied"),),
        (S.NORMAL.but(tooltip="Base normal, as the converted Bump node's Normal (leave "
                      "unlinked: the shading normal)"),
         S.SURFACE_GRADIENT.but(tooltip="Surface gradient at Strength 1 (SG Height Map "
                                "Forward)"),
         S.NODE_STRENGTH.but(tooltip="As the Bump node's Strength: 1 keeps the gradient, 0 is "
                             "flat, between them the bumped normal is blended toward the "
                             "base"))),
    ".SG Gradient Noise": GRADIENT_NOISE,
    ".SG Gradient Noise (Geometry)": GRADIENT_NOISE,
    ".SG MikkTSpace Frame": MIKKTSPACE_FRAME,
    ".SG Safe Normal": _g(
        "normalize(v) with the shading normal as fallback",
        (S.NORMAL_OUT.but(tooltip="Unit normal, always finite"),),
        (S.NOISE_VECTOR.but(tooltip="A direction of any length, or nothing"),)),
    ".SG Surface Gradient": _g(
        "Surface gradient of a scalar through the Bump node",
        (S.GRADIENT_OUT.but(tooltip="Surface gradient of Value"),),
        (SocketSpec("Value", FLOAT, "Scalar whose surface gradient is wanted (linear on each "
                    "triangle for an exact result, e.g. a UV coordinate)"), S.UNIT_NORMAL)),
    ".SG UV Gradients": _g(
        "Surface gradients of a UV map",
        (S.GRADIENT_OUT.but(name="Gradient S", tooltip="Surface gradient of s"),
         S.GRADIENT_OUT.but(name="Gradient T", tooltip="Surface gradient of t")),
        (S.UV, S.UNIT_NORMAL)),
    # -- the menu's groups --------------------------------------------------------------------
    "SG Blend Normals": _g(
        "Classic blends of two tangent-space normals on one UV map (Table 1, Eq. 18); through "
        "SG Normal Map each equals its surface-gradient form",
        (SocketSpec("Color", COLOR, "Blended tangent-space normal colour: feed it to SG Normal "
                    "Map"),),
        (S.NORMAL_COLOR.but(name="Color A", tooltip="First (base) tangent-space normal colour, "
                            "OpenGL or DirectX like Color B (the result keeps the convention)"),
         S.NORMAL_COLOR.but(name="Color B", tooltip="Second (detail) tangent-space normal "
                            "colour"),
         S.enumeration("Method", "How the two normals combine", (
             ("Partial Derivative", "Add the slopes (PD): the surface-gradient sum"),
             ("Whiteout", "Add x and y, multiply z"),
             ("UDN", "Add x and y, keep A's z (cheapest, flattens)"),
             ("RNM", "Reoriented normal mapping: B rotated onto A (Eq. 18)"))))),
    "SG Combine": _g(
        "Layering (Eq. 13-14): add, scale, mask or invert surface gradients",
        (S.SURFACE_GRADIENT_OUT.but(tooltip="Scale A x A + Scale B x Mask B x B"),),
        (S.SURFACE_GRADIENT.but(name="A", tooltip="First surface gradient"),
         S.SURFACE_GRADIENT.but(name="B", tooltip="Second surface gradient"),
         S.STRENGTH.but(name="Scale A", tooltip="Weight of A (negative inverts that bump)",
                        keyword=None),
         S.STRENGTH.but(name="Scale B", tooltip="Weight of B (negative inverts that bump)",
                        keyword=None),
         SocketSpec("Mask B", FLOAT, "Mask for B (0 hides it, 1 keeps it)", default=1.0,
                    min=0.0, max=1.0, subtype="FACTOR"))),
    "SG Decal": _g(
        "Listing 15: a decal projector (box, sphere, cylinder, cone, wedge or capsule) as a "
        "volume bump map, faded by its falloff, added to or overwriting the surface gradient "
        "underneath",
        (S.SURFACE_GRADIENT_OUT.but(tooltip="Surface gradient (with the Base Gradient, added or "
                                    "overwritten)"),),
        (S.NORMAL,
         S.DECAL_COORDINATES.but(tooltip="Position in the projector's space: a Texture "
                                 "Coordinate node's Object output with the projector (an empty) "
                                 "as its object; the decal covers [-1, 1] in x and y"),
         S.NORMAL_COLOR.but(tooltip="Tangent-space normal map sampled at the Decal UV of SG "
                            "Decal Coordinates"),
         S.DIRECTX,
         SocketSpec("Axis X", VECTOR, "The projector's X axis in world space (unit length; the "
                    "Add Decal Projector operator drives it)", default=(1.0, 0.0, 0.0),
                    subtype="DIRECTION"),
         SocketSpec("Axis Y", VECTOR, "The projector's Y axis in world space (unit length)",
                    default=(0.0, 1.0, 0.0), subtype="DIRECTION"),
         S.STRENGTH,
         SocketSpec("Falloff", FLOAT, "Distance over which the decal fades out toward its "
                    "shape's boundary (fraction of the projector's half-size)", default=0.2,
                    min=0.0, max=1.0, keyword="falloff"),
         S.enumeration("Shape", "Projector volume, in the projector's [-1, 1] cube", (
             ("Box", "The projector's cube, faded toward its near and far faces"),
             ("Sphere", "The unit ball, faded toward its surface"),
             ("Cylinder", "Along the projection axis, faded toward its side and ends"),
             ("Cone", "Apex at the projector (+z), radius 1 at the far end, faded toward its "
              "side and ends"),
             ("Wedge", "A prism along the projection axis whose footprint is a triangle, apex "
              "at +y, base at y = -1, faded toward its sloped faces and ends"),
             ("Capsule", "Within 1 of the axis from z = -0.5 to 0.5, faded toward its "
              "surface")), keyword="shape"),
         S.SURFACE_GRADIENT.but(name="Base Gradient", tooltip="The surface gradient underneath "
                                "(the sum of the layers below). Add mode adds the decal to it; "
                                "Overwrite replaces it where the decal is, faded by Opacity and "
                                "the falloff"),
         SocketSpec("Overwrite", BOOLEAN, "Off: add (the surface gradients sum). On: the decal's "
                    "gradient replaces the Base Gradient", default=False, keyword="overwrite"),
         SocketSpec("Opacity", FLOAT, "How much of the decal: scales it in Add mode, blends "
                    "from the Base Gradient to it in Overwrite mode", default=1.0, min=0.0,
                    max=1.0, keyword="opacity"))),
    "SG Decal Coordinates": _g(
        "Image coordinates of a decal projector: feed the decal's Image Texture, then SG Decal",
        (SocketSpec("Decal UV", VECTOR, "Where to sample the decal image (its Image Texture's "
                    "Vector)"),),
        (S.DECAL_COORDINATES,)),
    "SG Displace": _g(
        "Gustavson's procedural displacement: noise along the normal, normals recomputed "
        "analytically (Eq. 3-8)",
        (SocketSpec("Geometry", GEOMETRY, "Displaced mesh with analytic normals and its rest "
                    "position in the '" + REST_ATTRIBUTE + "' attribute"),),
        (SocketSpec("Geometry", GEOMETRY, "Mesh to displace"),
         SocketSpec("Amount", FLOAT, "Displacement along the normal per unit of noise (object "
                    "units)", default=0.1, min=-100.0, max=100.0, keyword="amount"),
         S.NOISE_SCALE.but(default=2.0), S.OCTAVES.but(default=1), S.GAIN,
         SocketSpec("Analytic Normals", BOOLEAN, "Set the normals from the noise's gradient "
                    "(Eq. 4-8); off: Blender recomputes them from the displaced geometry, which "
                    "needs a dense mesh", default=True))),
    "SG Height Blend": _g(
        "Height-blended layers: the higher layer shows through, the lower settles into the "
        "hollows (w_i = max(h_i + o_i - max_j(h_j + o_j) + c, 0), normalised)",
        (S.SUMMABLE_GRADIENT_OUT.but(tooltip="A and B weighted by their heights: add to "
                                     "others, then SG Resolve"),
         SocketSpec("Height", FLOAT, "Blended height: link it to the next SG Height Blend's "
                    "Height A to stack another layer"),
         SocketSpec("Weight B", FLOAT, "How much of B shows (0 to 1): mix the layers' colours "
                    "and roughness by it")),
        (S.SURFACE_GRADIENT.but(name="A", tooltip="Surface gradient of layer A (e.g. the "
                                "rock)"),
         S.LAYER_HEIGHT.but(name="Height A"),
         S.SURFACE_GRADIENT.but(name="B", tooltip="Surface gradient of layer B (e.g. sand or "
                                "moss)"),
         S.LAYER_HEIGHT.but(name="Height B"),
         SocketSpec("Offset B", FLOAT, "Added to B's height before the blend: raise it to fill "
                    "more of A's hollows, or link a painted mask", default=0.0, min=-10.0,
                    max=10.0),
         S.CONTRAST)),
    "SG Height Map Forward": _g(
        "Scale-dependent bump from any height by forward differences (Listing 7, Listing 6)",
        (S.SURFACE_GRADIENT_OUT,),
        (S.NORMAL,
         SocketSpec("Height", FLOAT, "Height (link an Image Texture or any scalar graph)",
                    default=0.0, hide_value=True),
         S.BUMP_SCALE)),
    "SG Height Map HQ": _g(HEIGHT_IMAGE, (S.SURFACE_GRADIENT_OUT,),
                           (S.NORMAL, HEIGHT_UV, S.BUMP_SCALE), label="HQ", image=NO_IMAGE),
    "SG Height Map One-Texel": _g(HEIGHT_IMAGE, (S.SURFACE_GRADIENT_OUT,),
                                  (S.NORMAL, HEIGHT_UV, S.BUMP_SCALE), label="One-Texel",
                                  image=NO_IMAGE),
    "SG Height Map HQ (Sampler)": _g(HEIGHT_SAMPLER, (S.SURFACE_GRADIENT_OUT,),
                                     (S.NORMAL, HEIGHT_UV, S.BUMP_SCALE, *SAMPLED_SIZE),
                                     label="HQ"),
    "SG Height Map One-Texel (Sampler)": _g(HEIGHT_SAMPLER, (S.SURFACE_GRADIENT_OUT,),
                                            (S.NORMAL, HEIGHT_UV, S.BUMP_SCALE, *SAMPLED_SIZE),
                                            label="One-Texel"),
    "SG Noise": _g(
        "The reference's 3-D gradient noise (fractal sum or turbulence) with its exact "
        "gradient, bit-compatible lattice (White Noise hash)",
        (S.VALUE_OUT.but(tooltip="Noise value (for displacement or masks)"),
         S.GRADIENT_OUT.but(tooltip="Exact gradient of Value (world space when Object Space is "
                            "on): feed SG Volume Gradient")),
        (S.NOISE_VECTOR.but(tooltip="Where to evaluate (unlinked: object coordinates)"),
         S.NOISE_SCALE, S.OCTAVES, S.GAIN,
         SocketSpec("Turbulence", BOOLEAN, "Sum |noise| (Perlin's turbulence) instead of noise "
                    "(fractal sum)", default=False),
         SocketSpec("Object Space", BOOLEAN, "Vector is in object space: return the gradient "
                    "in world space (for SG Volume Gradient)", default=True), S.PRECISE_FAR,
         SocketSpec("Filter Footprint", BOOLEAN, "Fade out the octaves finer than the pixel "
                    "(or baked texel) footprint, so distant bump does not sparkle",
                    default=False))),
    "SG Normal Map": _g(
        "Tangent-space normal map to surface gradient, MikkTSpace compliant (Listings 2, 3, 9 "
        "through the Normal Map node, then 5) on UV map {uv_map}",
        (S.SUMMABLE_GRADIENT_OUT,),
        (S.NORMAL_COLOR.but(tooltip="Tangent-space normal map colour (Non-Color image, sampled "
                            "on the same UV map)"),
         S.DIRECTX, S.NODE_STRENGTH,
         S.NORMAL.but(tooltip="Base normal the result is resolved against (leave unlinked: the "
                      "shading normal)")),
        uv_map="(active render map)"),
    "SG Object Normal": _g(
        "Listing 5: surface gradient from an object- or world-space normal",
        (S.SURFACE_GRADIENT_OUT,),
        (S.NORMAL,
         S.UV.but(name="Perturbed Normal", tooltip="The normal to reach, world space, any "
                  "positive length (for an object-space map, convert it with a Vector Transform "
                  "node, type Normal)"),
         S.STRENGTH)),
    "SG Parallax": _g(PARALLAX, PARALLAX_OUTPUTS, PARALLAX_INPUTS),
    "SG Parallax (Sampler)": _g(PARALLAX + ", the height image given as a Sampler closure",
                                PARALLAX_OUTPUTS, (*PARALLAX_INPUTS, S.SAMPLER)),
    "SG Procedural Basis": _g(
        "Listing 4: a tangent frame for any UV map, generated per pixel; with UV unlinked, "
        "on UV map {uv_map}",
        (S.TANGENT_OUT, S.BITANGENT_OUT),
        (S.NORMAL, S.UV.but(tooltip="Texture coordinate of a UV map without stored tangents "
                            "(unlinked: the UV map in the description, the active render one "
                            "unless the group is SG Procedural Basis [<map>]; for another UV map "
                            "that group is cheaper than linking a UV Map node)")),
        uv_map="(active render map)"),
    "SG Projector Coordinates": _g(
        "A decal projector's coordinates, precise kilometres from the origin (a Texture "
        "Coordinate node's Object output alone is not): feed SG Decal Coordinates and SG Decal",
        (S.DECAL_COORDINATES.but(tooltip="Position in the projector's space, for SG Decal "
                                 "Coordinates and SG Decal", hide_value=False),),
        (S.DECAL_COORDINATES.but(tooltip="A Texture Coordinate node's Object output with the "
                                 "projector as its object, used as given; with Precise Far From "
                                 "Origin on, near the origin only (far out or unlinked: the "
                                 "precise route)"),
         SocketSpec("Projector Location", VECTOR, "The projector's world location (the Add "
                    "Decal Projector operator drives it)", default=(0.0, 0.0, 0.0)),
         *(SocketSpec(f"To Projector {a}", VECTOR, f"Row {a} of the projector's world-to-local "
                      "3 x 3 matrix, the inverse of its rotation and scale (driven by the "
                      "operator)", default=e)
           for a, e in zip("XYZ", ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))),
         S.PRECISE_FAR)),
    "SG Resolve": _g(
        "Listing 1: the perturbed normal from the base normal and the summed surface gradient",
        (S.NORMAL_OUT,), (S.NORMAL, S.SURFACE_GRADIENT)),
    "SG Rest Position": _g(
        "The undisplaced object coordinates stored by SG Displace",
        (SocketSpec("Rest Position", VECTOR, "Object-space position before SG Displace moved "
                    "it: feed SG Noise's Vector for bump on top"),)),
    "SG Tangent Normal": _g(
        "Listings 2 and 3: tangent-space normal to surface gradient on a given tangent frame",
        (S.SURFACE_GRADIENT_OUT,),
        (S.NORMAL_COLOR, S.DIRECTX, S.STRENGTH,
         S.UV.but(name="Tangent", tooltip="Tangent (e.g. from SG Procedural Basis)"),
         S.UV.but(name="Bitangent", tooltip="Bitangent (e.g. from SG Procedural Basis)"))),
    "SG Triplanar": _g(
        TRIPLANAR, (S.SURFACE_GRADIENT_OUT, S.WEIGHTS_OUT),
        (S.NORMAL, *COLOR_ON_PLANES, S.DIRECTX, S.SHARPNESS, S.STRENGTH)),
    "SG Triplanar (Sampler)": _g(
        TRIPLANAR + ", the normal map given as a Sampler closure",
        (S.SURFACE_GRADIENT_OUT, S.WEIGHTS_OUT),
        (S.NORMAL, S.POSITION, S.TEXTURE_SCALE, S.SAMPLER, S.DIRECTX, S.SHARPNESS, S.STRENGTH,
         S.PRECISE_FAR)),
    "SG Triplanar Coordinates": _g(
        "The three planar projections of triplanar mapping (Eq. 19): feed three Image Texture "
        "nodes, then SG Triplanar",
        tuple(SocketSpec(f"UV {a}", VECTOR, f"Coordinates for the image projected along {a}")
              for a in "XYZ"),
        (S.POSITION, S.TEXTURE_SCALE, S.PRECISE_FAR)),
    "SG Triplanar Height": _g(TRIPLANAR_HEIGHT, (S.SURFACE_GRADIENT_OUT,),
                              (*TRIPLANAR_HEIGHT_INPUTS, S.PRECISE_FAR)),
    "SG Triplanar Height (Sampler)": _g(
        TRIPLANAR_HEIGHT + ", the image given as a Sampler closure", (S.SURFACE_GRADIENT_OUT,),
        (*TRIPLANAR_HEIGHT_INPUTS, *SAMPLED_SIZE, S.PRECISE_FAR)),
    "SG Volume Gradient": _g(
        "Listing 8: surface gradient of a volume bump map",
        (S.SUMMABLE_GRADIENT_OUT,),
        (S.NORMAL,
         S.SURFACE_GRADIENT.but(name="Gradient", tooltip="Gradient of a volume bump function "
                                "(world space), e.g. SG Noise's Gradient"),
         S.BUMP_SCALE.but(keyword="amount", renamed_from=("Strength",), tooltip="World units "
                          "of displacement per unit of the function, as the height groups' Bump "
                          "Scale (0.05 gives SG Noise's default a moderate relief on a 1 m "
                          "object)"))),
}


def plain_value(value):
    """A setting as plain data that compares equal across Blender lines (floats to 6 places)."""
    if hasattr(value, "__len__") and not isinstance(value, str):      # Blender's arrays too
        return [round(float(x), 6) for x in value]
    if isinstance(value, float):
        return round(value, 6)
    return value


def signature_row(spec, in_out):
    """One socket as node_builder.interface_signature reports it from Blender."""
    unset = BLENDER_UNSET[spec.type]
    row = {"name": spec.name, "in_out": in_out, "type": SOCKET_TYPES[spec.type],
           "description": spec.tooltip, "hide_value": spec.hide_value}
    for key, attr in (("subtype", "subtype"), ("default_value", "default"),
                      ("min_value", "min"), ("max_value", "max")):
        if attr in unset:
            value = getattr(spec, attr)
            row[key] = plain_value(unset[attr] if value is None else value)
    return row


def expected_signature(name, menu_sockets=True, **fields):
    iface = INTERFACES[name].for_line(menu_sockets)
    return {"description": iface.describe(**fields),
            "sockets": [signature_row(s, "OUTPUT") for s in iface.outputs]
            + [signature_row(s, "INPUT") for s in iface.inputs]}


def expected_signatures(menu_sockets=True):
    """{group name: signature} for every group: the content of tests/interfaces.json (a line
    with Menu sockets; menu_sockets=False: what 4.2 and 4.5 must report)."""
    return {name: expected_signature(name, menu_sockets) for name in sorted(INTERFACES)}
