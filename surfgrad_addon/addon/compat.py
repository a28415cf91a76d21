"""Python API differences between the supported Blender lines (4.2 LTS to 5.2 LTS), in one
place, decided by what the running Blender has rather than by its version number.

- Geometry Nodes modifier inputs: ID properties (`mod[identifier]`) up to 5.0; from 5.1
  `mod.properties.inputs.<identifier>.value`, and item assignment raises TypeError.
- A new material has a node tree from 5.0; before, only after `use_nodes = True`.
(tests/test_line_facts.py pins both on every line.)
"""


def new_material(name):
    """A new material with a node tree (Principled BSDF into Material Output) on every line."""
    import bpy
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    return mat


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
