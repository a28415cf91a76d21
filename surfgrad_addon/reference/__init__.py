"""surfgrad's reference evaluator: the surface-gradient framework in pure numpy (no bpy).

The oracle that the Blender node groups and Cycles bakes are checked against. Functions take
arrays of shape (..., 3) / (..., 2) and compute in float64, or float32 when every array input
is float32. Names follow the paper's listings (Mikkelsen, JCGT 2020) in snake_case.
"""

from .listings import (derivative_to_tspace_normal, determine_triplanar_weights,
                       gen_basis_tb, resolve_normal_from_surface_gradient, sigma_vectors,
                       surfgrad_from_decal, surfgrad_from_perturbed_normal, surfgrad_from_tbn,
                       surfgrad_from_triplanar_projection, surfgrad_from_volume_gradient,
                       surfgrad_scale_dependent, triplanar_volume_gradient,
                       tspace_normal_to_derivative)
from .prologue import (BumpPrologue, bump_prologue, mikkts_bitangent, mikkts_renormalize,
                       screen_deriv_of_pos_no_ddxy, two_sided_flip)
from .parallax import (parallax_occlusion_march, parallax_offset_limited,
                       project_vec_to_texture_space, tex_space_offs_to_surface)
from .compositing import (blend_pd, blend_rnm, blend_udn, blend_whiteout, post_resolve_bump,
                          surfgrad_blend, surfgrad_blend_rnm, table1_inputs)
from .image_sampling import (BAKE_TEXEL_OFFSET, bake_sample_points, sample_image,
                             texel_centres)
from .height_map import deriv_from_height_map, deriv_three_tap
from .noise import (dented, fractal_sum, gradient_noise, hash_uint3, hash_uint4,
                    lattice_gradient, turbulence, white_noise_color)
from .displacement import displace_along_normal, displaced_normal
from .baselines import (bump_screen_derivative_lxengine, decal_projector_normal,
                        perturb_normal_perlin1985, triplanar_derivative_perlin, triplanar_geiss)
from .mesh_arrays import MeshArrays
from .raster import rasterize
from .texels import TexelData
from .decals import (DECAL_SHAPES, decal_weight_box, decal_weight_capsule,  # noqa: F401
                     decal_weight_cone, decal_weight_cylinder, decal_weight_sphere,
                     decal_weight_wedge, surfgrad_from_decal_box, surfgrad_from_decal_capsule,
                     surfgrad_from_decal_cone, surfgrad_from_decal_cylinder,
                     surfgrad_from_decal_sphere, surfgrad_from_decal_wedge)
from . import compiled, input_checks, raster, tiles
from . import images, meshes, methods
