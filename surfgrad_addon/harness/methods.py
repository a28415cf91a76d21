"""The one registry of methods: every way of perturbing a normal that the bake-and-compare
pipeline, the stability suite and the command line know. A `Method` joins the method's bpy-free
part (reference/method_registry.py: variants, parameters, reference) to its node graph
(method_graphs/) and its scene set-up (method_scene.py).

    METHODS["normal-map"].at(strength=0.3)

is the method with SG Normal Map's Strength at 0.3 in its graph and strength=0.3 given to its
reference: one value for both sides. Importing this module needs no bpy (the main job's
reference stage runs without Blender); graphs, gates and scenes import the add-on when used.
"""

from dataclasses import dataclass

from ..reference.method_registry import SPECS, MethodSpec
# Re-exported for their callers (compare, far, main_job): the comparison's settings.
from ..reference.method_registry import (  # noqa: F401
    DECAL_FALLOFF, HEIGHT_BUMP_SCALE, NOISE_AMOUNT, NOISE_SCALE, PARALLAX_SCALE)

# The test images every method's graph and reference share (compare.prepare_inputs).
NORMAL_IMAGE_SIZE = 128
HEIGHT_IMAGE_SIZE = 32       # small: bakes magnify it, where the variants differ


def _group_interface(tree_name):
    """The group a node tree is built as: "SG Height Map HQ [sg_height]" is SG Height Map HQ
    for the image sg_height."""
    return tree_name.split(" [", 1)[0]


def set_parameter(g, method, parameter, value):
    """Set `parameter` (a method_registry.Parameter) to `value` on every node of its groups in
    graph g; a graph without one, or with the socket linked, is a BuildError."""
    from ..addon.node_builder import BuildError
    targets = [n for n in g.nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree
               and _group_interface(n.node_tree.name) in parameter.groups]
    if not targets:
        raise BuildError(f"method {method!r}: parameter {parameter.name!r} sets "
                         f"{parameter.socket!r} of {' or '.join(parameter.groups)}, which its "
                         f"graph does not have")
    for node in targets:
        socket = node.inputs[parameter.socket]
        if socket.is_linked:
            raise BuildError(f"method {method!r}: parameter {parameter.name!r} cannot set "
                             f"{node.node_tree.name}.{parameter.socket}: it is linked")
        g.link(value, socket)


def _bound_graph(spec, values):
    """graph(inp, nodes, links) -> socket: the method's graph with `values` set on it."""
    def graph(inp, nodes, links):
        from .graph import Graph
        from .method_graphs import GRAPHS
        g = Graph(nodes, links)
        out = GRAPHS[spec.name](inp, g)
        for parameter, (_, value) in zip(spec.parameters, values):
            set_parameter(g, spec.name, parameter, value)
        return out
    graph.__name__ = spec.name
    return graph


@dataclass(frozen=True)
class Method:
    spec: MethodSpec
    values: tuple          # (parameter name, value) for every parameter, in order

    name = property(lambda self: self.spec.name)
    variants = property(lambda self: self.spec.variants)
    parameters = property(lambda self: self.spec.parameters)
    group = property(lambda self: self.spec.group)
    stability = property(lambda self: self.spec.stability)
    scene_only = property(lambda self: self.spec.scene_only)
    mikktspace = property(lambda self: self.spec.mikktspace)
    same_reference_as = property(lambda self: self.spec.same_reference_as)
    spread = property(lambda self: self.spec.spread)
    reads = property(lambda self: self.spec.reads)

    def at(self, **given):
        """This method with the named parameters set (the others kept); an unknown name is a
        ValueError that lists the method's parameters."""
        return Method(self.spec, self.spec.values(**{**dict(self.values), **given}))

    @property
    def reference(self):
        """reference(inputs, td) -> (base normal, surface gradient), at this method's values."""
        return self.spec.bound_reference(self.values)

    @property
    def graph(self):
        """graph(inputs, nodes, links) -> socket: a surface gradient (resolved against the
        shading normal) or an already resolved "Normal", at this method's values."""
        return _bound_graph(self.spec, self.values)

    def unavailable_reason(self):
        """None when this Blender can run the method, else why not (docs/versions.md)."""
        if not self.spec.group:
            return None
        from ..addon import groups as G
        return G.unavailable_reason(self.spec.group)

    def scene(self, obj, inputs):
        """A context manager: the method's temporary scene additions for obj (a decal
        projector, an SG Displace modifier) set on inputs, removed afterwards."""
        from .method_scene import method_scene
        return method_scene(self.spec.adds, obj, inputs)


METHODS = {name: Method(spec, spec.values()) for name, spec in SPECS.items()}


def unavailable_reason(method):
    """None when `method` (a name) can run in this Blender, else why not."""
    return METHODS[method].unavailable_reason()


def cases():
    """(method, variant) for every method this Blender can run, each variant separately."""
    return [(m.name, v) for m in sorted(METHODS.values(), key=lambda m: m.name)
            if m.unavailable_reason() is None for v in m.variants]


def resolve_sg(nodes, links, surface_gradient):
    """SG Resolve of a surface-gradient socket, in the (nodes, links) form compare's build
    takes."""
    from .graph import Graph
    return Graph(nodes, links).resolve(surface_gradient)


# Scene set-up and the Sampler zone for callers that import them from here (demo, far,
# bench/render_cost): they need bpy, so they load when asked for.
_LATER = {"decal_projector": "method_scene", "add_displace_modifier": "method_scene",
          "sampler_socket": "method_graphs.samplers"}


def __getattr__(name):
    if name in _LATER:
        import importlib
        return getattr(importlib.import_module(f".{_LATER[name]}", __package__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
