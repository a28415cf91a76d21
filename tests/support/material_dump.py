"""A full dump of a material (its nodes with every property and input value, its links, its
custom properties) and the file's images, to compare a material before and after an edit that
must leave it exactly as it was."""

SKIP = {"rna_type", "inputs", "outputs", "internal_links", "dimensions", "interface",
        "location_absolute"}


def _value(value):
    if hasattr(value, "name_full"):                 # an ID: by name
        return ("ID", value.name_full)
    if hasattr(value, "bl_rna"):                    # a nested struct: not compared
        return ("struct", type(value).__name__)
    if hasattr(value, "__len__") and not isinstance(value, str):
        try:
            return [round(v, 5) if isinstance(v, float) else v for v in value]
        except TypeError:
            return repr(value)
    return round(value, 5) if isinstance(value, float) else value


def _sockets(sockets):
    return [(s.identifier, s.name, s.hide, s.enabled,
             _value(s.default_value) if hasattr(s, "default_value") else None) for s in sockets]


def node_dump(node):
    props = {p.identifier: _value(getattr(node, p.identifier))
             for p in node.bl_rna.properties
             if p.identifier not in SKIP and p.type != "COLLECTION"}
    props["parent"] = node.parent.name if node.parent else None
    return {"props": props, "inputs": _sockets(node.inputs), "outputs": _sockets(node.outputs)}


def material_dump(mat):
    """Everything in `mat` an edit could change, as plain data (== compares it)."""
    import bpy
    tree = mat.node_tree
    return {
        "nodes": {n.name: node_dump(n) for n in tree.nodes},
        "active": tree.nodes.active.name if tree.nodes.active else None,
        "links": sorted((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name,
                         lk.to_socket.identifier, lk.is_muted) for lk in tree.links),
        "custom": sorted(mat.keys()),
        "images": sorted(i.name_full for i in bpy.data.images),
    }
