"""Every kind of node-group socket, declared once as data (no bpy): its name, type, default,
range, subtype, tooltip, and the keyword of the reference function it maps to.

The node groups (addon/groups) build their interfaces from these specs, tests/interfaces.json
is generated from them (reference/group_interfaces.py), and a method registry can read
`keyword` to drive a group's socket and the reference with one value (Strength -> strength,
Bump Scale -> bump_scale). A group that needs its own tooltip for a kind derives a variant with
`spec.but(tooltip=...)` (dataclasses.replace): the kind itself is declared here only.

type is the interface socket kind: VECTOR, FLOAT, COLOR, BOOLEAN, INT, GEOMETRY, CLOSURE or
MENU (SOCKET_TYPES names its Blender socket type). An enumeration is a MENU spec (`enumeration`):
its items are named; on a line without Menu sockets (4.2, 4.5) it is built as `as_int()`, an
integer 0..N-1 in the same order whose tooltip lists the names. renamed_from: the socket's
earlier names, so a rebuild renames the saved socket in place (links and values kept). None for default, min,
max or subtype leaves Blender's own (the fill-ins are in group_interfaces.BLENDER_UNSET).
"""

from dataclasses import dataclass, replace
from typing import Any, Optional

VECTOR, FLOAT, COLOR, BOOLEAN, INT = "VECTOR", "FLOAT", "COLOR", "BOOLEAN", "INT"
GEOMETRY, CLOSURE = "GEOMETRY", "CLOSURE"     # Closure: Blender 5.0 and later
MENU = "MENU"           # shader groups: Blender 5.0 and later (blender_lines.menu_sockets)
TYPES = (VECTOR, FLOAT, COLOR, BOOLEAN, INT, GEOMETRY, CLOSURE, MENU)
# The Blender interface socket type of each (addon/node_builder creates them).
SOCKET_TYPES = {VECTOR: "NodeSocketVector", FLOAT: "NodeSocketFloat", COLOR: "NodeSocketColor",
                BOOLEAN: "NodeSocketBool", INT: "NodeSocketInt",
                GEOMETRY: "NodeSocketGeometry", CLOSURE: "NodeSocketClosure",
                MENU: "NodeSocketMenu"}


@dataclass(frozen=True)
class SocketSpec:
    name: str
    type: str
    tooltip: str
    default: Any = None
    min: Optional[float] = None
    max: Optional[float] = None
    subtype: Optional[str] = None
    hide_value: bool = False
    keyword: Optional[str] = None      # the reference function's keyword, or None
    items: tuple = ()                  # MENU: ((name, tooltip), ...) in index order
    renamed_from: tuple = ()           # earlier names of this socket, newest first

    def __post_init__(self):
        if self.type not in TYPES:
            raise ValueError(f"socket {self.name!r}: type {self.type!r} is not one of {TYPES}")
        if not self.tooltip:
            raise ValueError(f"socket {self.name!r} has no tooltip")
        if (self.type == MENU) != bool(self.items):
            raise ValueError(f"socket {self.name!r}: items belong to MENU sockets only")

    def item_names(self):
        return tuple(name for name, _ in self.items)

    def as_int(self):
        """The integer an older line builds for this enumeration: 0..N-1 in the items' order,
        the tooltip listing them."""
        names = ", ".join(f"{k} {name}" for k, name in enumerate(self.item_names()))
        return replace(self, type=INT, tooltip=f"{self.tooltip} ({names})", default=0, min=0,
                       max=len(self.items) - 1, items=())

    def but(self, **changes):
        """A variant of this kind (e.g. a group's own tooltip); the kind stays declared once."""
        return replace(self, **changes)


def _vector(name, tooltip, **kw):
    """A vector input that is linked, not typed in (its value hidden)."""
    return SocketSpec(name, VECTOR, tooltip, hide_value=True, **kw)


def enumeration(name, tooltip, items, **kw):
    """A choice among named items ((name, tooltip), ...): a Menu socket, the first item the
    default."""
    return SocketSpec(name, MENU, tooltip, default=items[0][0], items=tuple(items), **kw)


def _out(name, type_, tooltip):
    return SocketSpec(name, type_, tooltip)


FLAT_NORMAL_COLOR = (0.5, 0.5, 1.0, 1.0)     # tangent-space (0, 0, 1): no bump
UNLINKED_UV = " (unlinked: the active render UV map)"

# -- inputs: base normal, coordinates -----------------------------------------------------------
NORMAL = _vector("Normal", "Base normal to perturb (world space). Leave unlinked for the shading "
                 "normal; link a resolved normal for post-resolve bump mapping")
UNIT_NORMAL = NORMAL.but(tooltip="Unit base normal")
UV = _vector("UV", "Texture coordinate (link a UV Map node for any UV map)")
POSITION = _vector("Position", "Where to project from (unlinked: world position)")
SURFACE_GRADIENT = _vector("Surface Gradient", "Sum of the surface gradients to apply")

# -- inputs: scales ------------------------------------------------------------------------------
# "Strength" is a multiplier of the surface gradient everywhere except the groups that convert
# a Blender node (NODE_STRENGTH: that node's meaning and range). World units are "Bump Scale".
STRENGTH = SocketSpec("Strength", FLOAT, "Multiplies the surface gradient (1: as the map is, "
                      "0: flat, negative inverts the bump); unlike the Normal Map node's "
                      "Strength it scales the slope itself", default=1.0, min=-100.0,
                      max=100.0, keyword="strength")
