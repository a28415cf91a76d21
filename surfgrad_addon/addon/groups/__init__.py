"""The surface-gradient framework as shader node groups, one builder per group, one module per
section of the paper (Mikkelsen, JCGT 9(3), 2020); Gustavson's displacement in Geometry Nodes.

Shader nodes have no ddx/ddy. What they have instead (pinned in tests/test_blender_facts.py):
the Bump node. Fed a scalar h with Strength 1, Distance 1 and base normal N it returns
n = normalize(N - grad_S h) (its forward differences are exact for h linear on a triangle, such
as a UV coordinate), so g = N - n / dot(n, N) recovers the surface gradient grad_S h
(".SG Surface Gradient"). The surface gradients of a UV map's s and t carry everything
Listings 4 and 6 need from dP/dx, dP/dy and d(st)/dx, d(st)/dy; the builders rewrite those
listings in them (the screen basis cancels).

GROUPS is the one table of what the Add menus offer: name, builder, whether it is built per
image, tree type, the oldest Blender line that has it, in menu order.
"""

from dataclasses import dataclass
from typing import Callable

from . import common  # noqa: F401 (VERSION lives there; builders read it at call time)
from .common import (SAMPLER_GROUPS, BUMP_FILTER_WIDTH, FORWARD_FILTER_WIDTH, GATED_HELPERS, REQUIRES,  # noqa: F401
                     VERSION, FeatureUnavailable, decode_tangent_normal, directx_input,
                     image_group_name, normal_input, safe_normal_group, sub_group, surface_gradient_group,
                     unavailable_reason, uv_gradients_group)
from .displacement import REST_ATTRIBUTE, displace_group, rest_position_group  # noqa: F401
from .height_blend import height_blend_group
from .height import (bump_strength_group, height_map_forward_group, height_map_group,  # noqa: F401
                     height_map_sampler_group, triplanar_height_group,
                     triplanar_height_sampler_group)
from .parallax import POM_STEPS, parallax_group, parallax_sampler_group  # noqa: F401
from .projection import (decal_coordinates_group, decal_group, projector_coordinates_group,
                         triplanar_coordinates_group, triplanar_group,
                         triplanar_sampler_group, triplanar_surface_gradient,  # noqa: F401
                         triplanar_weights)
from .resolve import combine_group, resolve_group
from .tangent_space import (blend_normals_group, mikktspace_frame_group,  # noqa: F401
                            normal_map_group, procedural_basis_group, tangent_normal_group)
from .volume import (NOISE_OCTAVES, gradient_noise_group, noise_group,  # noqa: F401
                     object_normal_group, volume_gradient_group)


@dataclass(frozen=True)
class GroupEntry:
    name: str
    build: Callable
    image_bound: bool = False         # built for one image (the active Image Texture's)
    tree_type: str = "ShaderNodeTree"
    min_line: str = "4.2"             # the oldest supported line that has it (REQUIRES says why)
    # The group the menu offers instead where that one can be built (the per-image groups
    # give way to their Sampler group from Blender 5.0).
    superseded_by: str = ""


GROUPS = (
    GroupEntry("SG Resolve", resolve_group),
    GroupEntry("SG Volume Gradient", volume_gradient_group),
    GroupEntry("SG Object Normal", object_normal_group),
    GroupEntry("SG Procedural Basis", procedural_basis_group),
    GroupEntry("SG Tangent Normal", tangent_normal_group),
    GroupEntry("SG Normal Map", normal_map_group),
    GroupEntry("SG Blend Normals", blend_normals_group),
    GroupEntry("SG Noise", noise_group),
    GroupEntry("SG Triplanar Coordinates", triplanar_coordinates_group),
    GroupEntry("SG Triplanar", triplanar_group),
    GroupEntry("SG Triplanar (Sampler)", triplanar_sampler_group, min_line="5.0"),
    GroupEntry("SG Projector Coordinates", projector_coordinates_group),
    GroupEntry("SG Decal Coordinates", decal_coordinates_group),
    GroupEntry("SG Decal", decal_group),
    GroupEntry("SG Combine", combine_group),
    GroupEntry("SG Height Blend", height_blend_group),
    GroupEntry("SG Height Map HQ", height_map_group, image_bound=True,
               superseded_by="SG Height Map HQ (Sampler)"),
    GroupEntry("SG Height Map HQ (Sampler)", height_map_sampler_group, min_line="5.0"),
    GroupEntry("SG Height Map One-Texel (Sampler)",
               lambda: height_map_sampler_group("one-texel"), min_line="5.0"),
    GroupEntry("SG Height Map Forward", height_map_forward_group),
    GroupEntry("SG Triplanar Height", triplanar_height_group, image_bound=True,
               superseded_by="SG Triplanar Height (Sampler)"),
    GroupEntry("SG Triplanar Height (Sampler)", triplanar_height_sampler_group,
               min_line="5.0"),
    GroupEntry("SG Parallax", parallax_group, image_bound=True,
               superseded_by="SG Parallax (Sampler)"),
    GroupEntry("SG Parallax (Sampler)", parallax_sampler_group, min_line="5.0"),
    GroupEntry("SG Rest Position", rest_position_group),
    GroupEntry("SG Displace", displace_group, tree_type="GeometryNodeTree", min_line="4.5"),
)
BY_NAME = {entry.name: entry for entry in GROUPS}
# (menu name, builder) in menu order, per editor.
MENU_GROUPS = [(e.name, e.build) for e in GROUPS if e.tree_type == "ShaderNodeTree"]
GEOMETRY_MENU_GROUPS = [(e.name, e.build) for e in GROUPS if e.tree_type == "GeometryNodeTree"]


def build_all():
    """Create (or update) every shader menu group this Blender can build (the Sampler groups
    need 5.0) and its helpers; returns {name: tree}."""
    return {name: build() for name, build in MENU_GROUPS if unavailable_reason(name) is None}


def offered(name):
    """True when the Add menu offers group `name` here: it can be built, and no group that
    supersedes it can (Blender 5.0+ offers the Sampler groups, 4.2/4.5 the per-image ones)."""
    entry = BY_NAME[name]
    if unavailable_reason(name) is not None:
        return False
    return not (entry.superseded_by and unavailable_reason(entry.superseded_by) is None)
