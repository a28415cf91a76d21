"""A small layer for building shader node groups by code, so that a builder reads like the
listing it implements:

    def build(b):                       # the interface comes from reference/group_interfaces
        n = b.input(S.NORMAL)
        sg = b.input(S.SURFACE_GRADIENT)
        with b.frame("Listing 1: resolve"):
            b.output(S.NORMAL_OUT, b.normalize(b.sub(n, sg)))
    ensure_group("SG Resolve", VERSION, build, interface=INTERFACES["SG Resolve"])

Sockets are SocketSpecs (reference/socket_specs.py); a group with a declared interface gets all
its sockets created from it, in its order, and the builder only looks them up (an input or
output the interface lacks, or one it declares and the builder never uses, is a BuildError).
Arithmetic helpers take sockets or constants and return output sockets. `ensure_group` makes
building idempotent and versioned: a group that already has the current version is reused; an
older one is rebuilt in place (same datablock, same interface socket identifiers where the
socket still exists, or was renamed: SocketSpec.renamed_from), so links and values in existing
materials survive an add-on update. Enumerations: addon/enum_input.py.
"""

import hashlib
import math
import re
from contextlib import contextmanager
from typing import NamedTuple

import bpy

from ..reference.group_interfaces import plain_value
from ..reference.socket_specs import SOCKET_TYPES, SocketSpec
from .compat import animated_fcurves
from .group_names import (INSIDE_KEY, LINE_KEY, VERSION_KEY, fitting_name,
                          newer_group_problem, override_text, stale_copies)
from .node_vocabulary import VALUE_OPS, Math, VMath


def running_line():
    """The facts of the running Blender's line (reference/blender_lines.py)."""
    from ..reference.blender_lines import facts_for
    return facts_for(bpy.app.version)


class BuildError(RuntimeError):
    """A socket, node, property or link that this Blender refused or changed: the message
    names the group and the part, so nothing is lost silently on any Blender line."""


def ensure_group(name, version, build, description=None, stale=None, tree_type="ShaderNodeTree",
                 interface=None, held_name=None):
    """Return node group `name`, (re)building it with build(GroupBuilder) unless it already
    carries `version` (and `stale(tree)`, if given, is false: e.g. an image it references is
    gone). tree_type: "ShaderNodeTree" or "GeometryNodeTree". interface: the group's
    GroupInterface (its sockets, and the description unless one is given). held_name(tree):
    of a per-image group, the name it gets for the images it holds (None where one is gone).
    Checked whole first (checked_first): a refusal anywhere in it, a helper's too, changes no
    existing group."""
    args = (name, version, build, description, stale, tree_type, interface, held_name)
    if _CHECK.scratch is None and not _CHECK.done:
        return checked_first(lambda: _ensure(*args))[0]
    return _ensure(*args)


class _CheckPass:
    """The state of checked_first: during its check pass `scratch` maps each group name to what
    was built for it (its scratch group, the file lacked it, the _ensure arguments) and
    `rebuilt` lists the file's groups the real pass would rebuild in place; `done` during the
    real pass of a request already checked."""
    scratch = None
    rebuilt = None
    done = False


class HoldsTree(ValueError):
    """A request would put a group into the node tree an edit adds to (`outside`) that is that
    tree or holds it, or would rebuild that tree in place (freeing the nodes the editor shows,
    the one being converted too): refused in the check pass, nothing changed."""

    def __init__(self, tree, group_name, rebuilt=False):
        self.group_name = group_name
        if rebuilt:
            super().__init__(f"The editor shows the inside of node group {tree.name!r}, an "
                             f"older surfgrad's (or another Blender line's), which this edit "
                             f"would rebuild, replacing the nodes shown: leave the group (Tab) "
                             f"and edit the material, or run Update surfgrad Groups first")
            return
        super().__init__(f"The editor shows the inside of node group {tree.name!r}, and this "
                         f"edit adds {group_name!r} nodes" +
                         ("" if group_name == tree.name else f", which use {tree.name!r}") +
                         ": a group cannot hold itself; leave the group (Tab) and edit the "
                         "material")


def _holds(group, tree, real_of, seen):
    """True if `group` (a scratch group standing for the file's group `real_of` names, or a
    real one) is `tree` or holds it at any depth."""
    if group is None:
        return False
    if group == tree or real_of.get(group) == tree:
        return True
    if group.name_full in seen:
        return False
    seen.add(group.name_full)
    return any(_holds(n.node_tree, tree, real_of, seen) for n in group.nodes
               if n.bl_idname in ("ShaderNodeGroup", "GeometryNodeGroup"))


_CHECK = _CheckPass()


class _Scratch(NamedTuple):
    group: object
    new: bool
    args: tuple


