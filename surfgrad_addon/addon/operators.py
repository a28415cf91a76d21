"""Operators an artist reaches for: a surface-gradient layer stack on the active material,
Normal Map / Bump nodes converted to their SG equivalents, and a decal projector. Each is
undoable and reports what it did or why it could not. The work is in plain functions (usable
from scripts and tests); the operators wrap them.
"""

import math
import textwrap

import bpy
from bpy.props import EnumProperty, StringProperty

from ..reference.decals import CAPSULE_HALF_LENGTH, DECAL_SHAPES
from . import groups as G
from .enum_input import set_choice
from .material_inputs import edits_lost, linked_text, nodes_off_problem, render_output
from .node_vocabulary import Math
from .preview_links import previewed
from .all_or_nothing import all_or_nothing
from .group_updates import draw_stale_warning, report_notes, take_notes
from .far_precision import needs_precise_far, set_precise_far_on_node
from .node_builder import HoldsTree, checked_first

NORMAL_SOCKET = "Normal"


class SurfgradError(ValueError):
    """A request that cannot be carried out; the message says why and what to do."""


def _active_tree(context):
    obj = context.object
    if obj is None:
        raise SurfgradError("No active object: select the object whose material to edit")
    mat = obj.active_material
    if mat is None:
        raise SurfgradError(f"{obj.name!r} has no material: add one in the Material "
                            f"Properties first")
    if edits_lost(mat):
        raise SurfgradError(linked_text(repr(mat.name)))
    problem = nodes_off_problem(mat, "this edit")
    if problem:
        raise SurfgradError(problem)
    return mat, mat.node_tree


def tree_owner(tree):
    """The material whose node tree `tree` is, or None (a node group)."""
    return next((m for m in bpy.data.materials if m.node_tree == tree), None)


def require_editable(tree):
    """Refuse a node tree whose edits would be lost: linked from a library (a linked
    material's tree is too), or override data. Python may add nodes to such a tree, but the
    file never saves them."""
    owner = tree_owner(tree)
    if edits_lost(tree, owner):
        raise SurfgradError(linked_text(f"material {owner.name!r}" if owner is not None
                                         else f"node tree {tree.name!r}"))
    problem = owner is not None and nodes_off_problem(owner, "this edit")
    if problem:
        raise SurfgradError(problem)


def _is_world_tree(tree):
    """True for the nodes of a World, a light (the editor shows them in Object mode when the
    active object is a light) or a line style: no surface there to bump."""
    owners = (*bpy.data.worlds, *bpy.data.lights, *bpy.data.linestyles)
    return any(getattr(owner, "node_tree", None) == tree for owner in owners)


def material_editor_problem(context):
    """None where an operator on a material (a layer stack, a decal, Freeze, Thaw) can run in
    `context`, else why not: a node editor of another kind (a Geometry Nodes editor's F3 had
    them edit the active object's material, unseen), or a Shader Editor showing the World's
    or a line style's nodes (Freeze froze the active object's material from there). Elsewhere
    (the 3D Viewport, a script) they take the active object's material."""
    space = getattr(context, "space_data", None)
    if getattr(space, "type", None) != 'NODE_EDITOR':
        return None
    if getattr(space, "tree_type", None) != "ShaderNodeTree":
        return ("Works on a material: run it from a Shader Editor (or the 3D Viewport), not "
                "from this node editor")
    if space.shader_type != 'OBJECT':
        shown = {'WORLD': "the World's"}.get(space.shader_type, "a line style's")
        return (f"The Shader Editor shows {shown} nodes: this works on a material; switch the "
                f"editor to Object and show a material")
    return None


def material_poll(cls, context):
    problem = material_editor_problem(context)
    if problem:
        cls.poll_message_set(problem)
    return problem is None


def shown_tree(context):
    """The node tree to edit: the one the Shader Editor shows (pinned, or a group entered),
    else (no editor, or it shows nothing) the active object's active material. Raises
    SurfgradError where it makes no sense: the editor shows the World, a light or a line
    style."""
    space = getattr(context, "space_data", None)
    if space is not None and space.type == 'NODE_EDITOR' and \
            getattr(space, "tree_type", None) == "ShaderNodeTree":
        tree = space.edit_tree
        if space.shader_type != 'OBJECT' or (tree is not None and _is_world_tree(tree)):
            raise SurfgradError("The Shader Editor shows the World's (or a light's or a "
                                "line style's) nodes: layer stacks and decals go in a "
                                "material; switch the editor to Object and show a material")
        if tree is not None:
            require_editable(tree)
            return tree
    return _active_tree(context)[1]


