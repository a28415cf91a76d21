"""Bake a method's node groups with Cycles and compare them texel by texel with the reference.

    python -m surfgrad_addon compare --blend FILE --object NAME --method METHOD \\
        --resolution N --json OUT [--uv-map NAME] [--image PATH] [--variant V]

Without --blend the procedural test scene (blender/scenes.py) is used. The bake and the
reference see the same mesh (the evaluated object, Blender's MikkTSpace tangents), the same
images (their pixels as Cycles reads them) and the same parameters. Angular error is measured
over interior texels (whose 3 x 3 neighbourhood is covered): texels at UV-island borders and
texels only one side covered are excluded and counted.
"""

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import reference as R
from .png import write_png
from ..reference import methods as M
from . import bake as B
from ..addon import groups as G
from ..addon import compat
from .mesh_data import MeshDataError, mesh_arrays_from_object

DETAIL_UV = "Detail"
NORMAL_IMAGE_SIZE = 128
HEIGHT_IMAGE_SIZE = 32       # small: bakes magnify it, where the variants differ


class CompareError(ValueError):
    """Bad input for a comparison: the message names the thing and the fix."""


@dataclass
class Inputs:
    """Everything a method needs, shared by its node graph and its reference."""
    obj: object
    uv_map: str
    detail_uv: str
    images: dict = field(default_factory=dict)      # name -> (numpy pixels (H, W, C), bpy image)
    variant: str = "hq"
    projector: object = None                         # a temporary decal projector (an empty)
    modifier: object = None                          # a temporary SG Displace modifier

    def pixels(self, name):
        return self.images[name][0]

    def bpy_image(self, name):
        return self.images[name][1]


# Node-graph helpers --------------------------------------------------------------------------

def group_node(nodes, tree):
    node = nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    return node


def _link(links, source, target):
    if source is not None:
        links.new(source, target)


def image_node(nodes, links, image, vector, interpolation="Linear", extension="REPEAT"):
    node = nodes.new("ShaderNodeTexImage")
    node.image = image
    node.interpolation = interpolation
    node.extension = extension
    _link(links, vector, node.inputs["Vector"])
    return node.outputs["Color"]


def uv_node(nodes, uv_map):
    node = nodes.new("ShaderNodeUVMap")
    node.uv_map = uv_map
    return node.outputs["UV"]


def resolve_sg(nodes, links, surface_gradient):
    node = group_node(nodes, G.resolve_group())
    links.new(surface_gradient, node.inputs["Surface Gradient"])
    return node.outputs["Normal"]


def add_vectors(nodes, links, a, b):
    node = nodes.new("ShaderNodeVectorMath")
    node.operation = "ADD"
    links.new(a, node.inputs[0])
    links.new(b, node.inputs[1])
    return node.outputs[0]


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
    """A temporary empty projecting onto obj: centred on it, tilted, smaller than it."""
    import bpy
    from mathutils import Euler, Matrix, Vector
    empty = bpy.data.objects.new("SG Decal Projector (temporary)", None)
    bpy.context.scene.collection.objects.link(empty)
    centre = obj.matrix_world @ Vector(np.mean(np.array(obj.bound_box), axis=0))
    size = max(obj.dimensions) * 0.5
    empty.matrix_world = (Matrix.Translation(centre) @ Euler((0.5, 0.3, 0.2)).to_matrix()
                          .to_4x4() @ Matrix.Diagonal((0.55 * size, 0.4 * size, 1.2 * size, 1)))
    bpy.context.view_layer.update()
    return empty


def decal_graph(inp, nodes, links):
    tc = nodes.new("ShaderNodeTexCoord")
    tc.object = inp.projector
    decal = group_node(nodes, G.decal_group())
    coords = group_node(nodes, G.decal_coordinates_group())
    links.new(tc.outputs["Object"], decal.inputs["Decal Coordinates"])
    links.new(tc.outputs["Object"], coords.inputs["Decal Coordinates"])
    color = image_node(nodes, links, inp.bpy_image("normal"), coords.outputs["Decal UV"])
    links.new(color, decal.inputs["Color"])
    ax, ay, _, _ = M.decal_frame(np.array(inp.projector.matrix_world))
    decal.inputs["Axis X"].default_value = ax
    decal.inputs["Axis Y"].default_value = ay
    decal.inputs["Falloff"].default_value = DECAL_FALLOFF
    return decal.outputs["Surface Gradient"]