def checked_first(*builds, outside=None):
    """Call every group-building function in `builds` in two passes: a check pass, in which
    every group that would be built or rebuilt (helpers too) is built on a scratch group
    instead, then, if nothing was refused, the real pass. So a group of the user's under a
    helper's name, a newer surfgrad's helper or a node this line lacks refuses the whole request
    before any group of the file changes. `outside`: the node tree the request's groups go into
    (a group the editor shows, entered with Tab): a group that is it or holds it, or a rebuild
    of it in place, raises HoldsTree in the check pass. Returns the builds' results."""
    if _CHECK.scratch is not None or _CHECK.done:      # within a request checked already
        return [build() for build in builds]
    _CHECK.scratch, _CHECK.rebuilt = {}, []
    try:
        results = [build() for build in builds]
        if outside is not None:
            real_of = {b.group: bpy.data.node_groups.get((name, None))
                       for name, b in _CHECK.scratch.items()}
            names = {b.group: name for name, b in _CHECK.scratch.items()}
            for group in results:
                if _holds(group, outside, real_of, set()):
                    raise HoldsTree(outside, names.get(group, group.name))
            if outside in _CHECK.rebuilt:
                # (Rebuilt, its nodes are freed: an edit holding one crashed Blender.)
                raise HoldsTree(outside, outside.name, rebuilt=True)
    except BaseException:
        for built in _CHECK.scratch.values():
            bpy.data.node_groups.remove(built.group)
        raise
    finally:
        scratch, _CHECK.scratch, _CHECK.rebuilt = _CHECK.scratch, None, None
    _CHECK.done = True
    try:
        _build_checked(scratch)
        return [build() for build in builds]          # each group current now: returned
    finally:
        _CHECK.done = False


def _build_checked(scratch):
    """The real pass: the scratch group of a group the file lacked becomes that group (built
    once, not twice) where every group it uses is real or becomes so; every other group is
    built or rebuilt in place, and its scratch removed."""
    scratches = {built.group: name for name, built in scratch.items()}
    kept = {}

    def keeps(name):
        if name not in kept:
            built = scratch[name]
            kept[name] = built.new and all(
                keeps(scratches[n.node_tree]) for n in built.group.nodes
                if getattr(n, "node_tree", None) in scratches)
        return kept[name]

    for name, built in scratch.items():
        if keeps(name):
            built.group.name = name
            built.group[VERSION_KEY], built.group[LINE_KEY] = built.args[1], running_line().line
    try:
        for name, built in scratch.items():
            if not kept[name]:
                _ensure(*built.args)
    finally:
        for name, built in scratch.items():
            if not kept[name]:
                bpy.data.node_groups.remove(built.group)


def _ensure(name, version, build, description, stale, tree_type, interface, held_name=None):
    if description is None:
        description = interface.describe()
    name = fitting_name(name)
    # The local group only: one linked from a library (with a material linked in) is the
    # library's, and an edit of it is never saved: the new node would reopen on its old version.
    tree = bpy.data.node_groups.get((name, None))
    if tree is not None and tree.bl_idname != tree_type:
        raise ValueError(f"a {tree.bl_idname} named {name!r} already exists; rename it so the "
                         f"surface-gradient group can be created")
    if tree is not None and VERSION_KEY not in tree:
        # Ours carry the version stamp; a group without it is the user's: never rebuilt over.
        raise ValueError(f"a node group named {name!r} already exists and is not a "
                         f"surface-gradient group; rename it so surfgrad can add its own")
    problem = newer_group_problem(tree, name, version)
    if problem:
        raise ValueError(problem)
    line = running_line().line
    # Copies Blender named "<name>.001" when a material was appended or linked in from a
    # file with older groups: rebuilt here too, or the two versions stay mixed for good.
    copies = stale_copies(name, version, line, tree_type) if stale is None else []
    current = (tree is not None and tree.get(VERSION_KEY) == version
               and tree.get(LINE_KEY) == line and not (stale and stale(tree)))
    edited = current and (
        interface is not None and edited_sockets(
            tree, interface.for_line(running_line().menu_sockets))
        or edited_inside(tree) and "inside: a node or link added, removed, muted or set "
                                   "otherwise")
    if tree is not None and not current and getattr(tree, "override_library", None) is not None:
        # A library override takes the nodes of a rebuild, but the file saves only an
        # override's changed values: reopened, the group (and every node given it) would be
        # the library's older one again.
        raise ValueError(override_text(tree, name))
    if edited:
        # Reused, a new node would not do what surfgrad's does (a compare called the method
        # wrong; an operator linking a renamed socket raised KeyError); rebuilt, the artist's
        # edit would be lost: the artist's group now, as one of the user's is.
        raise ValueError(f"node group {name!r} was edited after surfgrad made it ({edited}): "
                         f"rename it to keep your version, so surfgrad can add its own")
    if _CHECK.scratch is not None and (copies or not current):
        # The check pass: what the request would build is built on a scratch group, once.
        _CHECK.rebuilt += [*copies, *([tree] if tree is not None and not current else [])]
        if name not in _CHECK.scratch:
            scratch = bpy.data.node_groups.new(f"{name} (build check)", tree_type)
            _CHECK.scratch[name] = _Scratch(scratch, tree is None and not copies,
                                            (name, version, build, description, stale,
                                             tree_type, interface, held_name))
            _rebuild(scratch, description, build, interface, 0, "")
        return tree if current else _CHECK.scratch[name].group
    for copy in copies:
        _rebuild(copy, description, build, interface, version, line)
    if current:
        return tree
    held = held_name and tree is not None and held_name(tree)
    if held and fitting_name(held) != name:
        # Another image's group under this image's name (that image renamed, by the artist or
        # by an append that brought in one of the same name): rebuilt here, every material
        # using it would read this image. It takes its own image's name; this one is new.
        tree.name = fitting_name(held)
        tree = None
    if tree is None:
        tree = bpy.data.node_groups.new(name, tree_type)
    _rebuild(tree, description, build, interface, version, line)
    return tree


