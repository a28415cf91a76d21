"""The one registry of methods: every way of perturbing a normal that the bake-and-compare
pipeline, the stability suite and the command line know, each a `Method` with its node graph
(what Cycles bakes), its reference (what the numpy evaluator computes on the same texels), its
variants, the gated group it needs, and the scene set-up it brings (a decal projector, an SG
Displace modifier) as a context manager.

A graph is graph(inputs, nodes, links) -> a surface-gradient socket (resolved against the shading
normal) or an already resolved "Normal" socket; a reference is reference(inputs, td) ->
(base normal, surface gradient) on the texels of td.
"""

import importlib
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from .. import reference as R
from ..reference import methods as M


class _OnFirstUse:
    """A module imported when first used: the registry's names and references need no bpy
    (the main job's reference stage runs without Blender); graphs and gates import it."""

    def __init__(self, name):
        self._name, self._module = name, None

    def __getattr__(self, attr):
        if self._module is None:
            self._module = importlib.import_module(self._name, __package__)
        return getattr(self._module, attr)


# The test images every method's graph and reference share (compare.prepare_inputs).
NORMAL_IMAGE_SIZE = 128
HEIGHT_IMAGE_SIZE = 32       # small: bakes magnify it, where the variants differ

G = _OnFirstUse("..addon.groups")
compat = _OnFirstUse("..addon.compat")
_graph = _OnFirstUse(".graph")


def Graph(nodes, links):  # noqa: N802 (the class, imported on first use)
    return _graph.Graph(nodes, links)


# Node-graph helpers: the harness's one vocabulary (graph.Graph, on the builder's NodeOps) in
# the (nodes, links) form the method graphs take -------------------------------------------------

def group_node(nodes, tree):
    return Graph(nodes, None).group(tree)


def image_node(nodes, links, image, vector, interpolation="Linear", extension="REPEAT"):
    return Graph(nodes, links).image(image, vector, interpolation, extension)


def uv_node(nodes, uv_map):
    return Graph(nodes, None).uv(uv_map)


def resolve_sg(nodes, links, surface_gradient):
    return Graph(nodes, links).resolve(surface_gradient)


def add_vectors(nodes, links, a, b):
    return Graph(nodes, links).add(a, b)


# Methods: (node graph, reference) pairs -------------------------------------------------------

def normal_map_graph(inp, nodes, links, image="normal", strength=1.0):
    color = image_node(nodes, links, inp.bpy_image(image), uv_node(nodes, inp.uv_map))
    node = group_node(nodes, G.normal_map_group(inp.uv_map))
    links.new(color, node.inputs["Color"])
    node.inputs["Strength"].default_value = strength
    return node.outputs["Surface Gradient"]


def _procedural_basis_graph(inp, nodes, links, image="detail", strength=1.0):
    uv = uv_node(nodes, inp.detail_uv)
    basis = group_node(nodes, G.procedural_basis_group())
    links.new(uv, basis.inputs["UV"])
    color = image_node(nodes, links, inp.bpy_image(image), uv)
    tn = group_node(nodes, G.tangent_normal_group())
    links.new(color, tn.inputs["Color"])
    links.new(basis.outputs["Tangent"], tn.inputs["Tangent"])
    links.new(basis.outputs["Bitangent"], tn.inputs["Bitangent"])
    tn.inputs["Strength"].default_value = strength
    return tn.outputs["Surface Gradient"]


def _object_normal_vector_graph(inp, nodes, links):
    """v = (2 c - 1) + 2 N: an arbitrary front-facing world-space normal from an image."""
    color = image_node(nodes, links, inp.bpy_image("normal"), uv_node(nodes, inp.uv_map))
    m = nodes.new("ShaderNodeVectorMath")
    m.operation = "MULTIPLY"
    links.new(color, m.inputs[0])
    m.inputs[1].default_value = (2.0, 2.0, 2.0)
    s = nodes.new("ShaderNodeVectorMath")
    s.operation = "SUBTRACT"
    links.new(m.outputs[0], s.inputs[0])
    s.inputs[1].default_value = (1.0, 1.0, 1.0)
    geo = nodes.new("ShaderNodeNewGeometry")
    n2 = nodes.new("ShaderNodeVectorMath")
    n2.operation = "SCALE"
    links.new(geo.outputs["Normal"], n2.inputs[0])
    n2.inputs["Scale"].default_value = 2.0
    return add_vectors(nodes, links, s.outputs[0], n2.outputs[0])