def _prebuild(tree, *builders):
    """Check first: build (or reuse) every group an edit of `tree` needs before any node is
    made, all checked before any is rebuilt; a foreign group under one of our names raises
    ValueError here, with nothing added or changed, and so does `tree` being one of them or
    one they would rebuild (a group entered in the editor: Blender keeps a group out of
    itself, and a rebuild frees the nodes shown)."""
    try:
        return checked_first(*builders, outside=tree)
    except HoldsTree as err:
        raise SurfgradError(str(err)) from None


# The engines that render a material's nodes, as a Material Output's target names them (EEVEE
# is BLENDER_EEVEE_NEXT on 4.2 and 4.5, BLENDER_EEVEE from 5.0).
OUTPUT_TARGETS = {"CYCLES": "CYCLES", "BLENDER_EEVEE": "EEVEE", "BLENDER_EEVEE_NEXT": "EEVEE"}
TARGET_NAMES = {"CYCLES": "Cycles", "EEVEE": "EEVEE"}          # as the output's menu says


def _surface_shader(tree):
    """The node linked (through reroutes) to the Surface of the Material Output the scene's
    engine renders through (render_output; another engine: the active one), with a Normal
    input."""
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    target = OUTPUT_TARGETS.get(bpy.context.scene.render.engine)
    output = render_output(tree, target) if target else \
        next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None and outputs:
        raise SurfgradError(f"Every Material Output of the material is targeted at another "
                            f"engine than the scene's ({TARGET_NAMES[target]}): set one's "
                            f"target to All or {TARGET_NAMES[target]} (the menu on the node)")
    if output is None and tree_owner(tree) is None:     # a node group: no output of its own
        raise SurfgradError(f"The editor shows the inside of node group {tree.name!r}, which "
                            f"has no Material Output: the layer stack goes into a material's "
                            f"BSDF; leave the group (Tab) and add it to the material")
    if output is None or not output.inputs["Surface"].is_linked:
        raise SurfgradError("The material has no shader linked to its Material Output's "
                            "Surface: link a BSDF first")
    preview = previewed(tree, output)     # the stack would go into the previewed node
    if preview:
        raise SurfgradError(f"The material shows a preview: {preview}, then add the stack")
    shader = output.inputs["Surface"].links[0].from_node
    while shader.bl_idname == "NodeReroute" and shader.inputs[0].is_linked:   # pass-through
        shader = shader.inputs[0].links[0].from_node
    if NORMAL_SOCKET not in shader.inputs:
        raise SurfgradError(f"{shader.name!r} has no Normal input: link a BSDF (e.g. "
                            f"Principled BSDF) to the Material Output")
    return shader


def _group_node(tree, builder, location, label=None):
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = builder()
    node.location = location
    if label:
        node.label = label
    return node


def _into_frame(nodes, frame):
    """Put new nodes, placed relative to a node in `frame` (or None), in that frame: node
    locations are relative to their frame, and setting a parent keeps where a node is drawn,
    so each location goes back after."""
    for node in nodes:
        location = tuple(node.location)
        node.parent = frame
        node.location = location


def _replaced_uv_map(shader):
    """The UV map of the tangent-space Normal Map node (through reroutes) whose link into the
    shader's Normal the stack replaces, or "" (none, or one on the active render UV map)."""
    socket = shader.inputs[NORMAL_SOCKET]
    node = socket.links[0].from_node if socket.is_linked else None
    while node is not None and node.bl_idname == "NodeReroute":
        node = node.inputs[0].links[0].from_node if node.inputs[0].is_linked else None
    if node is None or node.bl_idname != "ShaderNodeNormalMap" or node.space != "TANGENT":
        return ""
    return node.uv_map


