"""The harness's node vocabulary for bake materials: NodeOps (the group builder's arithmetic) plus
the material helpers every method, bench scenario and demo exhibit uses."""

from ..addon import groups as G
from ..addon.node_builder import NodeOps


class Graph(NodeOps):
    """A bake material's node tree, with NodeOps' arithmetic and a few material helpers."""

    def __init__(self, nodes, links):
        self.nodes, self.links = nodes, links

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
        return self.separate(v)[0]

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