def edited_sockets(tree, interface):
    """'' when group `tree` has the sockets of `interface` (names, directions, types), else
    what differs, e.g. "no input 'A'; an input 'Base' of its own"."""
    have = {(it.in_out, it.name, it.socket_type) for it in tree.interface.items_tree
            if it.item_type == "SOCKET"}
    want = {("OUTPUT", s.name, SOCKET_TYPES[s.type]) for s in interface.outputs} | \
        {("INPUT", s.name, SOCKET_TYPES[s.type]) for s in interface.inputs}
    return "; ".join([f"no {d.lower()} {n!r}" for d, n, _ in sorted(want - have)] +
                     [f"an {d.lower()} {n!r} of its own" for d, n, _ in sorted(have - want)])


def _rebuild(tree, description, build, interface, version, line):
    """Build `tree` in place: its interface sockets keep their identifiers, so the links and
    values of the group nodes that use it survive."""
    if edited_inside(tree):
        _NOTES.append(f"node group {tree.name!r} was edited inside after surfgrad made it (a "
                      f"node or link added, removed, muted or set otherwise), and its rebuild "
                      f"for this version replaced that edit: to keep it, undo (Ctrl+Z) and "
                      f"rename the group")
    driven = _driven_inputs(tree)
    tree.nodes.clear()
    tree.description = description
    builder = GroupBuilder(tree)
    if interface is not None:
        builder.declare(interface.for_line(running_line().menu_sockets))
    build(builder)
    builder.finish()
    if interface is not None:
        _carry_choices(builder, interface)
    _follow_drivers(driven)
    tree[VERSION_KEY] = version
    tree[LINE_KEY] = line
    tree[INSIDE_KEY] = inside_digest(tree)


_NODE_BASE = set(bpy.types.Node.bl_rna.properties.keys())
_SETTINGS = {}


def _settings(node):
    """The names of a node type's own settings (an operation, a data type, a space)."""
    if node.bl_idname not in _SETTINGS:
        _SETTINGS[node.bl_idname] = [
            p.identifier for p in node.bl_rna.properties
            if p.identifier not in _NODE_BASE and not p.is_readonly
            and p.type in {"BOOLEAN", "INT", "FLOAT", "STRING", "ENUM"}
            and getattr(p, "array_length", 0) == 0]
    return _SETTINGS[node.bl_idname]


def edited_inside(tree):
    """True when group `tree` was changed inside since it was built, as far as can be told: its
    digest was taken by this Blender version (another reads some nodes otherwise: a correct
    group is never called edited)."""
    stored, now = tree.get(INSIDE_KEY), inside_digest(tree)
    return isinstance(stored, str) and stored.split(":")[0] == now.split(":")[0] \
        and stored != now


def _settled(value):
    return sorted(value) if isinstance(value, set) else value     # (an enum flag: one order)


def inside_digest(tree):
    """"<Blender version>:<digest>" of what group `tree` computes: its nodes (type, mute,
    settings, unlinked input values) and links; not where they are drawn, nor the names of the
    groups and images they use (renamed by merges and by the artist)."""
    rows = []
    for node in sorted(tree.nodes, key=lambda n: n.name):
        settings = [(key, _settled(getattr(node, key))) for key in _settings(node)]
        values = [(i, _plain(s.default_value)) for i, s in enumerate(node.inputs)
                  if not s.is_linked and hasattr(s, "default_value")]
        rows.append(repr((node.name, node.bl_idname, node.mute, settings, values)))
    rows += sorted(repr((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name,
                         lk.to_socket.identifier, lk.is_muted)) for lk in tree.links)
    digest = hashlib.sha1("\n".join(rows).encode()).hexdigest()[:16]
    return f"{'.'.join(map(str, bpy.app.version))}:{digest}"