def add_layer_stack(tree, uv_map=""):
    """SG Normal Map -> SG Combine -> SG Resolve -> the surface shader's Normal. Returns the
    new nodes. An existing link into the shader's Normal is replaced (and reported). With no
    uv_map given, a replaced tangent-space Normal Map node's UV map is kept (a glTF import's
    normal map on its second UV map): the artist's map plugged into the stack is the one that
    node read, and on the active UV map it would turn with that map's tangents."""
    require_editable(tree)
    shader = _surface_shader(tree)
    kept = "" if uv_map else _replaced_uv_map(shader)
    uv_map = uv_map or kept
    _prebuild(tree, G.resolve_group, G.combine_group, lambda: G.normal_map_group(uv_map))
    x, y = shader.location
    replaced = shader.inputs[NORMAL_SOCKET].is_linked
    resolve = _group_node(tree, G.resolve_group, (x - 260, y - 420))
    combine = _group_node(tree, G.combine_group, (x - 520, y - 420))
    normal_map = _group_node(tree, lambda: G.normal_map_group(uv_map), (x - 780, y - 340))
    links = tree.links
    links.new(normal_map.outputs[0], combine.inputs["A"])
    links.new(combine.outputs[0], resolve.inputs["Surface Gradient"])
    links.new(resolve.outputs[0], shader.inputs[NORMAL_SOCKET])
    _into_frame((resolve, combine, normal_map), shader.parent)
    return {"resolve": resolve, "combine": combine, "normal_map": normal_map,
            "replaced": replaced, "uv_map": kept}


def convert_node(tree, node):
    """Replace a Normal Map (tangent space) or Bump node by its surface-gradient equivalent
    with the same look; the node's input and output links are carried over. Returns the
    SG Resolve node that now feeds what the old node fed."""
    links = tree.links
    require_editable(tree)
    if node.bl_idname not in ("ShaderNodeNormalMap", "ShaderNodeBump"):
        raise SurfgradError(f"{node.name!r} is a {node.bl_idname}: select a Normal Map or a "
                            f"Bump node to convert")
    if node.mute:            # the groups would not be muted: the look would change
        raise SurfgradError(f"{node.name!r} is muted: unmute it (M) to convert it, or "
                            f"delete it")
    width = node.inputs.get("Filter Width")
    if width is not None and width.is_linked:   # the group takes its width as a constant
        raise SurfgradError(f"{node.name!r} has a link into Filter Width, which the "
                            f"surface-gradient group takes as a value: remove the link and "
                            f"type the width, then convert")
    if node.bl_idname == "ShaderNodeNormalMap" and node.space != "TANGENT":
        raise SurfgradError(f"{node.name!r} is an {node.space.lower()}-space Normal Map: "
                            f"use SG Object Normal for object or world space maps")
    # Read now: the builders run twice (checked_first), and a node is not read after a build.
    uv_map = node.uv_map if node.bl_idname == "ShaderNodeNormalMap" else ""
    if node.bl_idname == "ShaderNodeNormalMap":
        _prebuild(tree, G.resolve_group, lambda: G.normal_map_group(uv_map))
    else:
        fw = node.inputs["Filter Width"].default_value if "Filter Width" in node.inputs else None
        strength = node.inputs["Strength"]
        blends = strength.is_linked or strength.default_value != 1.0
        _prebuild(tree, G.resolve_group, lambda: G.height_map_forward_group(fw),
                  *([G.bump_strength_group] if blends else []))
    outgoing = [lk.to_socket for lk in node.outputs["Normal"].links]
    x, y = node.location
    existing = set(tree.nodes)
    if node.bl_idname == "ShaderNodeNormalMap":
        sg = _group_node(tree, lambda: G.normal_map_group(uv_map), (x, y))
        _move_input(tree, node.inputs["Color"], sg.inputs["Color"])
        _move_input(tree, node.inputs["Strength"], sg.inputs["Strength"])
        # 5.2's Normal Map node has a convention; SG Normal Map's DirectX switch matches it.
        sg.inputs["DirectX"].default_value = getattr(node, "convention", "OPENGL") == "DIRECTX"
    else:
        # Same steps as the Bump node (its Filter Width, where the node has one): same look.
        fw = node.inputs["Filter Width"].default_value if "Filter Width" in node.inputs else None
        sg = _group_node(tree, lambda: G.height_map_forward_group(fw), (x, y))
        _move_input(tree, node.inputs["Height"], sg.inputs["Height"])
        _move_input(tree, node.inputs["Normal"], sg.inputs["Normal"])
        distance = node.inputs["Distance"]
        if distance.is_linked and node.invert:
            flip = tree.nodes.new("ShaderNodeMath")
            flip.operation = Math.MULTIPLY.value
            flip.location = (x - 180, y - 200)
            tree.links.new(distance.links[0].from_socket, flip.inputs[0])
            flip.inputs[1].default_value = -1.0
            tree.links.new(flip.outputs[0], sg.inputs["Bump Scale"])
        elif distance.is_linked:
            tree.links.new(distance.links[0].from_socket, sg.inputs["Bump Scale"])
        else:
            sg.inputs["Bump Scale"].default_value = (distance.default_value *
                                                     (-1 if node.invert else 1))
        strength = node.inputs["Strength"]
        if strength.is_linked or strength.default_value != 1.0:
            # The Bump node's Strength blends normals, not gradients: its own helper keeps it.
            blend = _group_node(tree, G.bump_strength_group, (x + 180, y - 160))
            tree.links.new(sg.outputs[0], blend.inputs["Surface Gradient"])
            _move_input(tree, strength, blend.inputs["Strength"])
            if sg.inputs["Normal"].is_linked:
                tree.links.new(sg.inputs["Normal"].links[0].from_socket, blend.inputs["Normal"])
            sg = blend
    resolve = _group_node(tree, G.resolve_group, (x + 220, y))
    links.new(sg.outputs[0], resolve.inputs["Surface Gradient"])
    if "Normal" in sg.inputs and sg.inputs["Normal"].is_linked:
        links.new(sg.inputs["Normal"].links[0].from_socket, resolve.inputs["Normal"])
    for socket in outgoing:
        links.new(resolve.outputs[0], socket)
    _into_frame([n for n in tree.nodes if n not in existing], node.parent)
    tree.nodes.remove(node)
    return resolve


