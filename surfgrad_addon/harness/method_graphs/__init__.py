"""Every registry method's node graph (the bpy-free rest of each method is in
reference/method_registry.py): GRAPHS[name](inp, g) -> a surface-gradient socket, or an already
resolved "Normal" socket, built on a harness Graph of the bake material."""

from ...reference.method_registry import BLEND_MODES
from .height_blend import height_blend_graph
from .images import (blend_graph, height_map_graph, normal_map_graph, object_normal_graph,
                     parallax_graph, procedural_basis_graph)
from .projection import (decal_graph, decal_overwrite_graph, triplanar_graph,
                         triplanar_height_graph)
from .samplers import (height_map_sampler_graph, parallax_sampler_graph,
                       triplanar_height_sampler_graph, triplanar_sampler_graph)
from .volume import (displace_bump_graph, layered_graph, post_resolve_graph,
                     volume_noise_filtered_graph, volume_noise_graph)

GRAPHS = {
    "normal-map": normal_map_graph,
    "procedural-basis": procedural_basis_graph,
    "object-normal": object_normal_graph,
    "volume-noise": volume_noise_graph,
    "volume-noise-filtered": volume_noise_filtered_graph,
    "height-map": height_map_graph,
    "triplanar": triplanar_graph,
    "triplanar-height": triplanar_height_graph,
    "decal": decal_graph,
    "decal-overwrite": decal_overwrite_graph,
    "parallax": parallax_graph,
    "post-resolve": post_resolve_graph,
    "displace-bump": displace_bump_graph,
    "layered": layered_graph,
    "height-map-sampler": height_map_sampler_graph,
    "triplanar-sampler": triplanar_sampler_graph,
    "triplanar-height-sampler": triplanar_height_sampler_graph,
    "parallax-sampler": parallax_sampler_graph,
    "height-blend": height_blend_graph,
    **{mode: blend_graph(mode) for mode in BLEND_MODES},
}
