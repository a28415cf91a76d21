"""Python API differences between the supported Blender lines (4.2 LTS to 5.2 LTS), in one
place, decided by what the running Blender has rather than by its version number.

- Geometry Nodes modifier inputs: ID properties (`mod[identifier]`) up to 5.0; from 5.1
  `mod.properties.inputs.<identifier>.value`, and item assignment raises TypeError.
- A new material has a node tree from 5.0; before, only after `use_nodes = True`. Up to 4.5
  Use Nodes can be off with a tree there (the material renders without it); from 5.0 it is
  always on (setting it off is ignored) and reading it is deprecated.
- An action's F-curves: `action.fcurves` up to 4.5; from 5.0 only in the channelbag of the
  animation data's slot (bpy_extras.anim_utils).
(tests/test_line_facts.py pins the tree and the F-curves on every line,
tests/test_faults_artist47.py Use Nodes.)
"""


def new_material(name):
    """A new material with a node tree (Principled BSDF into Material Output) on every line."""
    import bpy
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    return mat


def renders_nodes(mat):
    """True when material `mat` renders through its node tree (Use Nodes on, where the line
    lets it be off), without 5.0's deprecation warning for reading `use_nodes`."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return mat.node_tree is not None and getattr(mat, "use_nodes", True)


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


def animated_fcurves(anim):
    """The F-curves of animation data `anim`: its drivers and its action's keyframes."""
    fcurves = list(anim.drivers)
    action = anim.action
    if action is not None and hasattr(action, "fcurves"):
        fcurves += list(action.fcurves)
    elif action is not None:
        from bpy_extras.anim_utils import animdata_get_channelbag_for_assigned_slot
        bag = animdata_get_channelbag_for_assigned_slot(anim)
        fcurves += list(bag.fcurves) if bag is not None else []
    return fcurves