def _move_input(tree, old, new):
    if old.is_linked:
        tree.links.new(old.links[0].from_socket, new)
    elif hasattr(old, "default_value") and hasattr(new, "default_value"):
        try:
            new.default_value = old.default_value
        except (TypeError, ValueError):
            pass


# The projector's own display, and outline empties parented to it where Blender has no such
# display: its empties draw a circle in their XZ plane and a cone along +Y (apex at y = 2), so
# rotated +90 degrees about X they outline the cylinder's ends and the cone (apex at z = +1,
# radius 1 at z = -1) of SG Decal's volume. Empties have no prism, so the wedge shows the cube it
# is cut from with an unrotated cone inside (apex at y = +1, base at y = -1), whose outline seen
# down the projection axis is the wedge's triangle; the capsule shows the unit spheres around
# its segment's ends, whose hull it is.
DECAL_DISPLAY = {"box": ("CUBE", ()), "sphere": ("SPHERE", ()),
                 "cylinder": ("SINGLE_ARROW", (("CIRCLE", (0.0, 0.0, 1.0)),
                                               ("CIRCLE", (0.0, 0.0, -1.0)))),
                 "cone": ("SINGLE_ARROW", (("CONE", (0.0, 0.0, -1.0)),)),
                 "wedge": ("CUBE", (("CONE", (0.0, -1.0, 0.0), 0.0),)),
                 "capsule": ("SINGLE_ARROW", (("SPHERE", (0.0, 0.0, CAPSULE_HALF_LENGTH)),
                                              ("SPHERE", (0.0, 0.0, -CAPSULE_HALF_LENGTH))))}