def check_value(got, want, what):
    """Raise BuildError unless `got` (a Blender property read back) equals `want` to float32
    precision."""
    try:
        g = [float(x) for x in got] if hasattr(got, "__len__") and not isinstance(got, str) \
            else [float(got)]
        w = [float(x) for x in want] if hasattr(want, "__len__") and not isinstance(want, str) \
            else [float(want)]
    except (TypeError, ValueError):
        if got != want:
            raise BuildError(f"{what} reads back {got!r}, not {want!r}") from None
        return
    if len(g) != len(w) or any(abs(a - b) > 1e-6 * max(1.0, abs(b)) for a, b in zip(g, w)):
        raise BuildError(f"{what} reads back {got!r}, not {want!r}")


class NodeOps:
    """Node arithmetic shared by group builders and material graphs: sockets or constants in,
    output sockets out. Subclasses provide self.nodes, self.links and node()."""

    where = "a material"      # named in errors

    def node(self, bl_idname, label=None, **props):
        try:
            n = self.nodes.new(bl_idname)
        except RuntimeError as ex:
            raise BuildError(f"{self.where}: Blender {bpy.app.version_string} cannot create "
                             f"a {bl_idname} node ({ex})") from None
        for key, value in props.items():
            try:
                setattr(n, key, value)
            except (TypeError, AttributeError, ValueError) as ex:
                raise BuildError(f"{self.where}: cannot set {bl_idname}.{key} = {value!r} "
                                 f"({ex})") from None
            if isinstance(value, (str, bool, int)) and getattr(n, key) != value:
                raise BuildError(f"{self.where}: {bl_idname}.{key} reads back "
                                 f"{getattr(n, key)!r}, not {value!r}")
        if label:
            n.label = label
        return n

    def link(self, source, target):
        """Link a socket, or set a constant on `target`; raises BuildError when Blender makes
        no valid link or does not take the value."""
        if isinstance(source, bpy.types.NodeSocket):
            if not target.enabled:
                raise BuildError(f"{self.where}: {target.node.name}.{target.name} is not an "
                                 f"active input of this node on Blender "
                                 f"{bpy.app.version_string}")
            if target.type in ("BOOLEAN", "INT") and source.type in ("VECTOR", "RGBA"):
                raise BuildError(f"{self.where}: a {source.type.lower()} "
                                 f"({source.node.name}.{source.name}) would be squashed into "
                                 f"{target.type.lower()} input {target.node.name}."
                                 f"{target.name}")
            made = self.links.new(source, target)
            if made is None or not made.is_valid or made.to_socket != target:
                raise BuildError(f"{self.where}: no valid link from {source.node.name}."
                                 f"{source.name} to {target.node.name}.{target.name}")
        elif source is not None:
            if not hasattr(target, "default_value"):
                raise BuildError(f"{self.where}: {target.node.name}.{target.name} takes no "
                                 f"constant ({source!r})")
            target.default_value = source
            check_value(target.default_value, source,
                        f"{self.where}: {target.node.name}.{target.name}")

    def _op(self, bl_idname, op, inputs, output=0):
        n = self.node(bl_idname, operation=op)
        slots = [s for s in n.inputs if s.enabled]
        if len(inputs) > len(slots):
            raise BuildError(f"{self.where}: {bl_idname} {op} takes {len(slots)} inputs on "
                             f"Blender {bpy.app.version_string}, {len(inputs)} given")
        for slot, value in zip(slots, inputs):
            self.link(value, slot)
        return n.outputs[output]

    # Vector Math (outputs[0] is the vector, outputs[1] the value).
    def vmath(self, op, *inputs):
        """Vector Math `op` (a VMath) on sockets or constants."""
        op = VMath(op)
        return self._op("ShaderNodeVectorMath", op.value, inputs, 1 if op in VALUE_OPS else 0)

    def math(self, op, *inputs):
        """Math `op` (a Math) on sockets or constants."""
        return self._op("ShaderNodeMath", Math(op).value, inputs)

    def add(self, a, b):
        return self.vmath(VMath.ADD, a, b)

    def sub(self, a, b):
        return self.vmath(VMath.SUBTRACT, a, b)

    def scale(self, v, s):
        n = self.node("ShaderNodeVectorMath", operation=VMath.SCALE.value)
        self.link(v, n.inputs[0])
        self.link(s, n.inputs["Scale"])
        return n.outputs[0]

    def dot(self, a, b):
        return self.vmath(VMath.DOT_PRODUCT, a, b)

    def cross(self, a, b):
        return self.vmath(VMath.CROSS_PRODUCT, a, b)

    def normalize(self, v):
        return self.vmath(VMath.NORMALIZE, v)

    def length(self, v):
        return self.vmath(VMath.LENGTH, v)

    def is_zero(self, v):
        """1 where vector v is (0, 0, 0), else 0: how a group tells an unlinked vector input
        (it reads zero) from a linked one."""
        return self.math(Math.COMPARE, self.length(v), 0.0, 0.0)

    def geometry(self, output):
        """An output of a new Geometry node ("Normal", "Position", "Incoming", ...)."""
        return self.node("ShaderNodeNewGeometry").outputs[output]

    def bump(self, height, normal, filter_width=None, strength=1.0, distance=1.0):
        """The Bump node's normal for `height` over `normal` (Filter Width where the line has
        it, else the node's own)."""
        node = self.node("ShaderNodeBump")
        node.inputs["Strength"].default_value = strength
        node.inputs["Distance"].default_value = distance
        if filter_width is not None and "Filter Width" in node.inputs:
            node.inputs["Filter Width"].default_value = filter_width
        self.link(height, node.inputs["Height"])
        self.link(normal, node.inputs["Normal"])
        return node.outputs[0]

    def normal_map(self, color, space, strength=1.0, uv_map=""):
        """A Normal Map node's Normal; its colour read as OpenGL (5.2's Convention)."""
        props = {"uv_map": uv_map} if space == "TANGENT" else {}
        node = self.node("ShaderNodeNormalMap", space=space, **props)
        if space == "TANGENT" and hasattr(node, "convention"):
            node.convention = "OPENGL"
        self.link(strength, node.inputs["Strength"])
        self.link(color, node.inputs["Color"])
        return node.outputs["Normal"]

    def separate(self, v):
        n = self.node("ShaderNodeSeparateXYZ")
        self.link(v, n.inputs[0])
        return n.outputs[0], n.outputs[1], n.outputs[2]

    def combine(self, x, y, z=0.0):
        n = self.node("ShaderNodeCombineXYZ")
        for slot, value in zip(n.inputs, (x, y, z)):
            self.link(value, slot)
        return n.outputs[0]

    def mix_vector(self, factor, a, b, per_axis=False):
        """(1 - factor) a + factor b with a scalar factor (a vector one, axis by axis, where
        `per_axis`)."""
        n = self.node("ShaderNodeMix", data_type="VECTOR", clamp_factor=False,
                      factor_mode="NON_UNIFORM" if per_axis else "UNIFORM")
        inputs = {s.identifier: s for s in n.inputs}
        self.link(factor, inputs["Factor_Vector" if per_axis else "Factor_Float"])
        self.link(a, inputs["A_Vector"])
        self.link(b, inputs["B_Vector"])
        return {s.identifier: s for s in n.outputs}["Result_Vector"]



