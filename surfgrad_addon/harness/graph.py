"""The harness's node vocabulary for bake materials: NodeOps (the group builder's arithmetic) plus
the material helpers every method, bench scenario and demo exhibit uses."""

from contextlib import nullcontext

from ..addon import groups as G
from ..addon.enum_input import set_choice
from ..addon.node_builder import NodeOps
from ..addon.node_vocabulary import VMath

SURFACE_GRADIENT = "Surface Gradient"     # the output every SG group hands on


def surface_gradient(node):
    """A group node's Surface Gradient output."""
    return node.outputs[SURFACE_GRADIENT]


class Graph(NodeOps):
    """A bake material's node tree, with NodeOps' arithmetic and a few material helpers."""

    def __init__(self, nodes, links):
        self.nodes, self.links = nodes, links

    def group(self, tree, **inputs):
        """A group node of `tree`, its inputs linked or set by keyword (Bump_Scale: "Bump
        Scale")."""
        n = self.node("ShaderNodeGroup")
        n.node_tree = tree
        return self.set(n, **inputs)

    def set(self, node, **inputs):
        """Link sockets to, or set constants on, node's inputs by keyword; returns node. An
        enumeration takes its item index on every line (a Menu from 5.0, an integer before)."""
        for name, value in inputs.items():
            socket = node.inputs[name if name in node.inputs else name.replace("_", " ")]
            if socket.type == "MENU" and isinstance(value, int):
                set_choice(socket, value)
            else:
                self.link(value, socket)
        return node

    def frame(self, label):
        """The group builders' frames: a material built from their pieces gets none."""
        return nullcontext()

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
        return self.vmath(VMath.SUBTRACT, self.vmath(VMath.MULTIPLY, color, (2.0, 2.0, 2.0)),
                          (1.0, 1.0, 1.0))

    def perlin(self, normal, grad):
        """normalize(n - grad): Perlin's unprojected addition."""
        return self.vmath(VMath.NORMALIZE, self.vmath(VMath.SUBTRACT, normal, grad))

    def emission_material(self, color, displacement=None):
        """Material Output <- Emission(color, Strength 1) [and <- displacement]: what a bake
        reads back."""
        out = self.node("ShaderNodeOutputMaterial")
        emit = self.node("ShaderNodeEmission")
        self.set(emit, Color=color, Strength=1.0)
        self.link(emit.outputs["Emission"], out.inputs["Surface"])
        if displacement is not None:
            self.link(displacement, out.inputs["Displacement"])
        return out