def add_decal_projector(context, tree, image=None, name="SG Decal Projector", shape="box"):
    """An empty at the 3D cursor whose display shows the projector's volume (`shape`: one of
    DECAL_SHAPES), and in `tree` the decal chain: Texture Coordinate (object = the
    empty) -> SG Projector Coordinates (driven by the empty; Precise Far From Origin on where the
    active object is far) -> SG Decal Coordinates -> Image Texture -> SG Decal (its Shape set),
    whose Axis X/Y are driven by the empty's rotation. Returns (empty, decal node)."""
    if shape not in DECAL_SHAPES:
        raise SurfgradError(f"decal shape {shape!r}: use one of {', '.join(DECAL_SHAPES)}")
    require_editable(tree)
    _prebuild(tree, G.projector_coordinates_group, G.decal_coordinates_group, G.decal_group)
    empty = bpy.data.objects.new(name, None)
    display, outlines = DECAL_DISPLAY[shape]
    empty.empty_display_type = display
    empty.location = context.scene.cursor.location
    collection = placing_collection(context)
    collection.objects.link(empty)
    for kind, offset, *tilt in outlines:           # tilt about X: 90 degrees unless given
        outline = bpy.data.objects.new(f"{name} ({shape} outline)", None)
        outline.empty_display_type = kind
        outline.parent = empty
        outline.location = offset
        outline.rotation_euler = (math.radians(tilt[0] if tilt else 90.0), 0.0, 0.0)
        outline.hide_select = True          # select and scale the projector, not its outline
        outline.hide_render = True
        collection.objects.link(outline)
    texco = tree.nodes.new("ShaderNodeTexCoord")
    texco.object = empty
    tc = _group_node(tree, G.projector_coordinates_group, (texco.location.x + 200,
                                                           texco.location.y))
    tree.links.new(texco.outputs["Object"], tc.inputs["Decal Coordinates"])
    drive_projector(tc, empty)
    set_precise_far_on_node(tc, needs_precise_far(getattr(context, "object", None)))
    coords = _group_node(tree, G.decal_coordinates_group, (tc.location.x + 200, tc.location.y))
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.extension = "CLIP"
    tex.location = (coords.location.x + 220, coords.location.y)
    decal = _group_node(tree, G.decal_group, (tex.location.x + 300, tex.location.y))
    set_choice(decal.inputs["Shape"], DECAL_SHAPES.index(shape))
    links = tree.links
    links.new(tc.outputs["Decal Coordinates"], coords.inputs[0])
    links.new(tc.outputs["Decal Coordinates"], decal.inputs["Decal Coordinates"])
    links.new(coords.outputs[0], tex.inputs["Vector"])
    links.new(tex.outputs["Color"], decal.inputs["Color"])
    for axis, column in (("Axis X", 0), ("Axis Y", 1)):
        drive_axis(decal.inputs[axis], empty, column)
    return empty, decal


def placing_collection(context):
    """Where Add Object puts a new object: the active collection (the one highlighted in the
    Outliner; the projector went in the Scene Collection, outside the artist's set), else the
    scene's own where that one cannot hold it (linked or override data: not saved; excluded
    from the view layer: the projector would be hidden and its drivers' matrix not
    evaluated)."""
    layer = getattr(getattr(context, "view_layer", None), "active_layer_collection", None)
    collection = getattr(layer, "collection", None)
    if collection is None or layer.exclude or collection.library is not None or \
            collection.override_library is not None or \
            collection not in context.scene.collection.children_recursive:
        return context.scene.collection
    return collection


# Rows of the inverse of a 3 x 3 matrix (a b c / d e f / g h i) by cofactors over the
# determinant: simple expressions, which drivers run without auto-run Python scripts.
# A division by zero would mark the driver invalid for good (Blender evaluates it no more,
# even once the scale is back), so a projector scaled to zero on an axis gets the inverse of a
# tiny one instead (ZERO_SIZE_INVERSE on the diagonal): it covers nothing until it grows again.
_DET = "(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g))"
ZERO_SIZE_INVERSE = 1e6
_INVERSE_ROWS = (("e * i - f * h", "c * h - b * i", "b * f - c * e"),
                 ("f * g - d * i", "a * i - c * g", "c * d - a * f"),
                 ("d * h - e * g", "b * g - a * h", "a * e - b * d"))


def drive_projector(node, obj):
    """Drive SG Projector Coordinates' inputs with obj's world location and the rows of its
    world-to-local 3 x 3 matrix (RNA indexes matrices column first: [column][row])."""
    for i in range(3):
        drv = node.inputs["Projector Location"].driver_add("default_value", i).driver
        drv.type = "SCRIPTED"
        var = drv.variables.new()
        var.name, var.type = "t", "SINGLE_PROP"
        var.targets[0].id = obj
        var.targets[0].data_path = f"matrix_world[3][{i}]"
        drv.expression = "t"
    for axis, row in zip("XYZ", _INVERSE_ROWS):
        for i, cofactor in enumerate(row):
            drv = node.inputs[f"To Projector {axis}"].driver_add("default_value", i).driver
            drv.type = "SCRIPTED"
            for k, name in enumerate("abcdefghi"):
                var = drv.variables.new()
                var.name, var.type = name, "SINGLE_PROP"
                var.targets[0].id = obj
                var.targets[0].data_path = f"matrix_world[{k % 3}][{k // 3}]"
            fallback = ZERO_SIZE_INVERSE if i == "XYZ".index(axis) else 0.0
            drv.expression = f"({cofactor}) / {_DET} if {_DET} != 0 else {fallback:g}"