def _decal_reference(inp, td):
    return M.decal_surfgrad(td, inp.pixels("normal"), np.array(inp.projector.matrix_world),
                            falloff=DECAL_FALLOFF)


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


def _parallax_graph(inp, nodes, links):
    geo = nodes.new("ShaderNodeNewGeometry")
    view = nodes.new("ShaderNodeVectorMath")
    view.operation = "ADD"
    links.new(geo.outputs["Normal"], view.inputs[0])
    view.inputs[1].default_value = VIEW_TILT
    unit = nodes.new("ShaderNodeVectorMath")
    unit.operation = "NORMALIZE"
    links.new(view.outputs[0], unit.inputs[0])
    par = group_node(nodes, G.parallax_group(inp.bpy_image("height")))
    links.new(uv_node(nodes, inp.uv_map), par.inputs["UV"])
    links.new(unit.outputs[0], par.inputs["View"])
    par.inputs["Bump Scale"].default_value = PARALLAX_SCALE
    color = image_node(nodes, links, inp.bpy_image("normal"), par.outputs["UV"])
    nm = group_node(nodes, G.normal_map_group(inp.uv_map))
    links.new(color, nm.inputs["Color"])
    return nm.outputs["Surface Gradient"]


def _parallax_reference(inp, td):
    n = M.unit_base_normal(td)
    view = R.vecmath.normalize(n + np.array(VIEW_TILT))
    offs = M.parallax_offset(td, inp.pixels("height"), view, PARALLAX_SCALE, G.POM_STEPS,
                             inp.uv_map)
    return M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map,
                                 st=td.uv(inp.uv_map) + offs)


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


METHODS = {
    "normal-map": (lambda inp, nodes, links: normal_map_graph(inp, nodes, links),
                   lambda inp, td: M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map)),
    "procedural-basis": (lambda inp, nodes, links: _procedural_basis_graph(inp, nodes, links),
                         lambda inp, td: M.procedural_basis_surfgrad(td, inp.pixels("detail"),
                                                                     inp.detail_uv)),
    "object-normal": (_object_normal_graph, _object_normal_reference),
    "volume-noise": (_volume_noise_graph,
                     lambda inp, td: M.volume_noise_surfgrad(td, NOISE_SCALE, NOISE_AMOUNT, 4)),
    "height-map": (_height_map_graph, _height_map_reference),
    "triplanar": (triplanar_graph,
                  lambda inp, td: M.triplanar_surfgrad(td, inp.pixels("normal"))),
    "triplanar-height": (_triplanar_height_graph,
                         lambda inp, td: M.triplanar_height_surfgrad(
                             td, inp.pixels("height"), bump_scale=HEIGHT_BUMP_SCALE)),
    "decal": (decal_graph, _decal_reference),
    "parallax": (_parallax_graph, _parallax_reference),
    "post-resolve": (_post_resolve_graph, _post_resolve_reference),
    "displace-bump": (_displace_bump_graph, _displace_bump_reference),
    "layered": (_layered_graph, _layered_reference),
    **{mode: (_blend_graph(mode), _blend_reference(mode)) for mode in BLEND_MODES},
}

# Methods built on a group that older Blender lines lack (groups.REQUIRES).
METHOD_GROUPS = {"displace-bump": "SG Displace"}


def unavailable_reason(method):
    """None when `method` can run in this Blender, else why not (docs/versions.md)."""
    group = METHOD_GROUPS.get(method)
    return G.unavailable_reason(group) if group else None


# Inputs -----------------------------------------------------------------------------------------

def bpy_float_image(name, pixels):
    import bpy
    px = np.asarray(pixels, dtype=np.float32)
    if px.ndim == 2:
        px = np.repeat(px[..., None], 3, axis=-1)
    h, w = px.shape[:2]
    if px.shape[2] == 3:
        px = np.concatenate([px, np.ones((h, w, 1), np.float32)], axis=-1)
    img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(px.ravel())
    img.pack()
    return img


