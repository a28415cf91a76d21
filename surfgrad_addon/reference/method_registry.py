"""The registry's bpy-free half: every method's name, variants, parameters (with defaults) and
reference, which the harness joins to the method's node graph (harness/methods.py).

A Parameter names the group socket it drives and the reference keyword it feeds, so one value
sets both: `SPECS["normal-map"].values(strength=0.3)` checks the names, and the harness sets
Strength on the method's SG Normal Map node while the reference receives strength=0.3.

A reference is reference(inputs, td, **values) -> (base normal, surface gradient) on the texels
of td; `inputs` gives pixels(name), uv_map, detail_uv, variant and projector.matrix_world (the
harness's compare inputs, or main_job.ReferenceInputs without Blender).
"""

import functools
import inspect
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from . import methods as M
from .compositing import surfgrad_blend, surfgrad_blend_rnm
from .decals import DECAL_SHAPES
from .group_interfaces import REST_ATTRIBUTE
from .height_blend import HEIGHT_BLEND_CONTRAST, surfgrad_height_blend
from .image_sampling import sample_image
from .listings import resolve_normal_from_surface_gradient, surfgrad_from_perturbed_normal
from .parallax_conditioning import march_spread_texels
from .vecmath import normalize

# The comparison's settings, shared by graphs (harness/method_graphs) and references.
NOISE_SCALE, NOISE_AMOUNT, NOISE_OCTAVES = 4.0, 0.05, 4
HEIGHT_BUMP_SCALE = 0.05
DECAL_FALLOFF = 0.2
OVERWRITE_OPACITY = 0.7            # decal-overwrite: a cylinder decal over the detail map
LAYER_DETAIL, LAYER_NOISE = 0.5, 0.02
# layered: SG Combine's Scale A, Scale B and Mask B. At 1, 1, 1 a Combine ignoring Scale B or
# Mask B passed compare (tests/test_faults_mutants58b.py); B's two multiply to 1, so the
# reference's values stay those of tests/data/reference_a08fc13.npz (and Scale A stays 1).
LAYER_COMBINE = (1.0, 2.0, 0.5)
POST_RESOLVE_STRENGTH = 0.5        # the triplanar detail on top of the resolved normal map
PARALLAX_SCALE = 0.15
VIEW_TILT = (0.45, -0.3, 0.2)      # view = normalize(n + VIEW_TILT): oblique, front-facing
BUMP_ON_TOP = (8.0, 0.02, 2)       # displace-bump: scale, amount, octaves of the finer bump
BLEND_MODES = {"blend-pd": 0, "blend-whiteout": 1, "blend-udn": 2, "blend-rnm": 3}
# SG Parallax's march steps (addon/groups/parallax.py's POM_STEPS, needed here without the
# add-on; tests/test_method_registry.py holds them equal).
POM_STEPS = 8
# height-blend: SG Noise's Value (about -0.5 .. 0.5) raised by this, against the wave height
# image (0 .. 1): the sand fills about half of the rock's hollows.
SAND_LEVEL = 0.45


@dataclass(frozen=True)
class Parameter:
    """One setting of a method: `name` in method.at(name=...) and in the method's reference,
    its default, the group input `socket` it sets on every node of `groups` in the method's
    graph, and the keyword (default: the name) the reference passes it to `function` (a
    reference/methods.py function) as."""
    name: str
    default: object
    socket: str
    groups: tuple
    function: Callable
    keyword: Optional[str] = None

    @property
    def reference_keyword(self):
        return self.keyword or self.name


@dataclass(frozen=True)
class MethodSpec:
    name: str
    reference: Callable                # reference(inputs, td, **values)
    variants: tuple = ("hq",)          # height-map: the three derivative variants
    parameters: tuple = ()
    group: Optional[str] = None        # a group behind a feature gate (groups.REQUIRES)
    adds: Optional[str] = None         # "projector" or "modifier": the scene set-up it needs
    stability: bool = True             # run by the stability suite (bench/stability.py)
    scene_only: bool = False           # its reference needs Blender's evaluated scene
    mikktspace: bool = False           # it reads the MikkTSpace frame (SG Normal Map)
    same_reference_as: Optional[str] = None   # another method's reference (a Sampler group's)
    # spread(inputs, td) -> (N,) float32 spread of a view-dependent reference in texels of its
    # images (compare leaves out the texels where it is too large: "grazing").
    spread: Optional[Callable] = None
    # The test images its reference and graph read ("normal", "detail", "height"): compare
    # refuses an --image the method would drop before any bake (tests pin it to the run).
    reads: tuple = ()

    def values(self, **given):
        """Every parameter's value, as (name, value) pairs in declaration order: the defaults
        with `given` in their place. An unknown name is a ValueError naming the known ones."""
        known = [p.name for p in self.parameters]
        unknown = sorted(set(given) - set(known))
        if unknown:
            raise ValueError(f"method {self.name!r} has no parameter {unknown[0]!r}; its "
                             f"parameters: {', '.join(known) if known else 'none'}")
        return tuple((p.name, given.get(p.name, p.default)) for p in self.parameters)

    def bound_reference(self, values):
        """reference(inputs, td) with `values` (from values()) passed by name; the reference
        hands each on to its function as the parameter's keyword."""
        return _bind(self.reference, tuple(values))


