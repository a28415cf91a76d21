"""The UV maps an object's materials read besides the one baked, checked for NaN and Inf
before a bake (bake_request.mesh_problems), as the baked map is. A NaN in a second UV map that a
Normal Map node's tangents or a texture lookup read baked with exit 0 (red team 43b: 15 texels
up to 5 degrees off through a Normal Map node, 4 texels up to 59 through an Image Texture)."""

from ..reference import input_checks as IC
from .image_checks import objects_nodes


def read_uv_maps(obj):
    """{UV map name: (material, node path)} for the UV maps named by the nodes the object's
    materials render through (an empty name is the active map, checked as the baked one)."""
    out = {}
    for mat, node, path, _ in objects_nodes(obj):
        name = ""
        if node.bl_idname in ("ShaderNodeUVMap", "ShaderNodeNormalMap"):
            name = node.uv_map if getattr(node, "space", "TANGENT") == "TANGENT" else ""
        elif node.bl_idname == "ShaderNodeTangent" and node.direction_type == "UV_MAP":
            name = node.uv_map
        elif node.bl_idname == "ShaderNodeAttribute" and node.attribute_type == "GEOMETRY":
            name = node.attribute_name
        if name:
            out.setdefault(name, (mat, path))
    return out


def read_uv_map_problems(obj, triangle_uvs, baked_map):
    """A problem per UV map the materials read (read_uv_maps), other than baked_map, holding
    NaN or Inf in the mesh as it renders (triangle_uvs: {name: per-corner UVs})."""
    out = []
    for name, (mat, path) in read_uv_maps(obj).items():
        if name == baked_map or name not in triangle_uvs:
            continue
        problem = IC.finite_problem(
            f"the UVs of UV map {name!r} of object {obj.name!r}, which node {path!r} of "
            f"material {mat.name!r} reads,", triangle_uvs[name],
            "unwrap it again (UV > Unwrap) or remove it")
        if problem:
            out.append(problem)
    return out