def _load_image(path):
    """An image file as Cycles will read it (Non-Color), and its pixels for the reference."""
    import bpy
    path = Path(path)
    if not path.is_file():
        raise CompareError(f"image {str(path)!r} does not exist; give an existing file to "
                           f"--image")
    try:
        img = bpy.data.images.load(str(path.resolve()), check_existing=False)
    except RuntimeError as err:
        raise CompareError(f"image {str(path)!r} could not be read ({err})") from err
    img.colorspace_settings.name = "Non-Color"
    w, h = img.size
    if w == 0 or h == 0:
        raise CompareError(f"image {str(path)!r} is empty")
    px = np.empty(w * h * img.channels, dtype=np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, img.channels).astype(np.float64)
    if not np.all(np.isfinite(px)):
        raise CompareError(f"image {str(path)!r} has non-finite pixels (NaN or Inf); fix "
                           f"or clamp them before using it as a bump map")
    return px[..., :3] if img.channels >= 3 else px[..., 0], img


def prepare_inputs(obj, uv_map=None, image=None, variant="hq"):
    if obj.type != "MESH":
        raise CompareError(f"object {obj.name!r} is a {obj.type.lower()}, not a mesh")
    names = [uv.name for uv in obj.data.uv_layers]
    if not names:
        raise CompareError(f"object {obj.name!r} has no UV map; add one (UV > Unwrap)")
    if uv_map is None:
        active = [uv.name for uv in obj.data.uv_layers if uv.active_render]
        uv_map = active[0] if active else names[0]
    elif uv_map not in names:
        raise CompareError(f"object {obj.name!r} has no UV map named {uv_map!r}; it has "
                           f"{names}")
    detail = DETAIL_UV if DETAIL_UV in names else uv_map
    inp = Inputs(obj=obj, uv_map=uv_map, detail_uv=detail, variant=variant)
    if isinstance(image, np.ndarray):       # pixels given directly (the stability suite)
        inp.images["normal"] = (image[..., :3].astype(np.float32).astype(np.float64),
                                bpy_float_image("sg_normal", image))
    elif image is not None:
        px, img = _load_image(image)
        inp.images["normal"] = (px, img)
    else:
        px = R.images.hemisphere_tile_image(NORMAL_IMAGE_SIZE)
        inp.images["normal"] = (px.astype(np.float32).astype(np.float64),
                                bpy_float_image("sg_normal", px))
    px = R.images.hemisphere_tile_image(NORMAL_IMAGE_SIZE, tiles=8, radius=0.6)
    inp.images["detail"] = (px.astype(np.float32).astype(np.float64),
                            bpy_float_image("sg_detail", px))
    h = R.images.wave_height_image(HEIGHT_IMAGE_SIZE)
    inp.images["height"] = (h.astype(np.float32).astype(np.float64),
                            bpy_float_image("sg_height", h))
    return inp


# The comparison -----------------------------------------------------------------------------------