def _object_normal_graph(inp, nodes, links):
    node = group_node(nodes, G.object_normal_group())
    links.new(_object_normal_vector_graph(inp, nodes, links), node.inputs["Perturbed Normal"])
    return node.outputs["Surface Gradient"]


def _object_normal_reference(inp, td):
    n = M.unit_base_normal(td)
    v = M.decode_normal_map(R.sample_image(inp.pixels("normal"), td.uv(inp.uv_map))) + 2 * n
    return n, R.surfgrad_from_perturbed_normal(n, v)


NOISE_SCALE, NOISE_AMOUNT = 4.0, 0.05


def _noise_gradient_graph(nodes, links, turbulence=False):
    noise = group_node(nodes, G.noise_group())
    noise.inputs["Scale"].default_value = NOISE_SCALE
    noise.inputs["Octaves"].default_value = 4
    noise.inputs["Turbulence"].default_value = turbulence
    return noise.outputs["Gradient"]


def _volume_noise_graph(inp, nodes, links, amount=NOISE_AMOUNT):
    vg = group_node(nodes, G.volume_gradient_group())
    links.new(_noise_gradient_graph(nodes, links), vg.inputs["Gradient"])
    vg.inputs["Strength"].default_value = amount
    return vg.outputs["Surface Gradient"]


def triplanar_graph(inp, nodes, links, image="normal"):
    coords = group_node(nodes, G.triplanar_coordinates_group())
    tri = group_node(nodes, G.triplanar_group())
    for axis in "XYZ":
        color = image_node(nodes, links, inp.bpy_image(image), coords.outputs[f"UV {axis}"])
        links.new(color, tri.inputs[f"Color {axis}"])
    return tri.outputs["Surface Gradient"]


def _triplanar_height_graph(inp, nodes, links):
    node = group_node(nodes, G.triplanar_height_group(inp.bpy_image("height")))
    node.inputs["Bump Scale"].default_value = HEIGHT_BUMP_SCALE
    return node.outputs["Surface Gradient"]


DECAL_FALLOFF = 0.2


def decal_projector(obj):
    """A temporary empty projecting onto obj: centred on it, tilted, about its size (the
    round shapes reach well into it: the cone is half as wide at its centre)."""
    import bpy
    from mathutils import Euler, Matrix, Vector
    empty = bpy.data.objects.new("SG Decal Projector (temporary)", None)
    bpy.context.scene.collection.objects.link(empty)
    centre = obj.matrix_world @ Vector(np.mean(np.array(obj.bound_box), axis=0))
    size = max(obj.dimensions) * 0.5
    empty.matrix_world = (Matrix.Translation(centre) @ Euler((0.5, 0.3, 0.2)).to_matrix()
                          .to_4x4() @ Matrix.Diagonal((1.1 * size, 0.95 * size, 1.2 * size, 1)))
    bpy.context.view_layer.update()
    return empty


def projector_coordinates(nodes, projector):
    """SG Projector Coordinates fed by a Texture Coordinate node of the projector and set to
    its matrix (as the operator's drivers do): its Decal Coordinates output."""
    node = group_node(nodes, G.projector_coordinates_group())
    tc = nodes.new("ShaderNodeTexCoord")
    tc.object = projector
    node.id_data.links.new(tc.outputs["Object"], node.inputs["Decal Coordinates"])
    m = np.array(projector.matrix_world, dtype=np.float64)
    node.inputs["Projector Location"].default_value = m[:3, 3]
    for axis, row in zip("XYZ", np.linalg.inv(m[:3, :3])):
        node.inputs[f"To Projector {axis}"].default_value = row
    return node.outputs["Decal Coordinates"]


