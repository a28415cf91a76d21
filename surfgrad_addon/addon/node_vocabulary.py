"""The one vocabulary for node graphs (groups, bake materials, benches, exhibits): Blender's
Math and Vector Math operations as enums, and the node types and socket names that code links
by, each spelled once here. Anything that builds nodes names them through this module, never
as string literals, so a typo is an AttributeError at import, not a wrong graph at render."""

from enum import Enum


class Math(str, Enum):
    """ShaderNodeMath.operation (also the Geometry Nodes Math node)."""
    ADD = "ADD"
    SUBTRACT = "SUBTRACT"
    MULTIPLY = "MULTIPLY"
    DIVIDE = "DIVIDE"
    MULTIPLY_ADD = "MULTIPLY_ADD"
    POWER = "POWER"
    EXPONENT = "EXPONENT"
    SQRT = "SQRT"
    ABSOLUTE = "ABSOLUTE"
    MINIMUM = "MINIMUM"
    MAXIMUM = "MAXIMUM"
    LESS_THAN = "LESS_THAN"
    GREATER_THAN = "GREATER_THAN"
    COMPARE = "COMPARE"
    SIGN = "SIGN"
    FLOOR = "FLOOR"
    FRACT = "FRACT"
    MODULO = "MODULO"
    SINE = "SINE"
    COSINE = "COSINE"
    ARCTAN2 = "ARCTAN2"


class VMath(str, Enum):
    """ShaderNodeVectorMath.operation. DOT_PRODUCT, LENGTH and DISTANCE answer on the Value
    output; the rest on the Vector output (NodeOps.vmath picks it)."""
    ADD = "ADD"
    SUBTRACT = "SUBTRACT"
    MULTIPLY = "MULTIPLY"
    DIVIDE = "DIVIDE"
    MULTIPLY_ADD = "MULTIPLY_ADD"
    SCALE = "SCALE"
    CROSS_PRODUCT = "CROSS_PRODUCT"
    FACEFORWARD = "FACEFORWARD"
    DOT_PRODUCT = "DOT_PRODUCT"
    LENGTH = "LENGTH"
    DISTANCE = "DISTANCE"
    NORMALIZE = "NORMALIZE"
    ABSOLUTE = "ABSOLUTE"
    MINIMUM = "MINIMUM"
    MAXIMUM = "MAXIMUM"
    FLOOR = "FLOOR"
    FRACTION = "FRACTION"
    MODULO = "MODULO"
    SINE = "SINE"
    COSINE = "COSINE"


VALUE_OPS = frozenset((VMath.DOT_PRODUCT, VMath.LENGTH, VMath.DISTANCE))
