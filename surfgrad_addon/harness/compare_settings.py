"""A comparison at settings other than a method's defaults: its parameters (Strength...) and
the DirectX switch of its tangent-space groups. At the defaults alone a group that ignored
Strength, squared it, or never flipped green for DirectX passed compare-all (Strength 1 and
DirectX off are exactly where those mistakes change nothing: tests/test_faults_mutants57d.py).

The DirectX case needs no DirectX code in the reference: a DirectX map is by definition the
OpenGL map with its green channel turned into 1 - green, so the graph reads the image with
DirectX on and the reference reads the image with green turned."""

import functools
import math
import numbers

import numpy as np

from ..reference.group_interfaces import INTERFACES
from ..reference.socket_specs import INT

DIRECTX = "directx"
# The tangent-space images a DirectX switch decodes (object-space maps have none).
TANGENT_IMAGES = ("normal", "detail")


class SettingsError(ValueError):
    """Settings a method cannot take; the message names them and what it takes."""


def split(method, settings):
    """(parameter values, DirectX on) from `settings` ({name: value}, "directx": bool), each
    name checked against the method's parameters."""
    settings = dict(settings or {})
    directx = settings.pop(DIRECTX, False)
    # Not bool(): the text "false" is true, and turned DirectX on.
    if directx not in (True, False):
        raise SettingsError(f"method {method.name!r}: setting {DIRECTX!r} takes True or "
                            f"False, not {directx!r}")
    directx = bool(directx)
    known = {p.name for p in method.parameters}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise SettingsError(f"method {method.name!r} has no setting {unknown[0]!r}; it takes "
                            f"{', '.join(sorted(known | {DIRECTX}))}")
    for p in method.parameters:
        if p.name in settings:
            settings[p.name] = checked_value(method, p, settings[p.name])
    return settings, directx


# Float sockets whose group follows the reference only within a range narrower than any
# float: Sharpness k past 64 (the socket's top) makes Listing 14's weights (|n| - 0.2)^k
# underflow the bake's float32 where no axis dominates, the blend then 0 / 0 (at 80 to 100
# the correct triplanar group compared 0.08-52 deg p99 wrong, triplanar-height 1.7-20 deg);
# a negative k divides by the zero weights (63-68 deg). 0 to 64 agree within 0.005 deg (rt59a).
HONOURED_RANGES = {"Sharpness": (0.0, 64.0)}


def _socket_spec(parameter):
    """The interface spec of the socket `parameter` sets (the same on each of its groups)."""
    for group in parameter.groups:
        for spec in getattr(INTERFACES.get(group), "inputs", ()):
            if spec.name == parameter.socket:
                return spec
    return None


def checked_value(method, parameter, value):
    """`value` as the group takes it; a SettingsError, naming what it takes, for a value the
    group would not honour as the reference does: not a finite number (a NaN Strength compared
    as 0.000 deg on the sphere; "2" and 2.5 octaves were raw bpy TypeErrors), or an integer
    socket's value outside its range (SG Noise sums at most its NOISE_OCTAVES octaves: the
    reference summing 8 called the correct group 29-36 deg wrong). Float sockets are honoured
    past their slider range (Strength 1e3, Bump Scale 1e4 compare within 0.03 deg), so only
    finiteness is asked of them."""
    spec = _socket_spec(parameter)
    what = f"method {method.name!r}: setting {parameter.name!r} ({parameter.socket})"
    if isinstance(value, bool) or not isinstance(value, numbers.Real) \
            or not math.isfinite(value):
        raise SettingsError(f"{what} must be a finite number, not {value!r}")
    if spec is None or spec.type != INT:
        low, high = HONOURED_RANGES.get(parameter.socket, (-math.inf, math.inf))
        if not low <= value <= high:
            raise SettingsError(f"{what} is compared from {low:g} to {high:g}, not {value!r}: "
                                f"past that the group's float32 blend weights underflow or "
                                f"divide by zero, and the bake differs from the reference by "
                                f"that, not by the group; set it within the range")
        return float(value)
    if value != int(value) or not spec.min <= value <= spec.max:
        raise SettingsError(f"{what} takes a whole number from {spec.min} to {spec.max} (the "
                            f"group's range), not {value!r}")
    return int(value)


def turn_green(inp, method):
    """The reference's copies of the tangent-space images the method reads, green turned into
    1 - green (the bpy images, which the bake reads, stay as they are)."""
    for name in TANGENT_IMAGES:
        if name in method.reads and name in inp.images:
            px, img = inp.images[name]
            px = px.copy()
            px[..., 1] = 1.0 - px[..., 1]
            inp.images[name] = (px, img)


def with_directx_on(graph):
    """graph, with DirectX switched on on every group node of it that has the switch; a graph
    without one is a SettingsError (the setting would reach nothing)."""
    @functools.wraps(graph)
    def on(inp, nodes, links):
        out = graph(inp, nodes, links)
        switches = [n.inputs["DirectX"] for n in nodes if n.bl_idname == "ShaderNodeGroup"
                    and "DirectX" in n.inputs and not n.inputs["DirectX"].is_linked]
        if not switches:
            raise SettingsError(f"method {graph.__name__!r} has no group with a DirectX switch")
        for socket in switches:
            socket.default_value = True
        return out
    return on


def label(settings):
    """"directx-strength0.6" for {"directx": True, "strength": 0.6}; "" for none."""
    parts = []
    for name, value in sorted((settings or {}).items()):
        if value is True:
            parts.append(name)
        elif value is not False:
            parts.append(f"{name}{np.format_float_positional(value, trim='-')}")
    return "-".join(parts)