def decal_graph(inp, nodes, links, shape=None, base=None, overwrite=False, opacity=1.0):
    """SG Decal with its chain; `shape` (default: the method's variant, box for plain
    "decal"), `base` a surface-gradient socket underneath, overwrite mode and opacity."""
    shape = shape or (inp.variant if inp.variant in R.decals.DECAL_SHAPES else "box")
    q = projector_coordinates(nodes, inp.projector)
    decal = group_node(nodes, G.decal_group())
    coords = group_node(nodes, G.decal_coordinates_group())
    links.new(q, decal.inputs["Decal Coordinates"])
    links.new(q, coords.inputs["Decal Coordinates"])
    color = image_node(nodes, links, inp.bpy_image("normal"), coords.outputs["Decal UV"])
    links.new(color, decal.inputs["Color"])
    ax, ay, _, _ = M.decal_frame(np.array(inp.projector.matrix_world))
    decal.inputs["Axis X"].default_value = ax
    decal.inputs["Axis Y"].default_value = ay
    decal.inputs["Falloff"].default_value = DECAL_FALLOFF
    decal.inputs["Shape"].default_value = R.decals.DECAL_SHAPES.index(shape)
    decal.inputs["Overwrite"].default_value = overwrite
    decal.inputs["Opacity"].default_value = opacity
    if base is not None:
        links.new(base, decal.inputs["Base Gradient"])
    return decal.outputs["Surface Gradient"]


def _decal_reference(inp, td):
    shape = inp.variant if inp.variant in R.decals.DECAL_SHAPES else "box"
    return M.decal_surfgrad(td, inp.pixels("normal"), np.array(inp.projector.matrix_world),
                            falloff=DECAL_FALLOFF, shape=shape)


# Overwrite mode: a cylinder decal replacing (at 70 %) the detail map underneath.
OVERWRITE_OPACITY = 0.7


def _decal_overwrite_graph(inp, nodes, links):
    base = _procedural_basis_graph(inp, nodes, links)
    return decal_graph(inp, nodes, links, shape="cylinder", base=base, overwrite=True,
                       opacity=OVERWRITE_OPACITY)


def _decal_overwrite_reference(inp, td):
    n, base = M.procedural_basis_surfgrad(td, inp.pixels("detail"), inp.detail_uv)
    return M.decal_surfgrad(td, inp.pixels("normal"), np.array(inp.projector.matrix_world),
                            falloff=DECAL_FALLOFF, shape="cylinder", overwrite=True,
                            opacity=OVERWRITE_OPACITY, base_sg=base)


LAYER_DETAIL, LAYER_NOISE = 0.5, 0.02


def _layered_graph(inp, nodes, links):
    combine = group_node(nodes, G.combine_group())
    links.new(normal_map_graph(inp, nodes, links), combine.inputs["A"])
    links.new(_procedural_basis_graph(inp, nodes, links, strength=LAYER_DETAIL),
              combine.inputs["B"])
    return add_vectors(nodes, links, combine.outputs[0],
                _volume_noise_graph(inp, nodes, links, amount=LAYER_NOISE))


def _layered_reference(inp, td):
    n, sg1 = M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map)
    _, sg2 = M.procedural_basis_surfgrad(td, inp.pixels("detail"), inp.detail_uv,
                                         strength=LAYER_DETAIL)
    _, sg3 = M.volume_noise_surfgrad(td, NOISE_SCALE, LAYER_NOISE, 4)
    return n, sg1 + sg2 + sg3


HEIGHT_BUMP_SCALE = 0.05


def _height_map_graph(inp, nodes, links):
    uv = uv_node(nodes, inp.uv_map)
    if inp.variant == "forward":
        height = nodes.new("ShaderNodeSeparateXYZ")
        links.new(image_node(nodes, links, inp.bpy_image("height"), uv), height.inputs[0])
        node = group_node(nodes, G.height_map_forward_group())
        links.new(height.outputs[0], node.inputs["Height"])
    else:
        node = group_node(nodes, G.height_map_group(inp.bpy_image("height"), inp.variant))
        links.new(uv, node.inputs["UV"])
    node.inputs["Bump Scale"].default_value = HEIGHT_BUMP_SCALE
    return node.outputs["Surface Gradient"]


def _height_map_reference(inp, td):
    return M.height_map_surfgrad(td, inp.pixels("height"), inp.variant, HEIGHT_BUMP_SCALE,
                                 inp.uv_map)


PARALLAX_SCALE = 0.15
VIEW_TILT = (0.45, -0.3, 0.2)      # view = normalize(n + VIEW_TILT): oblique, front-facing


def parallax_depth(inp):
    """The comparison's parallax depth: PARALLAX_SCALE, or what compare set for a small object
    (scale_limits.parallax_depth)."""
    return getattr(inp, "parallax_scale", None) or PARALLAX_SCALE