# A Blender node's own Strength (Normal Map, Bump), kept by groups that convert those nodes.
NODE_STRENGTH = SocketSpec("Strength", FLOAT, "As the Normal Map node's Strength: 1 reproduces "
                           "the map, 0 is flat, above 1 steeper (so a converted Normal Map node "
                           "keeps its look)", default=1.0, min=0.0, max=10.0, keyword="strength")
BUMP_SCALE = SocketSpec("Bump Scale", FLOAT, "World units of displacement per unit of height",
                        default=0.05, min=-1000.0, max=1000.0, keyword="bump_scale")
TEXTURE_SCALE = SocketSpec("Scale", FLOAT, "Texture repeats per unit", default=1.0, min=0.0,
                           max=1e4, keyword="scale")
SHARPNESS = SocketSpec("Sharpness", FLOAT, "Blend sharpness k of Listing 14", default=3.0,
                       min=1.0, max=64.0, keyword="k")

# -- inputs: tangent-space normal maps -----------------------------------------------------------
NORMAL_COLOR = SocketSpec("Color", COLOR, "Tangent-space normal map colour (Non-Color image)",
                          default=FLAT_NORMAL_COLOR)
DIRECTX = SocketSpec("DirectX", BOOLEAN, "The map is in DirectX convention (green points down, "
                     "-Y: Unreal, 3ds Max, Substance's DirectX preset): its green channel is "
                     "flipped. Off: OpenGL (+Y), Blender's own. Blender 5.2's Normal Map node "
                     "calls this Convention", default=False, keyword="directx")

# -- inputs: images given as a Sampler closure (Blender 5.0+) ------------------------------------
SAMPLER = SocketSpec("Sampler", CLOSURE, "Your image as a closure: an Image Texture inside a "
                     "Closure Zone (Vector in, Color out), its Closure linked here. Linear or "
                     "Closest interpolation; the group evaluates it at the coordinates it needs")
# "Image ...": a group's "Height" is a height value (SG Height Map Forward, SG Parallax).
IMAGE_WIDTH = SocketSpec("Image Width", INT, "Width of the sampled image in pixels (the Add "
                         "menu sets it from the active Image Texture's image)", default=1024,
                         min=1, max=65536, renamed_from=("Width",))
IMAGE_HEIGHT = SocketSpec("Image Height", INT, "Height of the sampled image in pixels",
                          default=1024, min=1, max=65536, renamed_from=("Height",))

# -- inputs: far from the origin -----------------------------------------------------------------
# Off (a constant), Cycles folds the precise route away: the group costs what it did without it.
PRECISE_FAR = SocketSpec("Precise Far From Origin", BOOLEAN, "Rebuild positions from precise "
                         "parts (the object's origin and its own coordinates) where the object "
                         "is far from the origin, where float32 world positions step visibly. "
                         "Off: the plain route, free. surfgrad's operators and api switch it on "
                         "for objects farther than 64 m", default=False)

# -- inputs: gradient noise ----------------------------------------------------------------------
NOISE_OCTAVES = 4      # the most octaves a noise group sums
NOISE_VECTOR = _vector("Vector", "Position to evaluate")
NOISE_SCALE = SocketSpec("Scale", FLOAT, "Frequency of the first octave", default=4.0, min=0.0,
                         max=1e4, keyword="scale")
OCTAVES = SocketSpec("Octaves", INT, f"Octaves of the fractal sum (1 to {NOISE_OCTAVES})",
                     default=4, min=1, max=NOISE_OCTAVES, keyword="octaves")
GAIN = SocketSpec("Gain", FLOAT, "Amplitude ratio between octaves (frequency doubles)",
                  default=0.5, min=0.0, max=1.0, keyword="gain")

# -- inputs: height-blended layers (reference/height_blend.py) -----------------------------------
LAYER_HEIGHT = SocketSpec("Height", FLOAT, "Height of the layer (the height its bump comes "
                          "from, e.g. the same Image Texture or SG Noise's Value)", default=0.0)
CONTRAST = SocketSpec("Contrast", FLOAT, "Height-blend contrast: 0 blends softly over a whole "
                      "unit of height, 1 switches hard to the higher layer (transition width "
                      "1 - Contrast)", default=0.8, min=0.0, max=1.0, subtype="FACTOR",
                      keyword="contrast")

# -- inputs: decals ------------------------------------------------------------------------------
DECAL_COORDINATES = _vector("Decal Coordinates", "Position in the projector's space (a Texture "
                            "Coordinate node's Object output, the projector as its object)")

# -- outputs -------------------------------------------------------------------------------------
SURFACE_GRADIENT_OUT = _out("Surface Gradient", VECTOR, "Surface gradient")
SUMMABLE_GRADIENT_OUT = SURFACE_GRADIENT_OUT.but(
    tooltip="Surface gradient: add to others, then SG Resolve")
NORMAL_OUT = _out("Normal", VECTOR, "Perturbed unit normal (world space): link it to a BSDF's "
                  "Normal")
TANGENT_OUT = _out("Tangent", VECTOR, "Unit tangent along +s")
BITANGENT_OUT = _out("Bitangent", VECTOR, "Unit bitangent toward +t")
WEIGHTS_OUT = _out("Weights", VECTOR, "The blend weights (x, y, z)")
GRADIENT_OUT = _out("Gradient", VECTOR, "Exact gradient with respect to Vector")
VALUE_OUT = _out("Value", FLOAT, "Noise value")