@functools.lru_cache(maxsize=None)
def _bind(reference, keywords):
    """One callable per (reference, keywords): methods sharing a reference and its values (a
    Sampler method and its twin) share the bound reference itself."""
    if not keywords:
        return reference
    return functools.partial(reference, **dict(keywords))


def accepts(function, keyword):
    """Whether `function` takes `keyword` as a keyword argument."""
    return keyword in inspect.signature(function).parameters


def relief(inp):
    """The comparison's relief factor: 1, or the object's half-size in metres where compare
    shrank the relief to it (harness/scale_limits.scaled_relief): height-blend's relief
    lengths (the rock's Bump Scale, the sand's amount) are multiplied by it."""
    return getattr(inp, "relief_scale", None) or 1.0


def parallax_depth(inp):
    """The comparison's parallax depth: PARALLAX_SCALE, or what compare set for a small object
    (harness/scale_limits.parallax_depth)."""
    return getattr(inp, "parallax_scale", None) or PARALLAX_SCALE


# References: the reference/methods.py functions on a method's inputs ----------------------------

def _normal_map(inp, td, strength):
    return M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map, strength=strength)


def _procedural_basis(inp, td, strength):
    return M.procedural_basis_surfgrad(td, inp.pixels("detail"), inp.detail_uv,
                                       strength=strength)


def _object_normal(inp, td):
    n = M.unit_base_normal(td)
    v = M.decode_normal_map(sample_image(inp.pixels("normal"), td.uv(inp.uv_map))) + 2 * n
    return n, surfgrad_from_perturbed_normal(n, v)


def _volume_noise(inp, td, scale, amount, octaves):
    return M.volume_noise_surfgrad(td, scale, amount, octaves)


def _volume_noise_filtered(inp, td, scale, amount, octaves):
    return M.volume_noise_surfgrad(td, scale, amount, octaves, footprint_filter=True)


def _height_map(inp, td, bump_scale):
    return M.height_map_surfgrad(td, inp.pixels("height"), inp.variant, bump_scale, inp.uv_map)


def _triplanar(inp, td, strength, sharpness):
    return M.triplanar_surfgrad(td, inp.pixels("normal"), strength=strength, k=sharpness)


def _triplanar_height(inp, td, bump_scale, sharpness):
    return M.triplanar_height_surfgrad(td, inp.pixels("height"), bump_scale=bump_scale, k=sharpness)


def decal_shape(inp):
    """The decal's shape: the method's variant, box for plain "decal"."""
    return inp.variant if inp.variant in DECAL_SHAPES else "box"


def _decal(inp, td, strength, falloff, opacity):
    return M.decal_surfgrad(td, inp.pixels("normal"), np.array(inp.projector.matrix_world),
                            strength=strength, falloff=falloff, shape=decal_shape(inp),
                            opacity=opacity)


def _decal_overwrite(inp, td, falloff, opacity):
    n, base = M.procedural_basis_surfgrad(td, inp.pixels("detail"), inp.detail_uv)
    return M.decal_surfgrad(td, inp.pixels("normal"), np.array(inp.projector.matrix_world),
                            falloff=falloff, shape="cylinder", overwrite=True,
                            opacity=opacity, base_sg=base)


def _layered(inp, td, detail_strength, noise_amount):
    n, sg1 = M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map)
    _, sg2 = M.procedural_basis_surfgrad(td, inp.pixels("detail"), inp.detail_uv,
                                         strength=detail_strength)
    _, sg3 = M.volume_noise_surfgrad(td, NOISE_SCALE, noise_amount, NOISE_OCTAVES)
    scale_a, scale_b, mask_b = LAYER_COMBINE
    return n, scale_a * sg1 + (scale_b * mask_b) * sg2 + sg3


def _parallax_view(td):
    return normalize(M.unit_base_normal(td) + np.array(VIEW_TILT))


def _parallax(inp, td):
    offs = M.parallax_offset(td, inp.pixels("height"), _parallax_view(td), parallax_depth(inp),
                             POM_STEPS, inp.uv_map)
    return M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map,
                                 st=td.uv(inp.uv_map) + offs)