class GroupBuilder(NodeOps):
    """Creates sockets and nodes in a shader node group; see the module doc."""

    def __init__(self, tree):
        self.tree = tree
        self.where = f"node group {tree.name!r}"
        self.nodes = tree.nodes
        self.links = tree.links
        self._frame = None
        self._wanted = []          # interface items in order, to prune stale ones at the end
        self._specs = {}           # (in_out, name) -> (SocketSpec, identifier)
        self._used = set()
        self._fixed = False        # True once an interface is declared: nothing may be added
        self.retyped = {}          # name -> [GroupNodeInput] of a socket that changed type
        self.group_in = self.nodes.new("NodeGroupInput")
        self.group_out = self.nodes.new("NodeGroupOutput")

    # -- interface ---------------------------------------------------------------------------
    def _item(self, identifier):
        for it in self.tree.interface.items_tree:
            if it.item_type == "SOCKET" and it.identifier == identifier:
                return it
        raise BuildError(f"{self.where}: interface socket {identifier} vanished")

    def _existing(self, names, in_out):
        """The first not yet claimed interface socket named one of `names` (in that order)."""
        for name in names:
            for it in self.tree.interface.items_tree:
                if (it.item_type == "SOCKET" and it.name == name and it.in_out == in_out
                        and it.identifier not in self._wanted):
                    return it
        return None

    def _socket(self, name, in_out, kind, description, default=None, min_value=None,
                max_value=None, subtype=None, hide_value=False, renamed_from=()):
        # Items are tracked by identifier: from Blender 5.1 setting a subtype replaces the
        # item's Python object (its type becomes e.g. ...VectorDirection).
        bl_type = SOCKET_TYPES[kind]
        what = f"{self.where}: {in_out.lower()} socket {name!r}"
        item = self._existing((name, *renamed_from), in_out)
        if item is not None and item.name != name:
            item.name = name        # renamed in place: same identifier, links and values kept
        if item is not None and item.socket_type != bl_type:
            # A new type (an integer become a Menu): the nodes' values, for the new socket.
            self.retyped[name] = group_node_inputs(self.tree, item.identifier)
            self.tree.interface.remove(item)
            item = None
        if item is None:
            try:
                item = self.tree.interface.new_socket(name, in_out=in_out, socket_type=bl_type)
            except (TypeError, RuntimeError) as ex:
                raise BuildError(f"{what}: cannot create a {bl_type} ({ex})") from None
        identifier = item.identifier
        item.description = description
        if subtype is not None:
            if not hasattr(item, "subtype"):
                raise BuildError(f"{what}: a {bl_type} has no subtype here")
            item.subtype = subtype
            item = self._item(identifier)
        for key, value in (("default_value", default), ("min_value", min_value),
                           ("max_value", max_value)):
            if value is not None:
                if not hasattr(item, key):
                    raise BuildError(f"{what}: a {bl_type} has no {key}")
                setattr(item, key, value)
        item.hide_value = hide_value
        item = self._item(identifier)
        # Read everything back: a line that drops or clamps a setting is an error, not a loss.
        if item.name != name or item.socket_type != bl_type or item.in_out != in_out:
            raise BuildError(f"{what}: became {item.in_out} {item.name!r} {item.socket_type}")
        if item.description != description:
            raise BuildError(f"{what}: the tooltip was not kept")
        if subtype is not None and item.subtype != subtype:
            raise BuildError(f"{what}: subtype {item.subtype!r}, not {subtype!r}")
        for key, value in (("default_value", default), ("min_value", min_value),
                           ("max_value", max_value)):
            if value is not None:
                check_value(getattr(item, key), value, f"{what} {key}")
        self._wanted.append(identifier)
        return item

    def declare(self, interface):
        """Create every socket of `interface` (a GroupInterface), outputs then inputs; from
        then on input() and output() only look them up."""
        for spec in interface.outputs:
            self._declare(spec, "OUTPUT")
        for spec in interface.inputs:
            self._declare(spec, "INPUT")
        self._fixed = True

    def _declare(self, spec, in_out):
        # A Menu socket's default names an item of the Menu Switch it feeds: enum_input sets
        # it once that is linked.
        default = None if spec.items else spec.default
        item = self._socket(spec.name, in_out, spec.type, spec.tooltip, default, spec.min,
                            spec.max, spec.subtype, spec.hide_value, spec.renamed_from)
        self._specs[(in_out, spec.name)] = (spec, item.identifier)

    def _declared(self, spec, in_out):
        """The interface item of `spec` (a SocketSpec, or the name of a declared socket). With
        a declared interface a spec is found by name and must have its type (its tooltip may be
        the group's variant); without one, the spec is added."""
        name = spec if isinstance(spec, str) else spec.name
        found = self._specs.get((in_out, name))
        if found is None:
            if self._fixed or isinstance(spec, str):
                raise BuildError(f"{self.where}: {in_out.lower()} {name!r} is not in the "
                                 f"group's declared interface")
            self._declare(spec, in_out)
            found = self._specs[(in_out, name)]
        elif not isinstance(spec, str) and found[0].type != spec.type:
            raise BuildError(f"{self.where}: {in_out.lower()} {name!r} used as a {spec.type}, "
                             f"declared as a {found[0].type}")
        self._used.add((in_out, name))
        return self._item(found[1])

    def declared_spec(self, socket):
        """The SocketSpec a Group Input socket was declared from."""
        for (in_out, _), (spec, identifier) in self._specs.items():
            if in_out == "INPUT" and identifier == socket.identifier:
                return spec
        raise BuildError(f"{self.where}: {socket.name!r} is not a declared input")

    def input(self, spec, kind=None, description=None, default=None, min_value=None,
              max_value=None, subtype=None, hide_value=False):
        """The Group Input socket of `spec`: a SocketSpec, or the name of a declared input. A
        group without a declared interface may instead give name, kind, description and
        settings."""
        if kind is not None:
            spec = SocketSpec(spec, kind, description, default, min_value, max_value, subtype,
                              hide_value)
        return self._group_socket(self.group_in.outputs, self._declared(spec, "INPUT"))

    def output(self, spec, *source_or_kind):
        """Feed the group output `spec` (a SocketSpec or a declared output's name) from a socket
        or constant: output(spec, source); or output(name, kind, source, description) in a
        group without a declared interface."""
        if len(source_or_kind) == 1:
            (source,) = source_or_kind
        else:
            kind, source, description = source_or_kind
            spec = SocketSpec(spec, kind, description)
        item = self._declared(spec, "OUTPUT")
        self.link(source, self._group_socket(self.group_out.inputs, item))

    def _group_socket(self, sockets, item):
        for s in sockets:
            if s.identifier == item.identifier:
                return s
        raise BuildError(f"{self.where}: the group node has no socket for {item.name!r}")

    def finish(self):
        unused = sorted(set(self._specs) - self._used)
        if unused:
            raise BuildError(f"{self.where}: declared but never used: {unused}")
        iface = self.tree.interface
        for it in list(iface.items_tree):
            if it.item_type == "SOCKET" and it.identifier not in self._wanted:
                _note_dropped_uses(self.tree, it)
                iface.remove(it)
        # Interface order: outputs first, then inputs, in the order they were declared.
        wanted = [self._item(i) for i in self._wanted]
        order = [w for w in wanted if w.in_out == "OUTPUT"] + \
                [w for w in wanted if w.in_out == "INPUT"]
        for position, identifier in enumerate([w.identifier for w in order]):
            iface.move(self._item(identifier), position)
        have = [it.identifier for it in iface.items_tree if it.item_type == "SOCKET"]
        if sorted(have) != sorted(self._wanted):
            raise BuildError(f"{self.where}: interface has {have}, expected {self._wanted}")
        bad = [f"{ln.from_node.name}.{ln.from_socket.name} -> {ln.to_node.name}."
               f"{ln.to_socket.name}" for ln in self.tree.links if not ln.is_valid]
        if bad:
            raise BuildError(f"{self.where}: invalid links {bad}")
        self._layout()

    # -- nodes -------------------------------------------------------------------------------
    @contextmanager
    def frame(self, label):
        """Nodes created inside belong to a frame titled `label` (a listing or equation)."""
        node = self.nodes.new("NodeFrame")
        node.label = label
        node.shrink = True
        outer, self._frame = self._frame, node
        try:
            yield node
        finally:
            self._frame = outer

    def node(self, bl_idname, label=None, **props):
        n = super().node(bl_idname, label, **props)
        if self._frame is not None:
            n.parent = self._frame
        return n

    # -- layout ------------------------------------------------------------------------------
    def _layout(self):
        """Columns by longest path from the inputs; tidy enough to read, no overlaps."""
        depth = {self.group_in: 0}
        nodes = [n for n in self.nodes if n.bl_idname != "NodeFrame"]
        for _ in range(len(nodes)):
            changed = False
            for link in self.links:
                a, b = link.from_node, link.to_node
                d = depth.get(a, 0) + 1
                if d > depth.get(b, 0):
                    depth[b] = d
                    changed = True
            if not changed:
                break
        last = max(depth.values(), default=0) + 1
        depth[self.group_out] = last
        rows = {}
        for n in nodes:
            col = depth.get(n, 0)
            row = rows.get(col, 0)
            rows[col] = row + 1
            n.location = (col * 220.0, -row * 170.0)


