"""Python API differences between the supported Blender lines (4.2 LTS to 5.2 LTS), in one
place, decided by what the running Blender has rather than by its version number.

- Geometry Nodes modifier inputs: ID properties (`mod[identifier]`) up to 5.0; from 5.1
  `mod.properties.inputs.<identifier>.value`, and item assignment raises TypeError.
- A new material has a node tree from 5.0; before, only after `use_nodes = True`. Up to 4.5 a
  material keeps its tree with Use Nodes off (an old file's, or switched off) and renders
  without it; from 5.0 `use_nodes` is deprecated and always True.
- An action's F-curves: `action.fcurves` up to 4.5; from 5.0 only in the channelbag of the
  animation data's slot (bpy_extras.anim_utils).
(tests/test_line_facts.py pins both on every line.)
"""


def new_material(name):
    """A new material with a node tree (Principled BSDF into Material Output) on every line."""
    import bpy
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    return mat


def renders_its_nodes(mat):
    """Whether Cycles renders `mat` through its node tree (see the module's note)."""
    if mat.node_tree is None:
        return False
    rna = getattr(mat, "bl_rna", None)
    prop = rna.properties.get("use_nodes") if rna is not None else None
    if prop is None or getattr(prop, "is_deprecated", False):     # 5.0 on: always
        return True
    return mat.use_nodes


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
