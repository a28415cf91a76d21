"""Cycles' own MikkTSpace frame against the reference's, texel by texel (bpy).

Cycles' UV tangent (the Tangent node, UV map; svm_node_tangent takes it perpendicular to N)
is baked and compared with the reference's MikkTSpace tangent on the render mesh, made
perpendicular to the shading normal the same way, on every texel both cover off triangle
edges."""

import numpy as np


def tangent_errors(obj, uv_map, res):
    """(angles in degrees of Cycles' tangent against the reference's, texel mask (N,) of the
    texels compared, the reference's TexelData) at res x res."""
    from surfgrad_addon.harness import bake as B
    from surfgrad_addon.harness.mesh_data import mesh_arrays_from_object
    from surfgrad_addon.reference import rasterize
    from surfgrad_addon.reference.agreement import angle_deg

    def tangent(nodes, links):
        node = nodes.new("ShaderNodeTangent")
        node.direction_type = "UV_MAP"
        node.uv_map = uv_map
        return node.outputs["Tangent"]
    px, cov, _ = B.bake_vector(obj, tangent, res, res, uv_map)
    td = rasterize(mesh_arrays_from_object(obj), uv_map, res, res, facts=B.running_line())
    t, _ = td.tangent(uv_map)
    n = td.shading_normal
    c = np.cross(t, n)
    expected = np.cross(n, c / np.linalg.norm(c, axis=1, keepdims=True))
    x, y = td.pixel[:, 0], td.pixel[:, 1]
    use = cov[y, x] & ~td.on_edge[y, x]
    return angle_deg(px[y, x][use], expected[use]), use, td