def angle_deg(a, b):
    """Angle between vectors in float64, accurate near zero (atan2 of |a x b| and a . b).
    A zero-length or non-finite vector has no direction: it scores 180 degrees, never 0."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                np.sum(a * b, axis=-1)))
    valid = (np.isfinite(a).all(-1) & np.isfinite(b).all(-1)
             & (np.linalg.norm(a, axis=-1) > 0) & (np.linalg.norm(b, axis=-1) > 0))
    return np.where(valid, ang, 180.0)


def compare_object(obj, method, resolution, uv_map=None, image=None, variant="hq", log=print):
    """Bake `method` on obj and compare with the reference. Returns (report dict, per-texel
    error image (H, W) with NaN where not compared)."""
    if method not in METHODS:
        raise CompareError(f"method {method!r} is not available; use one of "
                           f"{sorted(METHODS)}")
    reason = unavailable_reason(method)
    if reason is not None:
        raise CompareError(f"method {method!r} is not available in this Blender: {reason}")
    inp = prepare_inputs(obj, uv_map, image, variant)
    import bpy
    try:
        if method == "decal":
            inp.projector = decal_projector(obj)
        if method == "displace-bump":
            inp.modifier = add_displace_modifier(obj)
        graph, reference = METHODS[method]
        report, heat = compare_graph(inp, obj, graph, reference, resolution)
        report["method"] = method
        report["variant"] = inp.variant if method == "height-map" else None
        return report, heat
    finally:
        for _, img in inp.images.values():
            bpy.data.images.remove(img)
        if inp.projector is not None:
            bpy.data.objects.remove(inp.projector)
        if inp.modifier is not None:
            obj.modifiers.remove(inp.modifier)


def compare_graph(inp, obj, graph, reference, resolution):
    """Bake graph(inp, nodes, links) on obj and compare with reference(inp, td): the report
    and the per-texel error image."""
    method = getattr(graph, "__name__", "graph")
    G.build_all()
    def build(nodes, links):
        out = graph(inp, nodes, links)
        # Graphs return a surface gradient to resolve against the shading normal, or (post-
        # resolve) an already resolved normal.
        return out if out.name == "Normal" else resolve_sg(nodes, links, out)
    pixels, covered, bake_seconds = B.bake_vector(obj, build, resolution, resolution,
                                                  uv_map=inp.uv_map)
    try:
        mesh = mesh_arrays_from_object(obj)
    except MeshDataError as err:
        raise CompareError(str(err)) from err
    t0 = time.perf_counter()
    td = R.rasterize(mesh, inp.uv_map, resolution, resolution, facts=B.running_line())
    ref = M.resolve(reference(inp, td))
    reference_seconds = time.perf_counter() - t0
    baked = pixels[td.pixel[:, 1], td.pixel[:, 0]].astype(np.float64)
    in_bake = covered[td.pixel[:, 1], td.pixel[:, 0]]
    interior = td.interior() & in_bake
    err = angle_deg(baked[interior], ref[interior])
    excluded = int(len(td.pixel) - interior.sum() + (covered & ~td.covered).sum())
    base = M.unit_base_normal(td)[interior]
    tilt_bake = angle_deg(baked[interior], base)
    tilt_ref = angle_deg(ref[interior], base)
    # Over every texel both cover (borders included): the stability figures.
    both = in_bake
    ng = td.geometric_normal[both]
    b_all, r_all = baked[both], ref[both]
    norms = np.linalg.norm(b_all, axis=-1)
    finite_unit = np.isfinite(b_all).all(-1) & (np.abs(norms - 1) < 1e-3)
    away = np.sum(b_all * ng, axis=-1) < -1e-3
    truth_away = np.sum(r_all * ng, axis=-1) < 1e-3
    report_all = {
        "finite_unit_fraction_all": float(finite_unit.mean()),
        "facing_away_fraction": float(away.mean()),
        "truth_facing_away_fraction": float((np.sum(r_all * ng, axis=-1) < 0).mean()),
        "faces_away_where_truth_does_not": int(np.sum(away & ~truth_away)),
    }
    report = {
        **report_all,
        "method": method, "object": obj.name, "uv_map": inp.uv_map,
        "tilt_mean_deg": float(tilt_ref.mean()), "bake_tilt_mean_deg": float(tilt_bake.mean()),
        "resolution": resolution, "texels_compared": int(interior.sum()),
        "texels_excluded": excluded,
        "excluded_fraction": excluded / max(1, int(interior.sum()) + excluded),
        "mean_deg": float(err.mean()), "p99_deg": float(np.percentile(err, 99)),
        "max_deg": float(err.max()), "bake_seconds": bake_seconds,
        "reference_seconds": reference_seconds,
        "finite_unit_fraction": float(np.mean(np.isfinite(baked[interior]).all(-1) & (
            np.abs(np.linalg.norm(baked[interior], axis=-1) - 1) < 1e-4))),
    }
    heat = np.full((resolution, resolution), np.nan)
    heat[td.pixel[interior, 1], td.pixel[interior, 0]] = err
    return report, heat


def write_heat_map(path, heat, overwrite):
    """Error in degrees as a picture: black 0, white at the max (or 0.5 deg, whichever is
    larger), uncompared texels dark blue."""
    top = max(0.5, float(np.nanmax(heat)) if np.isfinite(heat).any() else 0.5)
    v = np.clip(np.nan_to_num(heat, nan=0.0) / top, 0, 1)
    rgb = np.stack([v, v ** 0.5 * 0.8, v ** 2], axis=-1)
    rgb[np.isnan(heat)] = (0.05, 0.05, 0.2)
    return write_png(path, rgb, overwrite=overwrite)


def run(blend, object_name, method, resolution, json_out, uv_map=None, image=None,
        variant="hq", overwrite=False, log=print, from_open_file=False):
    """The command: load, bake, compare, write the JSON and the heat map, print a summary."""
    import bpy
    json_out = Path(json_out)
    heat_path = json_out.with_name(json_out.stem + "_error.png")
    for p in (json_out, heat_path):
        if p.exists() and not overwrite:
            raise CompareError(f"{p} exists; pass --overwrite to replace it")
    if blend:
        if not Path(blend).is_file():
            raise CompareError(f".blend file {blend!r} does not exist")
        bpy.ops.wm.open_mainfile(filepath=str(blend))
    elif not from_open_file:
        from . import scenes
        scenes.new_scene()
    obj = bpy.data.objects.get(object_name)
    if obj is None:
        raise CompareError(f"no object named {object_name!r}; objects: "
                           f"{sorted(o.name for o in bpy.data.objects)}")
    report, heat = compare_object(obj, method, resolution, uv_map, image, variant, log)
    json_out.parent.mkdir(parents=True, exist_ok=True)
    json_out.write_text(json.dumps(report, indent=2))
    write_heat_map(heat_path, heat, overwrite)
    log(f"{method} on {obj.name} at {resolution}^2: {report['texels_compared']} texels, "
        f"mean {report['mean_deg']:.4f} p99 {report['p99_deg']:.4f} max "
        f"{report['max_deg']:.4f} deg; excluded {report['texels_excluded']}; bake "
        f"{report['bake_seconds']:.2f} s, reference {report['reference_seconds']:.2f} s")
    return report


def compare_cases():
    """(method, variant) for every method this Blender can run, each height-map variant
    separately."""
    return [(m, "hq") for m in sorted(METHODS)
            if m != "height-map" and unavailable_reason(m) is None] + \
        [("height-map", v) for v in ("forward", "one-texel", "hq")]


def run_all(out_dir, resolution=64, overwrite=False, log=print):
    """Every method on every object of the procedural test scene: JSON, a Markdown table and
    an error heat map per case."""
    from . import scenes
    out = Path(out_dir)
    table_md, table_json = out / "compare.md", out / "compare.json"
    for p in (table_md, table_json):
        if p.exists() and not overwrite:
            raise CompareError(f"{p} exists; pass --overwrite to replace it")
    (out / "heat").mkdir(parents=True, exist_ok=True)
    objects = scenes.new_scene()
    cases = compare_cases()
    for method in METHODS:
        if unavailable_reason(method) is not None:
            log(f"skipped {method}: {unavailable_reason(method)}")
    reports = []
    total = len(cases) * len(objects)
    for i, (method, variant) in enumerate(cases):
        for name, obj in objects.items():
            report, heat = compare_object(obj, method, resolution, variant=variant,
                                          log=lambda *_: None)
            reports.append(report)
            label = method + (f"-{variant}" if method == "height-map" else "")
            write_heat_map(out / "heat" / f"{label}_{name}.png", heat, overwrite=True)
            log(f"[{len(reports)}/{total}] {label:22s} {name:12s} p99 "
                f"{report['p99_deg']:.4f} max {report['max_deg']:.4f} deg, bake "
                f"{report['bake_seconds']:.3f} s, reference {report['reference_seconds']:.3f} s")
    table_json.write_text(json.dumps(reports, indent=2))
    lines = [f"# Bakes against the reference at {resolution}^2",
             "", "Angular error (degrees) between the Cycles bake of each method's node groups "
             "and the numpy reference, over interior texels.", "",
             "| method | scene | texels | excluded | mean | p99 | max | bake s | reference s |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in reports:
        label = r["method"] + (f" ({r['variant']})" if r["variant"] else "")
        lines.append(f"| {label} | {r['object']} | {r['texels_compared']} | "
                     f"{100 * r['excluded_fraction']:.1f}% | {r['mean_deg']:.5f} | "
                     f"{r['p99_deg']:.4f} | {r['max_deg']:.4f} | {r['bake_seconds']:.3f} | "
                     f"{r['reference_seconds']:.3f} |")
    worst = max(reports, key=lambda r: r["max_deg"])
    lines += ["", f"Worst case: {worst['method']} on {worst['object']}, max "
                  f"{worst['max_deg']:.4f} deg (bar: p99 0.1, max 0.5)."]
    table_md.write_text("\n".join(lines) + "\n")
    log(f"wrote {table_md}, {table_json} and {len(reports)} heat maps in {out / 'heat'}")
    return reports
