"""Operators are all-or-nothing: what an edit added before it failed is taken away again.

The operators check first (their groups are built before any node or object is made), so this
is the backstop for what a check cannot foresee: on any exception the nodes added to the tree,
the objects and node groups added to the file and the drivers added to the tree are removed,
the tree's links an edit replaced (a new link into an input takes the old one's place) are
made again, its nodes' selection is put back, and the exception goes on to the operator,
which reports it.
"""

from contextlib import contextmanager


def _links(tree):
    return {(lk.from_node.name, lk.from_socket.identifier, lk.to_node.name,
             lk.to_socket.identifier) for lk in tree.links}


def _relink(tree, links):
    """Make again each of `links` that is gone while its nodes and sockets are still there."""
    for from_node, from_id, to_node, to_id in links - _links(tree):
        source, target = tree.nodes.get(from_node), tree.nodes.get(to_node)
        output = source and next((s for s in source.outputs if s.identifier == from_id), None)
        socket = target and next((s for s in target.inputs if s.identifier == to_id), None)
        if output is not None and socket is not None:
            tree.links.new(output, socket)


def _drivers(tree):
    anim = tree.animation_data
    return set() if anim is None else {(d.data_path, d.array_index) for d in anim.drivers}


@contextmanager
def all_or_nothing(tree=None):
    import bpy
    nodes = None if tree is None else {n.name for n in tree.nodes}
    had_anim = tree is not None and tree.animation_data is not None
    drivers = set() if tree is None else _drivers(tree)
    links = set() if tree is None else _links(tree)
    selected = None if tree is None else {n.name: n.select for n in tree.nodes}
    active = None if tree is None or tree.nodes.active is None else tree.nodes.active.name
    objects = {o.name_full for o in bpy.data.objects}
    groups = {g.name_full for g in bpy.data.node_groups}
    try:
        yield
    except BaseException:
        if tree is not None:
            anim = tree.animation_data
            if anim is not None and not had_anim:
                tree.animation_data_clear()
            elif anim is not None:
                for d in [d for d in anim.drivers
                          if (d.data_path, d.array_index) not in drivers]:
                    anim.drivers.remove(d)
            for node in [n for n in tree.nodes if n.name not in nodes]:
                tree.nodes.remove(node)
            _relink(tree, links)
            for node in tree.nodes:
                node.select = selected.get(node.name, node.select)
            if active is not None and active in tree.nodes:
                tree.nodes.active = tree.nodes[active]
        for obj in [o for o in bpy.data.objects if o.name_full not in objects]:
            bpy.data.objects.remove(obj, do_unlink=True)
        for group in [g for g in bpy.data.node_groups if g.name_full not in groups]:
            bpy.data.node_groups.remove(group)
        raise