def drive_axis(socket, obj, column):
    """Drive a vector socket with the unit world direction of obj's local axis `column`
    (simple expressions only, so they run without auto-run Python scripts); zero while the
    axis is scaled to zero (a division by zero would stop the driver for good)."""
    names = "abc"
    for i in range(3):
        fcurve = socket.driver_add("default_value", i)
        drv = fcurve.driver
        drv.type = "SCRIPTED"
        for row, var_name in enumerate(names):
            var = drv.variables.new()
            var.name = var_name
            var.type = "SINGLE_PROP"
            var.targets[0].id = obj
            # RNA indexes matrices column first: [column][row].
            var.targets[0].data_path = f"matrix_world[{column}][{row}]"
        drv.expression = (f"{names[i]} / sqrt(a * a + b * b + c * c) "
                          f"if a * a + b * b + c * c > 0 else 0")


# Operators ------------------------------------------------------------------------------------

class SURFGRAD_OT_add_layer_stack(bpy.types.Operator):
    """Add a surface-gradient layer stack to the active material: SG Normal Map into SG Combine \
into SG Resolve, wired into the BSDF's Normal"""
    bl_idname = "surfgrad.add_layer_stack"
    bl_label = "Add Surface-Gradient Layer Stack"
    bl_options = {'REGISTER', 'UNDO'}

    uv_map: StringProperty(name="UV Map", description="UV map of the normal map (empty: that of "
                           "the Normal Map node whose link it replaces, else the active render "
                           "UV map)", default="")

    poll = classmethod(material_poll)

    def execute(self, context):
        take_notes()
        try:
            tree = shown_tree(context)
            with all_or_nothing(tree):
                made = add_layer_stack(tree, self.uv_map)
        except (ValueError, RuntimeError) as err:      # SurfgradError, a foreign group
            self.report({'ERROR'}, str(err))
            report_notes(self)
            return {'CANCELLED'}
        note = " (replaced the previous link into Normal)" if made["replaced"] else ""
        if made["uv_map"]:
            note += (f"; SG Normal Map reads UV map {made['uv_map']!r}, as the replaced Normal "
                     f"Map node did")
        self.report({'INFO'}, f"Added SG Normal Map, SG Combine and SG Resolve{note}; link "
                              f"your normal map image into SG Normal Map's Color")
        report_notes(self)
        return {'FINISHED'}


class SURFGRAD_OT_convert_node(bpy.types.Operator):
    """Replace the active Normal Map or Bump node by its surface-gradient equivalent with the \
same look (links are kept)"""
    bl_idname = "surfgrad.convert_node"
    bl_label = "Convert to Surface Gradient"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        space = context.space_data
        if space is None or getattr(space, "tree_type", None) != "ShaderNodeTree" or \
                space.edit_tree is None:
            cls.poll_message_set("Works in a Shader Editor with a node tree")
            return False
        return True

    def execute(self, context):
        tree = context.space_data.edit_tree
        node = tree.nodes.active
        if node is None:
            self.report({'ERROR'}, "No active node: click a Normal Map or Bump node first")
            return {'CANCELLED'}
        kind = node.bl_label
        take_notes()
        try:
            with all_or_nothing(tree):
                convert_node(tree, node)
        except (ValueError, RuntimeError) as err:      # SurfgradError, a foreign group
            self.report({'ERROR'}, str(err))
            report_notes(self)
            return {'CANCELLED'}
        self.report({'INFO'}, f"Converted the {kind} node to surface gradients")
        report_notes(self)
        return {'FINISHED'}