class GroupNodeInput(NamedTuple):
    """One group node's input as it was before a rebuild: where the node is, its value, and
    the socket linked into it (None when unlinked)."""
    owner: str                # "material 'Rock'" or "node group 'Mine'"
    node: bpy.types.Node
    value: object
    source: object


def _group_owners():
    """[(what it is, node tree)] of every node tree a group node can be in: materials', the
    World's (the Add menu puts groups there), lights' and line styles', and node groups (a
    World's SG Decal, a 4.5 file's, lost its Shape on 5.2: Cylinder became '', no note)."""
    owners = [(f"{kind} {o.name!r}", o.node_tree)
              for kind, data in (("material", bpy.data.materials), ("world", bpy.data.worlds),
                                 ("light", bpy.data.lights),
                                 ("line style", bpy.data.linestyles))
              for o in data if getattr(o, "node_tree", None) is not None]
    return owners + [(f"node group {g.name!r}", g) for g in bpy.data.node_groups]


def group_node_inputs(tree, identifier):
    """[GroupNodeInput] of input `identifier` on every group node of `tree` (in materials and
    node groups)."""
    found = []
    for owner, owner_tree in _group_owners():
        for node in owner_tree.nodes:
            if getattr(node, "node_tree", None) == tree:
                for s in node.inputs:
                    if s.identifier == identifier and hasattr(s, "default_value"):
                        source = s.links[0].from_socket if s.is_linked else None
                        found.append(GroupNodeInput(owner, node, s.default_value, source))
    return found


