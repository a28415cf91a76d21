"""A comparison at settings other than a method's defaults: its parameters (Strength...) and
the DirectX switch of its tangent-space groups. At the defaults alone a group that ignored
Strength, squared it, or never flipped green for DirectX passed compare-all (Strength 1 and
DirectX off are exactly where those mistakes change nothing: tests/test_faults_mutants57d.py).

The DirectX case needs no DirectX code in the reference: a DirectX map is by definition the
OpenGL map with its green channel turned into 1 - green, so the graph reads the image with
DirectX on and the reference reads the image with green turned."""

import functools

import numpy as np

DIRECTX = "directx"
# The tangent-space images a DirectX switch decodes (object-space maps have none).
TANGENT_IMAGES = ("normal", "detail")


class SettingsError(ValueError):
    """Settings a method cannot take; the message names them and what it takes."""


def split(method, settings):
    """(parameter values, DirectX on) from `settings` ({name: value}, "directx": bool), each
    name checked against the method's parameters."""
    settings = dict(settings or {})
    directx = bool(settings.pop(DIRECTX, False))
    known = {p.name for p in method.parameters}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise SettingsError(f"method {method.name!r} has no setting {unknown[0]!r}; it takes "
                            f"{', '.join(sorted(known | {DIRECTX}))}")
    return settings, directx


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
