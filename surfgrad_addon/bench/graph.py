"""A few helpers for building a bake material's node graph by code (the bench's methods)."""

import bpy

from ..blender import groups as G


class Graph:
    def __init__(self, nodes, links):
        self.nodes, self.links = nodes, links

    def node(self, bl_idname, **props):
        n = self.nodes.new(bl_idname)
        for key, value in props.items():
            setattr(n, key, value)
        return n

    def link(self, source, target):
        if isinstance(source, bpy.types.NodeSocket):
            self.links.new(source, target)
        elif source is not None:
            target.default_value = source

    def _op(self, idname, op, inputs, output=0):
        n = self.node(idname, operation=op)
        for slot, value in zip([s for s in n.inputs if s.enabled], inputs):
            self.link(value, slot)
        return n.outputs[output]

    def vmath(self, op, *inputs):
        return self._op("ShaderNodeVectorMath", op, inputs,
                        1 if op in ("DOT_PRODUCT", "LENGTH") else 0)

    def math(self, op, *inputs):
        return self._op("ShaderNodeMath", op, inputs)

    def scale(self, v, s):
        n = self.node("ShaderNodeVectorMath", operation="SCALE")
        self.link(v, n.inputs[0])
        self.link(s, n.inputs["Scale"])
        return n.outputs[0]

    def group(self, tree, **inputs):
        n = self.node("ShaderNodeGroup")
        n.node_tree = tree
        for name, value in inputs.items():
            self.link(value, n.inputs[name if name in n.inputs else name.replace("_", " ")])
        return n

    def uv(self, name):
        return self.node("ShaderNodeUVMap", uv_map=name).outputs["UV"]

    def image(self, image, vector, interpolation="Linear", extension="REPEAT",
              projection="FLAT"):
        n = self.node("ShaderNodeTexImage", interpolation=interpolation, extension=extension,
                      projection=projection)
        n.image = image
        self.link(vector, n.inputs["Vector"])
        return n.outputs["Color"]

    def first(self, v):
        """The x (red) component of a vector or colour."""
        n = self.node("ShaderNodeSeparateXYZ")
        self.link(v, n.inputs[0])
        return n.outputs[0]

    def geometry(self, output):
        return self.node("ShaderNodeNewGeometry").outputs[output]

    def resolve(self, surface_gradient, normal=None):
        n = self.group(G.resolve_group(), Surface_Gradient=surface_gradient)
        if normal is not None:
            self.link(normal, n.inputs["Normal"])
        return n.outputs["Normal"]

    def decode(self, color):
        """m = 2 c - 1."""
        return self.vmath("SUBTRACT", self.vmath("MULTIPLY", color, (2.0, 2.0, 2.0)),
                          (1.0, 1.0, 1.0))

    def perlin(self, normal, grad):
        """normalize(n - grad): Perlin's unprojected addition."""
        return self.vmath("NORMALIZE", self.vmath("SUBTRACT", normal, grad))