# What a rebuild could not carry over and the artist must hear of (a choice Blender cannot
# read here, a link it cannot keep): the operators report these as warnings (take_notes).
_NOTES = []


def take_notes():
    """The notes of the rebuilds since the last call (and forget them)."""
    notes = list(_NOTES)
    _NOTES.clear()
    return notes


# A driver's or keyframe's path names a node's input by its index:
# nodes["Decal"].inputs[4].default_value.
_INPUT_PATH = re.compile(r'nodes\["((?:[^"\\]|\\.)*)"\]\.inputs\[(\d+)\]')


def _driven_inputs(tree):
    """[(F-curve, group node, input identifier)] of the drivers (the decal projector's) and
    keyframes on the inputs of the group nodes using `tree`: a rebuild that adds, removes or
    moves an input changes the indices their paths hold."""
    found = []
    for _, owner in _group_owners():
        anim = owner.animation_data
        for fcurve in animated_fcurves(anim) if anim is not None else ():
            match = _INPUT_PATH.match(fcurve.data_path)
            node = match and owner.nodes.get(bpy.utils.unescape_identifier(match[1]))
            if node and getattr(node, "node_tree", None) == tree \
                    and int(match[2]) < len(node.inputs):
                found.append((fcurve, node, node.inputs[int(match[2])].identifier))
    return found