def _parallax_spread(inp, td):
    # In texels of the finer of the two images the march reads (height, then the normal map).
    width = max(inp.pixels("height").shape[1], inp.pixels("normal").shape[1])
    return march_spread_texels(td, _parallax_view(td), parallax_depth(inp), width, inp.uv_map)


def _post_resolve(inp, td, strength):
    n, sg = M.normal_map_surfgrad(td, inp.pixels("normal"), inp.uv_map)
    n1 = resolve_normal_from_surface_gradient(n, sg)
    _, sg2 = M.triplanar_surfgrad(td, inp.pixels("detail"), strength=strength, base_normal=n1)
    return n1, sg2


def _displace_bump(inp, td, scale, amount, octaves):
    return M.volume_noise_surfgrad(td, scale, amount, octaves,
                                   coords=td.point_attribute(REST_ATTRIBUTE))


def _blend(mode):
    method = {"blend-pd": "pd", "blend-whiteout": "whiteout", "blend-udn": "udn"}.get(mode)

    def reference(inp, td):
        n, t, bt = M.mikktspace_frame(td, inp.uv_map)
        uv = td.uv(inp.uv_map)
        a = M.decode_normal_map(sample_image(inp.pixels("normal"), uv))
        b = M.decode_normal_map(sample_image(inp.pixels("detail"), uv))
        if method is None:
            return n, surfgrad_blend_rnm(a, b, t, bt)
        return n, surfgrad_blend(method, a, t, bt, b, t, bt)
    return reference


def _height_blend(inp, td, contrast):
    """Rock (SG Height Map HQ of the height image, its height the image's Linear sample) and
    sand (SG Noise through SG Volume Gradient, its height the noise's value) by height."""
    r = relief(inp)
    n, rock = M.height_map_surfgrad(td, inp.pixels("height"), "hq", HEIGHT_BUMP_SCALE * r,
                                    inp.uv_map)
    rock_height = sample_image(inp.pixels("height"), td.uv(inp.uv_map))
    _, sand = M.volume_noise_surfgrad(td, NOISE_SCALE, NOISE_AMOUNT * r, NOISE_OCTAVES)
    sand_height, _ = M.noise_gradient_world(td, NOISE_SCALE, NOISE_OCTAVES)
    sg, _, _ = surfgrad_height_blend((rock, sand), (rock_height, sand_height), contrast,
                                     offsets=(0.0, SAND_LEVEL))
    return n, sg


# Parameters ---------------------------------------------------------------------------------------

def _strength(groups, function, default=1.0, name="strength"):
    return Parameter(name, default, "Strength", groups, function, "strength")


def _bump_scale(groups, function):
    return Parameter("bump_scale", HEIGHT_BUMP_SCALE, "Bump Scale", groups, function)


def _noise(default_scale, default_amount, default_octaves):
    f = M.volume_noise_surfgrad
    return (Parameter("scale", default_scale, "Scale", ("SG Noise",), f),
            Parameter("amount", default_amount, "Bump Scale", ("SG Volume Gradient",), f),
            Parameter("octaves", default_octaves, "Octaves", ("SG Noise",), f))


def _decal_settings(opacity):
    f = M.decal_surfgrad
    return (Parameter("falloff", DECAL_FALLOFF, "Falloff", ("SG Decal",), f),
            Parameter("opacity", opacity, "Opacity", ("SG Decal",), f))


def _sharpness(groups, function):
    """Listing 14's blend sharpness k (the Sharpness socket, 1..64)."""
    return Parameter("sharpness", 3.0, "Sharpness", groups, function, "k")


_NORMAL_MAP = _strength(("SG Normal Map",), M.normal_map_surfgrad)
_TRIPLANAR = _strength(("SG Triplanar",), M.triplanar_surfgrad)
_HEIGHT = _bump_scale(("SG Height Map Forward", "SG Height Map HQ", "SG Height Map One-Texel"),
                      M.height_map_surfgrad)
_TRIPLANAR_HEIGHT = _bump_scale(("SG Triplanar Height",), M.triplanar_height_surfgrad)