def _normal_map_at_parallax(inp, nodes, links, par):
    """A parallax group's view and scale set, and SG Normal Map read at its offset UV."""
    links.new(_parallax_view(nodes, links), par.inputs["View"])
    par.inputs["Bump Scale"].default_value = parallax_depth(inp)
    color = image_node(nodes, links, inp.bpy_image("normal"), par.outputs["UV"])
    nm = group_node(nodes, G.normal_map_group(inp.uv_map))
    links.new(color, nm.inputs["Color"])
    return nm.outputs["Surface Gradient"]


def _parallax_graph(inp, nodes, links):
    par = group_node(nodes, G.parallax_group(inp.bpy_image("height")))
    links.new(uv_node(nodes, inp.uv_map), par.inputs["UV"])
    return _normal_map_at_parallax(inp, nodes, links, par)


def _parallax_reference(inp, td):
    n = M.unit_base_normal(td)
    view = R.vecmath.normalize(n + np.array(VIEW_TILT))
    offs = M.parallax_offset(td, inp.pixels("height"), view, parallax_depth(inp), G.POM_STEPS,
                             inp.uv_map)
    return M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map,
                                 st=td.uv(inp.uv_map) + offs)


# Sampler groups (Blender 5.0+): the same references, the image as a closure -------------------

def sampler_socket(nodes, links, image, interpolation="Linear", extension="REPEAT"):
    """A Closure Zone around an Image Texture of `image`: the Sampler a group evaluates."""
    from ..addon.sampler_zone import sampler_zone
    tex = nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation, tex.extension = image, interpolation, extension
    zone, _, _ = sampler_zone(nodes, links, tex)
    return zone.outputs[0]


def _sized(node, image):
    node.inputs["Width"].default_value, node.inputs["Height"].default_value = image.size[:2]
    return node


def _height_map_sampler_graph(inp, nodes, links):
    image = inp.bpy_image("height")
    node = _sized(group_node(nodes, G.height_map_sampler_group(inp.variant)), image)
    links.new(sampler_socket(nodes, links, image), node.inputs["Sampler"])
    links.new(uv_node(nodes, inp.uv_map), node.inputs["UV"])
    node.inputs["Bump Scale"].default_value = HEIGHT_BUMP_SCALE
    return node.outputs["Surface Gradient"]


def _triplanar_sampler_graph(inp, nodes, links):
    node = group_node(nodes, G.triplanar_sampler_group())
    links.new(sampler_socket(nodes, links, inp.bpy_image("normal")), node.inputs["Sampler"])
    return node.outputs["Surface Gradient"]


def _triplanar_height_sampler_graph(inp, nodes, links):
    image = inp.bpy_image("height")
    node = _sized(group_node(nodes, G.triplanar_height_sampler_group()), image)
    links.new(sampler_socket(nodes, links, image), node.inputs["Sampler"])
    node.inputs["Bump Scale"].default_value = HEIGHT_BUMP_SCALE
    return node.outputs["Surface Gradient"]


def _parallax_view(nodes, links):
    geo = nodes.new("ShaderNodeNewGeometry")
    view = nodes.new("ShaderNodeVectorMath")
    view.operation = "ADD"
    links.new(geo.outputs["Normal"], view.inputs[0])
    view.inputs[1].default_value = VIEW_TILT
    unit = nodes.new("ShaderNodeVectorMath")
    unit.operation = "NORMALIZE"
    links.new(view.outputs[0], unit.inputs[0])
    return unit.outputs[0]


def _parallax_sampler_graph(inp, nodes, links):
    par = group_node(nodes, G.parallax_sampler_group())
    links.new(sampler_socket(nodes, links, inp.bpy_image("height")), par.inputs["Sampler"])
    links.new(uv_node(nodes, inp.uv_map), par.inputs["UV"])
    return _normal_map_at_parallax(inp, nodes, links, par)


def _post_resolve_graph(inp, nodes, links):
    """Figure 7(b): a baked normal map resolved first, then triplanar detail on top with the
    resolved normal as the new base normal (weights, projection and second resolve)."""
    first = resolve_sg(nodes, links, normal_map_graph(inp, nodes, links))
    tri_sg = triplanar_graph(inp, nodes, links, image="detail")
    tri = tri_sg.node
    links.new(first, tri.inputs["Normal"])
    tri.inputs["Strength"].default_value = 0.5
    final = group_node(nodes, G.resolve_group())
    links.new(first, final.inputs["Normal"])
    links.new(tri_sg, final.inputs["Surface Gradient"])
    return final.outputs["Normal"]