def _follow_drivers(driven):
    """Point each F-curve back at the input it animated (by identifier), wherever the rebuild
    put it; one whose input is gone is a note."""
    for fcurve, node, identifier in driven:
        index = next((i for i, s in enumerate(node.inputs) if s.identifier == identifier), None)
        match = _INPUT_PATH.match(fcurve.data_path)
        if index is None:
            _NOTES.append(f"{node.name!r} ({node.node_tree.name}): the input that "
                          f"{fcurve.data_path!r} animated is gone: remove that driver or "
                          f"keyframe")
        elif int(match[2]) != index:
            fcurve.data_path = (fcurve.data_path[:match.start(2)] + str(index)
                                + fcurve.data_path[match.end(2):])


def _note_dropped_uses(tree, item):
    """A note for each group node of `tree` whose link or value on socket `item` the rebuild
    drops with it (a socket the artist renamed in an older group, or one a newer version
    removed): never a silently different look."""
    for owner, owner_tree in _group_owners():
        for node in owner_tree.nodes:
            if getattr(node, "node_tree", None) != tree:
                continue
            sockets = node.inputs if item.in_out == "INPUT" else node.outputs
            socket = next((s for s in sockets if s.identifier == item.identifier), None)
            if socket is None:
                continue
            ends = [lk.from_node if item.in_out == "INPUT" else lk.to_node
                    for lk in socket.links]
            lost = [f"its link {'from' if item.in_out == 'INPUT' else 'to'} "
                    f"{', '.join(repr(n.name) for n in ends)}"] if ends else []
            default = getattr(item, "default_value", None)
            if not ends and default is not None and hasattr(socket, "default_value") \
                    and _plain(socket.default_value) != _plain(default):
                lost.append(f"its value {_plain(socket.default_value)}")
            if lost:
                _NOTES.append(f"{node.name!r} ({tree.name}) in {owner}: its "
                              f"{item.in_out.lower()} {item.name!r} is not one of the "
                              f"group's sockets now (renamed or added in the group?), so "
                              f"{' and '.join(lost)} went with it: check it")


def _plain(value):
    return value if isinstance(value, (str, int, float, bool)) else \
        tuple(round(v, 6) for v in value)


def _constant_behind(socket):
    """The value of a Value node that feeds `socket`'s link (through reroutes), else None."""
    node = socket.node
    while node.bl_idname == "NodeReroute" and node.inputs[0].is_linked:
        node = node.inputs[0].links[0].from_node
    return node.outputs[0].default_value if node.bl_idname == "ShaderNodeValue" else None


def _carry_choices(b, interface):
    """Each group node's choice from before its enumeration input changed type (an integer of
    an older surfgrad or line become a Menu on 5.0+, a Menu made on 5.0+ become the integer of
    4.5): the same item wherever it can be known, and otherwise a note naming the node: never
    a silently different look."""
    here = f"Blender {bpy.app.version_string}"
    for name, uses in b.retyped.items():
        spec = next((s for s in interface.inputs if s.name == name), None)
        if spec is None or not spec.items:
            continue
        names = spec.item_names()
        for use in uses:
            socket = use.node.inputs.get(name)
            if socket is None:
                continue
            where = f"{use.node.name!r} ({b.tree.name}) in {use.owner}"
            index, why = None, ""
            if isinstance(use.value, str):        # a Menu's item, if this line can read it
                if use.value in names:
                    index = names.index(use.value)
                else:
                    why = (f"its {name} menu (set on Blender 5.0 or later) cannot be read on "
                           f"{here}")
            else:
                index = use.value
                if use.source is not None:
                    given = _constant_behind(use.source)
                    if given is not None:
                        index = math.floor(given + 0.5)
                    why = (f"its {name} was linked from {use.source.node.name!r}, and a "
                           f"{socket.type.lower()} input cannot take that link on {here}")
                if not 0 <= index < len(names):
                    why = why or f"its {name} was {use.value}, no item's number"
                    index = None
            chosen = 0 if index is None else index
            socket.default_value = names[chosen] if socket.type == "MENU" else chosen
            if why:
                _NOTES.append(f"{where}: {why}; it is now {names[chosen]!r}: check it")


def interface_signature(tree):
    """Everything an artist sees of a group's interface, as plain data that compares equal
    across Blender lines: per socket its name, direction, type, subtype, default, range,
    tooltip and whether its value is hidden (5.1 and later report a subtyped vector as e.g.
    NodeSocketVectorDirection in bl_socket_idname; socket_type stays the base type)."""
    out = []
    for it in tree.interface.items_tree:
        if it.item_type != "SOCKET":
            continue
        row = {"name": it.name, "in_out": it.in_out, "type": it.socket_type,
               "description": it.description, "hide_value": it.hide_value}
        for key in ("subtype", "default_value", "min_value", "max_value"):
            if hasattr(it, key):
                row[key] = plain_value(getattr(it, key))
        out.append(row)
    return {"description": tree.description, "sockets": out}
