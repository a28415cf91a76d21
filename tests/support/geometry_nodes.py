"""A Geometry Nodes group for a test to fill: Geometry in, Geometry out."""


def geometry_group(name):
    """(the new group, its Group Input node, its Group Output node)."""
    import bpy
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    for side in ("INPUT", "OUTPUT"):
        ng.interface.new_socket("Geometry", in_out=side, socket_type="NodeSocketGeometry")
    return ng, ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
