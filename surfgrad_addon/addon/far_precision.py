"""The groups' Precise Far From Origin input: when an object needs it, and switching it.

Off by default, the input folds the groups' precise route away (render cost, issue 21). An
object whose bounding box reaches beyond FAR_METRES from the world origin needs it: there the
projector coordinates switch to their precise parts (and triplanar positions, 64 repeats out).
The operators set it when they add a group for the active object, api.update_precise_far and the
harness's bakes for the object they render.
"""

from ..reference.socket_specs import PRECISE_FAR
from .far_limits import FAR_METRES
from .precise_bake import distance_from_origin


def needs_precise_far(obj):
    """True when obj reaches farther than FAR_METRES from the origin (float32 world positions
    step by 7.6e-6 m or more there)."""
    return obj is not None and obj.type == "MESH" and distance_from_origin(obj) > FAR_METRES


def set_precise_far_on_node(node, on=True):
    """Set a group node's Precise Far From Origin (unless linked); True if it has one."""
    socket = node.inputs.get(PRECISE_FAR.name) if node.bl_idname == "ShaderNodeGroup" else None
    if socket is None or socket.is_linked:
        return False
    socket.default_value = bool(on)
    return True


def set_precise_far(tree, on):
    """Set Precise Far From Origin on every group node of `tree` that has it; returns how
    many were set."""
    return sum(set_precise_far_on_node(node, on) for node in tree.nodes)
