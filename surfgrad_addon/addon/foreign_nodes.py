"""Nodes in an object's materials that this Blender cannot evaluate, in a file made on a newer
line: 4.5 reads 5.0's Evaluate Closure as an undefined node, and keeps a Menu Switch in a shader
group (surfgrad's choices on 5.0+) that its shader trees cannot have. Cycles drops either and
bakes as if its output were zero, a different look with no error, so the bake is refused
(bake_request.py), naming the material, the group and the fix."""

from ..reference.blender_lines import facts_for
from .image_checks import checked_materials

MENU_SWITCH = "GeometryNodeMenuSwitch"


def _cannot_evaluate(node, menus):
    if not any(out.is_linked for out in node.outputs):
        return False                     # feeds nothing: the look does not depend on it
    return node.bl_idname == "NodeUndefined" or (node.bl_idname == MENU_SWITCH and not menus)


def foreign_node_problems(obj, only=None):
    """A sentence per material of `obj` (or material `only`: Freeze's) using a node this
    Blender cannot evaluate (at any depth of node groups)."""
    import bpy                 # not at import: the CLI imports bake_request without Blender
    menus = facts_for(bpy.app.version).menu_sockets
    here = f"Blender {bpy.app.version_string}"
    problems = []
    for mat in checked_materials(obj, only):
        if mat.node_tree is None:
            continue
        found, seen, trees = [], set(), [(mat.node_tree, None)]
        while trees:
            tree, group = trees.pop()
            for node in tree.nodes:
                sub = getattr(node, "node_tree", None)
                if sub is not None and sub.name_full not in seen:
                    seen.add(sub.name_full)
                    trees.append((sub, sub))
                elif _cannot_evaluate(node, menus):
                    where = f" in node group {group.name!r}" if group is not None else ""
                    found.append(f"{node.name!r}{where}")
        if found:
            problems.append(
                f"material {mat.name!r} uses node(s) {', '.join(sorted(found))} that {here} "
                f"cannot evaluate (the file was made on a newer Blender): Cycles would bake "
                f"them as zero. Bake on the Blender line the file was made with, or open it "
                f"here, run Update surfgrad Groups (Shader Editor > Add > Surface Gradient), "
                f"set again the choices it names, and save")
    return sorted(problems)
