"""The Cycles device of the harness's bakes and renders: the CPU (the default, exact and
repeatable), or every GPU of one kind, CUDA or OptiX (--cycles-device on compare, compare-all
and bench-render).

A GPU is chosen through the Cycles add-on's preferences (the same on Blender 4.2 to 5.2):
compute_device_type set to the kind, the devices Cycles finds of that kind enabled and every
other entry (the CPU among them) disabled, so a timing is the GPU's alone; the scene renders
with device "GPU". Everything changed is put back afterwards, device entries the look-up added
included. Without a device of the kind the run is refused (CyclesDeviceError, a ValueError:
the command line's one-line error, exit 2) before anything is baked or written.
"""

from contextlib import contextmanager
from dataclasses import dataclass

KINDS = ("CPU", "CUDA", "OPTIX")


class CyclesDeviceError(ValueError):
    """No device of the asked-for kind: the message names the kind and the fix."""


@dataclass(frozen=True)
class Selection:
    """What a bake or render sets scene.cycles.device to ("CPU" or "GPU"), and the devices
    in words for the JSON outputs ("CPU", or e.g. "CUDA: NVIDIA H200")."""
    scene_device: str
    description: str


def _preferences():
    import bpy
    addon = bpy.context.preferences.addons.get("cycles")
    if addon is None:
        raise CyclesDeviceError("the Cycles add-on is not enabled in this Blender; enable it "
                                "or leave --cycles-device at CPU")
    return addon.preferences


def _check_kind(kind):
    if kind not in KINDS:
        raise CyclesDeviceError(f"Cycles device {kind!r}: use one of {', '.join(KINDS)}")


def _found(prefs, kind):
    """The device entries of `kind` Cycles finds now (a look-up adds entries it had not)."""
    prefs.refresh_devices()
    entries = (prefs.find_existing_device_entry(d) for d in prefs.get_device_list(kind)
               if d[1] == kind)
    return [e for e in entries if e is not None]


def _entries(prefs):
    return {(e.type, e.id): e.use for e in prefs.devices}


def _put_back(prefs, compute_device_type, uses):
    """The preferences as they were: entries added since removed, the others' use restored."""
    for index in reversed(range(len(prefs.devices))):
        entry = prefs.devices[index]
        if (entry.type, entry.id) not in uses:
            prefs.devices.remove(index)
        else:
            entry.use = uses[(entry.type, entry.id)]
    prefs.compute_device_type = compute_device_type


def _no_device(kind):
    return CyclesDeviceError(f"no {kind} device found by Cycles; run on a machine with an "
                             f"NVIDIA GPU or leave --cycles-device at CPU")


def check(kind):
    """The names of the devices of `kind` (["CPU"] for the CPU); CyclesDeviceError when there
    are none. The preferences are left as they were: a check before anything is written."""
    _check_kind(kind)
    if kind == "CPU":
        return ["CPU"]
    prefs = _preferences()
    saved = prefs.compute_device_type, _entries(prefs)
    try:
        names = [e.name for e in _found(prefs, kind)]
    finally:
        _put_back(prefs, *saved)
    if not names:
        raise _no_device(kind)
    return names


@contextmanager
def selected(scene, kind):
    """Bake and render on `kind` inside the block: yields a Selection. CPU touches nothing
    (the bakes set the CPU themselves). A GPU kind sets the preferences and scene.cycles.device
    and puts them back on exit. Enter it after any read_factory_settings (which resets the
    preferences), around the bakes."""
    _check_kind(kind)
    if kind == "CPU":
        yield Selection("CPU", "CPU")
        return
    prefs = _preferences()
    saved = prefs.compute_device_type, _entries(prefs)
    device = scene.cycles.device
    try:
        found = _found(prefs, kind)
        if not found:
            raise _no_device(kind)
        wanted = {(e.type, e.id) for e in found}
        try:
            prefs.compute_device_type = kind
        except TypeError as err:        # this build of Cycles has no such backend
            raise CyclesDeviceError(f"this Blender's Cycles has no {kind} backend ({err}); "
                                    f"leave --cycles-device at CPU") from err
        # Setting the type may re-allocate the entries: enable through the ids.
        for entry in prefs.devices:
            entry.use = (entry.type, entry.id) in wanted
        names = [e.name for e in prefs.devices if e.use]
        scene.cycles.device = "GPU"
        yield Selection("GPU", f"{kind}: {', '.join(names)}")
    finally:
        scene.cycles.device = device
        _put_back(prefs, *saved)