def _post_resolve_reference(inp, td):
    n, sg = M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map)
    n1 = R.resolve_normal_from_surface_gradient(n, sg)
    _, sg2 = M.triplanar_surfgrad(td, inp.pixels("detail"), strength=0.5, base_normal=n1)
    return n1, sg2


DISPLACE = {"Amount": 0.1, "Scale": 2.0, "Octaves": 2}
BUMP_ON_TOP = (8.0, 0.02, 2)                   # scale, amount, octaves of the finer bump


def add_displace_modifier(obj, settings=None):
    """SG Displace as a Geometry Nodes modifier on obj (returns the modifier)."""
    tree = G.displace_group()
    mod = obj.modifiers.new("SG Displace", "NODES")
    mod.node_group = tree
    for name, value in (settings or DISPLACE).items():
        compat.set_input(mod, name, value)
    obj.data.update()
    return mod


def _displace_bump_graph(inp, nodes, links):
    """Gustavson's fragment shader: finer SG Noise at the undisplaced object coordinates,
    through SG Volume Gradient and SG Resolve, on the analytically displaced surface."""
    scale, amount, octaves = BUMP_ON_TOP
    rest = group_node(nodes, G.rest_position_group())
    noise = group_node(nodes, G.noise_group())
    links.new(rest.outputs[0], noise.inputs["Vector"])
    noise.inputs["Scale"].default_value = scale
    noise.inputs["Octaves"].default_value = octaves
    vg = group_node(nodes, G.volume_gradient_group())
    links.new(noise.outputs["Gradient"], vg.inputs["Gradient"])
    vg.inputs["Strength"].default_value = amount
    return vg.outputs["Surface Gradient"]


def _displace_bump_reference(inp, td):
    scale, amount, octaves = BUMP_ON_TOP
    return M.volume_noise_surfgrad(td, scale, amount, octaves,
                                   coords=td.point_attribute(G.REST_ATTRIBUTE))


BLEND_MODES = {"blend-pd": 0, "blend-whiteout": 1, "blend-udn": 2, "blend-rnm": 3}


def _blend_graph(mode):
    def graph(inp, nodes, links):
        uv = uv_node(nodes, inp.uv_map)
        a = image_node(nodes, links, inp.bpy_image("normal"), uv)
        b = image_node(nodes, links, inp.bpy_image("detail"), uv)
        blend = group_node(nodes, G.blend_normals_group())
        links.new(a, blend.inputs["Color A"])
        links.new(b, blend.inputs["Color B"])
        blend.inputs["Method"].default_value = BLEND_MODES[mode]
        nm = group_node(nodes, G.normal_map_group(inp.uv_map))
        links.new(blend.outputs["Color"], nm.inputs["Color"])
        return nm.outputs["Surface Gradient"]
    return graph


def _blend_reference(mode):
    method = {"blend-pd": "pd", "blend-whiteout": "whiteout", "blend-udn": "udn"}.get(mode)

    def reference(inp, td):
        n, t, bt = M.mikktspace_frame(td, inp.uv_map)
        uv = td.uv(inp.uv_map)
        a = M.decode_normal_map(R.sample_image(inp.pixels("normal"), uv))
        b = M.decode_normal_map(R.sample_image(inp.pixels("detail"), uv))
        if method is None:
            return n, R.surfgrad_blend_rnm(a, b, t, bt)
        return n, R.surfgrad_blend(method, a, t, bt, b, t, bt)
    return reference


@dataclass(frozen=True)
class Method:
    name: str
    graph: Callable
    reference: Callable
    variants: tuple = ("hq",)          # height-map: the three derivative variants
    group: Optional[str] = None        # a group behind a feature gate (groups.REQUIRES)
    setup: Optional[Callable] = None   # setup(obj) -> what to add to Inputs, removed after
    stability: bool = True             # run by the stability suite (bench/stability.py)
    scene_only: bool = False           # its reference needs Blender's evaluated scene
    mikktspace: bool = False           # it reads the MikkTSpace frame (SG Normal Map)
    same_reference_as: Optional[str] = None   # another method's reference (a Sampler group's)

    def unavailable_reason(self):
        """None when this Blender can run the method, else why not (docs/versions.md)."""
        return G.unavailable_reason(self.group) if self.group else None

    @contextmanager
    def scene(self, obj, inputs):
        """The method's temporary scene additions for obj, removed afterwards."""
        import bpy
        added = self.setup(obj) if self.setup else {}
        for key, value in added.items():
            setattr(inputs, key, value)
        try:
            yield inputs
        finally:
            if inputs.projector is not None:
                bpy.data.objects.remove(inputs.projector)
                inputs.projector = None
            if inputs.modifier is not None:
                obj.modifiers.remove(inputs.modifier)
                inputs.modifier = None