_SPECS = (
    MethodSpec("normal-map", _normal_map, reads=("normal",), parameters=(_NORMAL_MAP,),
               mikktspace=True),
    MethodSpec("procedural-basis", _procedural_basis, reads=("detail",),
               parameters=(_strength(("SG Tangent Normal",), M.procedural_basis_surfgrad),)),
    MethodSpec("object-normal", _object_normal, reads=("normal",)),
    MethodSpec("volume-noise", _volume_noise,
               parameters=_noise(NOISE_SCALE, NOISE_AMOUNT, NOISE_OCTAVES)),
    # SG Noise's Filter Footprint on: the octaves finer than the bake's footprint fade out (at
    # the comparison's 48 texels the third and fourth octaves are in or past the fade).
    MethodSpec("volume-noise-filtered", _volume_noise_filtered, stability=False,
               parameters=_noise(NOISE_SCALE, NOISE_AMOUNT, NOISE_OCTAVES)),
    MethodSpec("height-map", _height_map, reads=("height",), variants=M.HEIGHT_VARIANTS,
               parameters=(_HEIGHT,)),
    MethodSpec("triplanar", _triplanar, reads=("normal",), parameters=(
        _TRIPLANAR, _sharpness(("SG Triplanar",), M.triplanar_surfgrad))),
    MethodSpec("triplanar-height", _triplanar_height, reads=("height",),
               # the triplanar Listings, covered by "triplanar"
               parameters=(_TRIPLANAR_HEIGHT, _sharpness(("SG Triplanar Height",),
                                                         M.triplanar_height_surfgrad)),
               stability=False),
    MethodSpec("decal", _decal, reads=("normal",), variants=DECAL_SHAPES, adds="projector",
               parameters=(_strength(("SG Decal",), M.decal_surfgrad), *_decal_settings(1.0))),
    MethodSpec("decal-overwrite", _decal_overwrite, reads=("normal", "detail"), adds="projector",
               stability=False, parameters=_decal_settings(OVERWRITE_OPACITY)),
    MethodSpec("parallax", _parallax, reads=("height", "normal"), mikktspace=True,
               spread=_parallax_spread),
    # Two resolves of the methods the suite already runs.
    MethodSpec("post-resolve", _post_resolve, reads=("normal", "detail"), stability=False,
               mikktspace=True,
               parameters=(_strength(("SG Triplanar",), M.triplanar_surfgrad,
                                     POST_RESOLVE_STRENGTH),)),
    # Its hostile cases are the mesh's, not a texture's; its reference reads the displaced
    # mesh's rest positions.
    MethodSpec("displace-bump", _displace_bump, group="SG Displace", adds="modifier",
               stability=False, scene_only=True, parameters=_noise(*BUMP_ON_TOP)),
    MethodSpec("layered", _layered, reads=("normal", "detail"), mikktspace=True, parameters=(
        _strength(("SG Tangent Normal",), M.procedural_basis_surfgrad, LAYER_DETAIL,
                  name="detail_strength"),
        Parameter("noise_amount", LAYER_NOISE, "Bump Scale", ("SG Volume Gradient",),
                  M.volume_noise_surfgrad, "amount"))),
    # The Sampler groups (5.0+): the per-image methods' references, the image as a closure.
    MethodSpec("height-map-sampler", _height_map, reads=("height",),
               variants=("one-texel", "hq"),
               group="SG Height Map HQ (Sampler)", stability=False,
               same_reference_as="height-map",
               parameters=(_bump_scale(("SG Height Map HQ (Sampler)",
                                        "SG Height Map One-Texel (Sampler)"),
                                       M.height_map_surfgrad),)),
    MethodSpec("triplanar-sampler", _triplanar, reads=("normal",),
               group="SG Triplanar (Sampler)",
               stability=False, same_reference_as="triplanar",
               parameters=(_strength(("SG Triplanar (Sampler)",), M.triplanar_surfgrad),
                           _sharpness(("SG Triplanar (Sampler)",), M.triplanar_surfgrad))),
    MethodSpec("triplanar-height-sampler", _triplanar_height, reads=("height",),
               group="SG Triplanar Height (Sampler)", stability=False,
               same_reference_as="triplanar-height",
               parameters=(_bump_scale(("SG Triplanar Height (Sampler)",),
                                       M.triplanar_height_surfgrad),
                           _sharpness(("SG Triplanar Height (Sampler)",),
                                      M.triplanar_height_surfgrad))),
    MethodSpec("parallax-sampler", _parallax, reads=("height", "normal"),
               group="SG Parallax (Sampler)", stability=False, mikktspace=True,
               same_reference_as="parallax", spread=_parallax_spread),
    # Layers blended by height (reference/height_blend.py), over methods the suite runs.
    MethodSpec("height-blend", _height_blend, reads=("height",), stability=False, parameters=(
        Parameter("contrast", HEIGHT_BLEND_CONTRAST, "Contrast", ("SG Height Blend",),
                  surfgrad_height_blend),)),
    # RNM stands for the four blends in the stability suite (same decode, same SG Normal Map).
    *(MethodSpec(mode, _blend(mode), reads=("normal", "detail"), stability=mode == "blend-rnm",
                 mikktspace=True) for mode in BLEND_MODES),
)
SPECS = {s.name: s for s in _SPECS}
