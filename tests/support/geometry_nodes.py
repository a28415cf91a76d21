"""A Geometry Nodes group for a test to fill: Geometry in, Geometry out."""


def geometry_group(name):
    """(the new group, its Group Input node, its Group Output node)."""
    import bpy
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    for side in ("INPUT", "OUTPUT"):
        ng.interface.new_socket("Geometry", in_out=side, socket_type="NodeSocketGeometry")
    return ng, ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")


def set_material_group(material, name="Set Material"):
    """A new group whose Set Material node gives every face `material`."""
    ng, group_in, group_out = geometry_group(name)
    node = ng.nodes.new("GeometryNodeSetMaterial")
    node.inputs["Material"].default_value = material
    ng.links.new(group_in.outputs[0], node.inputs["Geometry"])
    ng.links.new(node.outputs[0], group_out.inputs[0])
    return ng