class SURFGRAD_OT_add_decal_projector(bpy.types.Operator):
    """Add a decal projector (an empty at the 3D cursor) and its SG Decal chain to the active \
material; the decal's axes follow the empty"""
    bl_idname = "surfgrad.add_decal_projector"
    bl_label = "Add Decal Projector"
    bl_options = {'REGISTER', 'UNDO'}

    image: StringProperty(name="Image", description="Decal normal map (an image in this file)",
                          default="")
    shape: EnumProperty(
        name="Shape", description="The projector's volume (SG Decal's Shape)", default="box",
        items=(("box", "Box", "Projects the whole image square; fades toward the near and "
                "far faces"),
               ("sphere", "Sphere", "A round decal fading toward the ball's surface"),
               ("cylinder", "Cylinder", "A round decal along the projection axis, fading "
                "toward its side and ends"),
               ("cone", "Cone", "Narrows toward the projector (apex at +Z), fading toward its "
                "side and ends"),
               ("wedge", "Wedge", "A triangular decal (apex at +Y) along the projection axis, "
                "fading toward its sloped sides and ends"),
               ("capsule", "Capsule", "A round decal along the projection axis with rounded "
                "ends, fading by the distance to its axis segment")))

    poll = classmethod(material_poll)

    def execute(self, context):
        take_notes()
        try:
            tree = shown_tree(context)
            image = bpy.data.images.get(self.image) if self.image else None
            if self.image and image is None:
                raise SurfgradError(f"No image named {self.image!r} in this file: open it "
                                    f"first (Image > Open)")
            with all_or_nothing(tree):
                empty, _ = add_decal_projector(context, tree, image, shape=self.shape)
        except (ValueError, RuntimeError) as err:      # SurfgradError, a foreign group
            self.report({'ERROR'}, str(err))
            report_notes(self)
            return {'CANCELLED'}
        self.report({'INFO'}, f"Added {empty.name!r} ({self.shape}): scale it to size the "
                              f"decal; link your surface gradients into SG Decal's Base "
                              f"Gradient (add or overwrite)")
        report_notes(self)
        return {'FINISHED'}


class NODE_PT_surfgrad(bpy.types.Panel):
    """Surface-gradient tools in the Shader Editor's sidebar"""
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "Surface Gradient"
    bl_label = "Surface Gradient"

    @classmethod
    def poll(cls, context):
        return getattr(context.space_data, "tree_type", None) == "ShaderNodeTree"

    def draw(self, context):
        col = self.layout.column(align=True)
        col.operator(SURFGRAD_OT_add_layer_stack.bl_idname, icon="NODETREE")
        col.operator(SURFGRAD_OT_convert_node.bl_idname, icon="FILE_REFRESH")
        col.operator(SURFGRAD_OT_add_decal_projector.bl_idname, icon="MOD_UVPROJECT")
        col.operator("surfgrad.freeze_stack", icon="FREEZE")      # freeze_operators.py
        col.operator("surfgrad.thaw_stack", icon="FILE_REFRESH")
        col.operator("surfgrad.update_groups", icon="FILE_REFRESH")   # group_updates.py
        draw_stale_warning(self.layout, context)
        draw_far_warning(self.layout, context)
        draw_muted_layer_warning(self.layout, context)


def _warning_box(layout, text):
    """A boxed warning under the tools, wrapped to the sidebar; nothing for ''."""
    if text:
        box = layout.box()
        for i, line in enumerate(textwrap.wrap(text, 38, break_on_hyphens=False)):
            box.label(text=line, icon="ERROR" if i == 0 else "BLANK1")


def draw_muted_layer_warning(layout, context):
    """A muted SG layer with its Normal linked tilts the surface: say so, with the fix."""
    from .muted_layers import muted_layer_warning
    text = muted_layer_warning(getattr(getattr(context, "space_data", None), "edit_tree", None))
    _warning_box(layout, text)


def draw_far_warning(layout, context):
    """Far from the origin, renders lose precision: say so under the tools, with the fix."""
    from .precise_bake import render_precision_warning
    text = render_precision_warning(getattr(context, "object", None))
    _warning_box(layout, text)


CLASSES = (SURFGRAD_OT_add_layer_stack, SURFGRAD_OT_convert_node,
           SURFGRAD_OT_add_decal_projector, NODE_PT_surfgrad)
