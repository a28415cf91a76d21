"""Enumeration inputs of node groups (a SocketSpec of type MENU, reference/socket_specs.py):
a Menu socket feeding a Menu Switch where the line has them (5.0 and later), its integer
(0..N-1, the same order) feeding a chain of Mix nodes on older lines. Either way a constant
choice folds to the chosen branch alone in Cycles (tests/test_render_cost_folding.py).
`set_choice` sets a group node's enumeration by item index on every line."""

from .node_builder import BuildError, check_value
from .node_vocabulary import Math


def choose(b, selector, candidates):
    """candidates[k] (vector sockets or constants) for the item chosen on `selector`, a Group
    Input socket declared from an enumeration spec (a Menu, or its integer on older lines)."""
    spec = b.declared_spec(selector)
    count = len(spec.items) if spec.items else spec.max + 1     # the integer: 0..max
    if len(candidates) != count:
        raise BuildError(f"{b.where}: {spec.name!r} has {count} items, {len(candidates)} "
                         f"candidates given")
    if selector.type != "MENU":
        out = candidates[0]
        for index, candidate in enumerate(candidates[1:], start=1):
            out = b.mix_vector(b.math(Math.COMPARE, selector, float(index), 0.5), out, candidate)
        return out
    return menu_switch(b, selector, candidates)


def menu_switch(b, selector, candidates, data_type="VECTOR"):
    """A Menu Switch on `selector` (a Menu group input) with the spec's items, candidates[k]
    the k-th item's value; sets the Menu's default (the group nodes' earlier integers are
    carried over after the build: node_builder._carry_choices)."""
    spec = b.declared_spec(selector)
    switch = b.node("GeometryNodeMenuSwitch", data_type=data_type)
    items = switch.enum_items
    while len(items) < len(spec.items):
        items.new(spec.items[len(items)][0])
    for item, (name, tooltip) in zip(items, spec.items):
        item.name, item.description = name, tooltip
    if [i.name for i in items] != list(spec.item_names()):
        raise BuildError(f"{b.where}: Menu Switch items read back {[i.name for i in items]}")
    b.link(selector, switch.inputs["Menu"])
    for index, candidate in enumerate(candidates):
        b.link(candidate, switch.inputs[index + 1])
    item = b._item(selector.identifier)
    item.default_value = spec.default
    check_value(item.default_value, spec.default, f"{b.where}: {spec.name!r} default")
    return switch.outputs[0]


def menu_items(socket):
    """The item names of a group node's Menu input, in index order (from the Menu Switch the
    group's input feeds)."""
    tree = socket.node.node_tree
    for node in tree.nodes:
        if node.bl_idname != "NodeGroupInput":
            continue
        for out in node.outputs:
            if out.identifier == socket.identifier:
                for link in out.links:
                    if link.to_node.bl_idname == "GeometryNodeMenuSwitch":
                        return [i.name for i in link.to_node.enum_items]
    raise BuildError(f"{tree.name!r}: {socket.name!r} feeds no Menu Switch")


def choice_index(socket):
    """The item index a group node's enumeration input is set to (Menu or integer)."""
    if socket.type == "MENU":
        return menu_items(socket).index(socket.default_value)
    return socket.default_value


def set_choice(socket, index):
    """Set a group node's enumeration input to item `index`: the item's name on a Menu
    socket, the index on an integer one."""
    if socket.type == "MENU":
        socket.default_value = menu_items(socket)[index]
    else:
        socket.default_value = index
