"""A small layer for building shader node groups by code, so that a builder reads like the
listing it implements:

    b = GroupBuilder(tree)
    n = b.input_normal()
    sg = b.input("Surface Gradient", "VECTOR", description="...")
    with b.frame("Listing 1: resolve"):
        b.output("Normal", "VECTOR", b.normalize(b.sub(n, sg)), description="...")

Arithmetic helpers take sockets or constants and return output sockets. `ensure_group` makes
building idempotent and versioned: a group that already has the current version is reused; an
older one is rebuilt in place (same datablock, same interface socket identifiers where the
socket still exists), so links from existing materials survive an add-on update.
"""

from contextlib import contextmanager

import bpy

from .node_vocabulary import VALUE_OPS, Math, VMath

VERSION_KEY = "surfgrad_version"
# The Blender line a group was built for: a few interiors differ by line (the interface never
# does), so a file saved on one line gets its groups rebuilt when used on another.
LINE_KEY = "surfgrad_line"


def running_line():
    """The facts of the running Blender's line (reference/blender_lines.py)."""
    from ..reference.blender_lines import facts_for
    return facts_for(bpy.app.version)


class BuildError(RuntimeError):
    """A socket, node, property or link that this Blender refused or changed: the message
    names the group and the part, so nothing is lost silently on any Blender line."""
SOCKET_TYPES = {"VECTOR": "NodeSocketVector", "FLOAT": "NodeSocketFloat",
                "COLOR": "NodeSocketColor", "BOOLEAN": "NodeSocketBool",
                "INT": "NodeSocketInt", "GEOMETRY": "NodeSocketGeometry",
                "CLOSURE": "NodeSocketClosure"}       # Closure: Blender 5.0 and later


def ensure_group(name, version, build, description, stale=None, tree_type="ShaderNodeTree"):
    """Return node group `name`, (re)building it with build(GroupBuilder) unless it already
    carries `version` (and `stale(tree)`, if given, is false: e.g. an image it references is
    gone). tree_type: "ShaderNodeTree" or "GeometryNodeTree"."""
    tree = bpy.data.node_groups.get(name)
    if tree is not None and tree.bl_idname != tree_type:
        raise ValueError(f"a {tree.bl_idname} named {name!r} already exists; rename it so the "
                         f"surface-gradient group can be created")
    if tree is not None and VERSION_KEY not in tree:
        # Ours carry the version stamp; a group without it is the user's: never rebuilt over.
        raise ValueError(f"a node group named {name!r} already exists and is not a "
                         f"surface-gradient group; rename it so surfgrad can add its own")
    line = running_line().line
    if (tree is not None and tree.get(VERSION_KEY) == version and tree.get(LINE_KEY) == line
            and not (stale and stale(tree))):
        return tree
    if tree is None:
        tree = bpy.data.node_groups.new(name, tree_type)
    tree.nodes.clear()
    tree.description = description
    builder = GroupBuilder(tree)
    build(builder)
    builder.finish()
    tree[VERSION_KEY] = version
    tree[LINE_KEY] = line
    return tree


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
        return self.vmath("ADD", a, b)

    def sub(self, a, b):
        return self.vmath("SUBTRACT", a, b)

    def scale(self, v, s):
        n = self.node("ShaderNodeVectorMath", operation="SCALE")
        self.link(v, n.inputs[0])
        self.link(s, n.inputs["Scale"])
        return n.outputs[0]

    def dot(self, a, b):
        return self.vmath("DOT_PRODUCT", a, b)

    def cross(self, a, b):
        return self.vmath("CROSS_PRODUCT", a, b)

    def normalize(self, v):
        return self.vmath("NORMALIZE", v)

    def length(self, v):
        return self.vmath("LENGTH", v)

    def separate(self, v):
        n = self.node("ShaderNodeSeparateXYZ")
        self.link(v, n.inputs[0])
        return n.outputs[0], n.outputs[1], n.outputs[2]

    def combine(self, x, y, z=0.0):
        n = self.node("ShaderNodeCombineXYZ")
        for slot, value in zip(n.inputs, (x, y, z)):
            self.link(value, slot)
        return n.outputs[0]

    def mix_vector(self, factor, a, b):
        """(1 - factor) a + factor b with a scalar factor."""
        n = self.node("ShaderNodeMix", data_type="VECTOR", clamp_factor=False)
        inputs = {s.identifier: s for s in n.inputs}
        self.link(factor, inputs["Factor_Float"])
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
        self.group_in = self.nodes.new("NodeGroupInput")
        self.group_out = self.nodes.new("NodeGroupOutput")

    # -- interface ---------------------------------------------------------------------------
    def _item(self, identifier):
        for it in self.tree.interface.items_tree:
            if it.item_type == "SOCKET" and it.identifier == identifier:
                return it
        raise BuildError(f"{self.where}: interface socket {identifier} vanished")

    def _socket(self, name, in_out, kind, description, default=None, min_value=None,
                max_value=None, subtype=None, hide_value=False):
        # Items are tracked by identifier: from Blender 5.1 setting a subtype replaces the
        # item's Python object (its type becomes e.g. ...VectorDirection).
        bl_type = SOCKET_TYPES[kind]
        what = f"{self.where}: {in_out.lower()} socket {name!r}"
        item = None
        for it in self.tree.interface.items_tree:
            if (it.item_type == "SOCKET" and it.name == name and it.in_out == in_out
                    and it.identifier not in self._wanted):
                item = it
                break
        if item is not None and item.socket_type != bl_type:
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

    def input(self, name, kind, description, default=None, min_value=None, max_value=None,
              subtype=None, hide_value=False):
        """A group input; returns its socket on the Group Input node."""
        item = self._socket(name, "INPUT", kind, description, default, min_value, max_value,
                            subtype, hide_value)
        return self._group_socket(self.group_in.outputs, item)

    def output(self, name, kind, source, description):
        """A group output fed by `source`."""
        item = self._socket(name, "OUTPUT", kind, description)
        self.link(source, self._group_socket(self.group_out.inputs, item))

    def _group_socket(self, sockets, item):
        for s in sockets:
            if s.identifier == item.identifier:
                return s
        raise BuildError(f"{self.where}: the group node has no socket for {item.name!r}")

    def finish(self):
        iface = self.tree.interface
        for it in list(iface.items_tree):
            if it.item_type == "SOCKET" and it.identifier not in self._wanted:
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


def interface_signature(tree):
    """Everything an artist sees of a group's interface, as plain data that compares equal
    across Blender lines: per socket its name, direction, type, subtype, default, range,
    tooltip and whether its value is hidden (5.1 and later report a subtyped vector as e.g.
    NodeSocketVectorDirection in bl_socket_idname; socket_type stays the base type)."""
    def plain(value):
        if hasattr(value, "__len__") and not isinstance(value, str):
            return [round(float(x), 6) for x in value]
        if isinstance(value, float):
            return round(value, 6)
        return value
    out = []
    for it in tree.interface.items_tree:
        if it.item_type != "SOCKET":
            continue
        row = {"name": it.name, "in_out": it.in_out, "type": it.socket_type,
               "description": it.description, "hide_value": it.hide_value}
        for key in ("subtype", "default_value", "min_value", "max_value"):
            if hasattr(it, key):
                row[key] = plain(getattr(it, key))
        out.append(row)
    return {"description": tree.description, "sockets": out}