_REGISTRY = (
    Method("normal-map", lambda inp, nodes, links: normal_map_graph(inp, nodes, links),
           lambda inp, td: M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map),
           mikktspace=True),
    Method("procedural-basis",
           lambda inp, nodes, links: _procedural_basis_graph(inp, nodes, links),
           lambda inp, td: M.procedural_basis_surfgrad(td, inp.pixels("detail"),
                                                       inp.detail_uv)),
    Method("object-normal", _object_normal_graph, _object_normal_reference),
    Method("volume-noise", _volume_noise_graph,
           lambda inp, td: M.volume_noise_surfgrad(td, NOISE_SCALE, NOISE_AMOUNT, 4)),
    Method("height-map", _height_map_graph, _height_map_reference,
           variants=M.HEIGHT_VARIANTS),
    Method("triplanar", triplanar_graph,
           lambda inp, td: M.triplanar_surfgrad(td, inp.pixels("normal"))),
    Method("triplanar-height", _triplanar_height_graph,
           lambda inp, td: M.triplanar_height_surfgrad(td, inp.pixels("height"),
                                                       bump_scale=HEIGHT_BUMP_SCALE),
           stability=False),          # the triplanar Listings, covered by "triplanar"
    Method("decal", decal_graph, _decal_reference, variants=R.decals.DECAL_SHAPES,
           setup=lambda obj: {"projector": decal_projector(obj)}),
    Method("decal-overwrite", _decal_overwrite_graph, _decal_overwrite_reference,
           setup=lambda obj: {"projector": decal_projector(obj)}, stability=False),
    Method("parallax", _parallax_graph, _parallax_reference, mikktspace=True),
    Method("post-resolve", _post_resolve_graph, _post_resolve_reference,
           stability=False, mikktspace=True),          # two resolves of the methods the suite already runs
    Method("displace-bump", _displace_bump_graph, _displace_bump_reference,
           group="SG Displace", setup=lambda obj: {"modifier": add_displace_modifier(obj)},
           stability=False, scene_only=True),   # the displaced mesh's rest positions          # its hostile cases are the mesh's, not a texture's
    Method("layered", _layered_graph, _layered_reference, mikktspace=True),
    # The Sampler groups (5.0+): the per-image methods' references, the image as a closure.
    Method("height-map-sampler", _height_map_sampler_graph, _height_map_reference,
           variants=("one-texel", "hq"), group="SG Height Map HQ (Sampler)", stability=False,
           same_reference_as="height-map"),
    Method("triplanar-sampler", _triplanar_sampler_graph,
           lambda inp, td: M.triplanar_surfgrad(td, inp.pixels("normal")),
           group="SG Triplanar (Sampler)", stability=False, same_reference_as="triplanar"),
    Method("triplanar-height-sampler", _triplanar_height_sampler_graph,
           lambda inp, td: M.triplanar_height_surfgrad(td, inp.pixels("height"),
                                                       bump_scale=HEIGHT_BUMP_SCALE),
           group="SG Triplanar Height (Sampler)", stability=False,
           same_reference_as="triplanar-height"),
    Method("parallax-sampler", _parallax_sampler_graph, _parallax_reference,
           group="SG Parallax (Sampler)", stability=False, mikktspace=True,
           same_reference_as="parallax"),
    # RNM stands for the four blends in the stability suite (same decode, same SG Normal Map).
    *(Method(mode, _blend_graph(mode), _blend_reference(mode), stability=mode == "blend-rnm",
             mikktspace=True) for mode in BLEND_MODES),
)
METHODS = {m.name: m for m in _REGISTRY}


def unavailable_reason(method):
    """None when `method` (a name) can run in this Blender, else why not."""
    return METHODS[method].unavailable_reason()


def cases():
    """(method, variant) for every method this Blender can run, each variant separately."""
    return [(m.name, v) for m in sorted(METHODS.values(), key=lambda m: m.name)
            if m.unavailable_reason() is None for v in m.variants]
