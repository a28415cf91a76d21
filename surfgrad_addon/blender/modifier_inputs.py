"""Geometry Nodes modifier inputs by socket name, on every supported Blender line.

Up to 5.0 a modifier keeps its inputs as ID properties (`mod[identifier]`). From 5.1 they live
in `mod.properties.inputs.<identifier>.value` and item assignment raises TypeError
(tests/test_displace.py pins both)."""


def _identifier(mod, name):
    for item in mod.node_group.interface.items_tree:
        if item.item_type == "SOCKET" and item.in_out == "INPUT" and item.name == name:
            return item.identifier
    raise KeyError(f"the modifier {mod.name!r} ({mod.node_group.name}) has no input {name!r}")


def get_input(mod, name):
    identifier = _identifier(mod, name)
    if hasattr(mod, "properties"):
        return getattr(mod.properties.inputs, identifier).value
    return mod[identifier]


def set_input(mod, name, value):
    """Set input `name` and read it back (a value the line refuses or clamps is an error)."""
    identifier = _identifier(mod, name)
    if hasattr(mod, "properties"):
        getattr(mod.properties.inputs, identifier).value = value
    else:
        mod[identifier] = value
    got = get_input(mod, name)
    if abs(float(got) - float(value)) > 1e-6 * max(1.0, abs(float(value))):
        raise ValueError(f"the modifier {mod.name!r} input {name!r} reads back {got!r}, "
                         f"not {value!r}")
