"""The UV maps an object's materials read besides the one baked, checked for NaN and Inf
before a bake (bake_request.mesh_problems, freeze.check), as the baked map is. A NaN in a second
UV map that a Normal Map node's tangents or a texture lookup read baked with exit 0 (red team
43b: 15 texels up to 5 degrees off through a Normal Map node, 4 texels up to 59 through an Image
Texture); so did one in the active render UV map, baking another, read by a Texture Coordinate
node's UV output, an Image Texture with its Vector unlinked or a UV Map node naming no map (red
team 44b: 20 texels up to 82 degrees off, each)."""

from ..reference import input_checks as IC
from .image_checks import objects_nodes


def _named_map(node):
    """The UV map node reads: its name, "" for the active render UV map, None for none."""
    kind = node.bl_idname
    if kind in ("ShaderNodeUVMap", "ShaderNodeNormalMap"):
        return node.uv_map if getattr(node, "space", "TANGENT") == "TANGENT" else None
    if kind == "ShaderNodeTangent":
        return node.uv_map if node.direction_type == "UV_MAP" else None
    if kind == "ShaderNodeAttribute":
        return node.attribute_name or None if node.attribute_type == "GEOMETRY" else None
    if kind == "ShaderNodeTexCoord":
        return "" if node.outputs["UV"].is_linked else None
    if kind == "ShaderNodeTexImage":          # an unlinked Vector looks up the render UVs
        return "" if node.image is not None and not node.inputs["Vector"].is_linked else None
    return None


def read_uv_maps(obj, only=None):
    """{UV map name: (material, node path, via the render map)} for the UV maps read by the
    nodes the object's materials (or material `only`) render through."""
    render = next((uv.name for uv in getattr(obj.data, "uv_layers", ()) if uv.active_render),
                  None)
    out = {}
    for mat, node, path, _ in objects_nodes(obj, only):
        name = _named_map(node)
        if name == "" and render:
            out.setdefault(render, (mat, path, True))
        elif name:
            out.setdefault(name, (mat, path, False))
    return out


def read_uv_map_problems(obj, triangle_uvs, baked_map, only=None):
    """A problem per UV map the materials read (read_uv_maps), other than baked_map, holding
    NaN or Inf in the mesh as it renders (triangle_uvs: {name: per-corner UVs})."""
    out = []
    for name, (mat, path, render) in read_uv_maps(obj, only).items():
        if name == baked_map or name not in triangle_uvs:
            continue
        how = " (as the active render UV map)" if render else ""
        problem = IC.finite_problem(
            f"the UVs of UV map {name!r} of object {obj.name!r}, which node {path!r} of "
            f"material {mat.name!r} reads{how},", triangle_uvs[name],
            "unwrap it again (UV > Unwrap) or remove it")
        if problem:
            out.append(problem)
    return out
