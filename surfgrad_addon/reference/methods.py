"""Whole bump methods evaluated on rasterised texels: the reference side of every bake.

Each `*_surfgrad` function returns (base_normal, surface_gradient) for the covered texels of a
TexelData, in world space, so contributions can be added before one resolve (Eq. 14); the
plain names resolve. Bake differentials stand in for ddx/ddy: x steps one bake texel along s
and y one along t (TexelData.texel_steps). Colour images are normal maps in [0, 1].
"""

import itertools
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import compiled, listing_kernels, normal_map_kernels, parallax_kernels, raster
from . import listings as L
from . import decals as D
from .cycles_bake import bump_differentials, uv_step
from .baselines import bump_screen_derivative_lxengine, perturb_normal_perlin1985, triplanar_geiss
from .height_map import deriv_from_height_map, deriv_three_tap
from .image_sampling import (exact_weights, height_image, images_unchanged, sample_colour,
                             sample_image)
from .parallax import parallax_occlusion_march, project_vec_to_texture_space
from .threads import reference_threads  # noqa: F401 (methods.reference_threads for callers)
from .noise import fractal_sum
from .noise_footprint import footprint_from_differentials
from .vecmath import (FLT_EPSILON, NODE_Z_FLOOR, TSPACE_Z_CLAMP, cross, dot, length, normalize,
                      stack_last, transform)

HEIGHT_VARIANTS = ("forward", "one-texel", "hq")
# Filter Width of the Forward variant's Bump node. Camera differentials in a render and a
# bake's differentials up to 5.0 are half a pixel / texel, so 2 steps about one, like the
# paper's one-pixel screen differences (a 5.2 bake steps two texels: blender_lines).
FORWARD_FILTER_WIDTH = 2.0


# Blocks per thread handed to the pool at once: the threads share them as they finish and
# the caller gets them in order, one window behind the threads.
WINDOW_BLOCKS = 4

_HEAP_KEPT = []


def keep_block_memory():
    """Keep freed block temporaries in the process instead of handing them back to the OS.

    glibc serves a block's 128 KB-1 MB temporaries from mmap or trims them off the heap when
    freed, so every block faults its pages in again (measured: Listing 9's frame on one
    16K-texel block 1.5 ms instead of 0.26 ms, and two block threads queue on the faults).
    Raising M_MMAP_THRESHOLD to 32 MB and M_TRIM_THRESHOLD to 256 MB keeps them on the heap.
    Process-wide and once; elsewhere than glibc (mallopt missing) nothing changes."""
    if _HEAP_KEPT:
        return
    _HEAP_KEPT.append(True)
    try:
        import ctypes
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return
    m_trim_threshold, m_mmap_threshold = -1, -3         # malloc.h
    mallopt(m_mmap_threshold, 32 << 20)
    mallopt(m_trim_threshold, 256 << 20)


def evaluated_blocks(fn, td, texels=None, threads=None, seconds=None):
    """(start, stop, block, fn(block)) for every block of td's texels, in order; fn runs on
    up to `threads` blocks at once (default reference_threads(), one for a small image). The first block runs alone
    (it fills the per-triangle arrays the others share). seconds: a one-item list the wall
    time spent in fn is added to."""
    if not threads:
        threads = reference_threads()
        # Under two windows of blocks (a 256^2 image is 4 blocks) threads only contend for
        # the GIL: measured 58 ns a texel on one thread against 66 on two (normal-map, 256^2).
        if td.texel_count < 2 * WINDOW_BLOCKS * threads * (texels or raster.BLOCK_TEXELS):
            threads = 1
    keep_block_memory()
    blocks = td.blocks(texels)
    first = next(blocks, None)
    if first is None:
        return
    timer = seconds if seconds is not None else [0.0]
    with images_unchanged():
        t0 = time.perf_counter()
        value = fn(first[2])
        timer[0] += time.perf_counter() - t0
        yield (*first, value)
        if threads == 1:
            for start, stop, block in blocks:
                t0 = time.perf_counter()
                value = fn(block)
                timer[0] += time.perf_counter() - t0
                yield start, stop, block, value
            return
        with ThreadPoolExecutor(threads) as pool:
            # Two windows in flight: the threads work on the next window while the caller
            # takes the current one's values, in order (a window at a time left the threads
            # idle while the caller worked through its values).
            t0 = time.perf_counter()
            waiting = 0.0                           # the caller's time between values
            ahead = _submitted(pool, fn, blocks, WINDOW_BLOCKS * threads)
            while ahead:
                current, ahead = ahead, _submitted(pool, fn, blocks, WINDOW_BLOCKS * threads)
                for (start, stop, block), future in current:
                    value = future.result()
                    t1 = time.perf_counter()
                    yield start, stop, block, value
                    waiting += time.perf_counter() - t1
            timer[0] += time.perf_counter() - t0 - waiting


def _submitted(pool, fn, blocks, count):
    """The next `count` blocks handed to the pool: [((start, stop, block), future)]."""
    return [((start, stop, block), pool.submit(fn, block))
            for start, stop, block in itertools.islice(blocks, count)]


def evaluate_in_blocks(fn, td, texels=None, threads=None):
    """fn(block) -> (n, ...) array on every block of td's texels (TexelData.blocks), gathered
    into one (N, ...) array: the whole bake's result with working memory of a few blocks."""
    out = None
    for start, stop, block, value in evaluated_blocks(fn, td, texels, threads):
        value = np.asarray(value)
        if out is None:
            # Component by component (vecmath's layout), as blocks come: contiguous copies.
            out = np.empty((td.texel_count,) + value.shape[1:], dtype=value.dtype, order="F")
        out[start:stop] = value
    if out is None:                             # nothing covered: an empty result
        out = np.asarray(fn(td))
    return out


def unit_base_normal(td):
    """The base normal of every method: the renderer's unit shading normal."""
    return td.shading_normal


def decode_normal_map(rgb):
    return 2.0 * np.asarray(rgb, dtype=np.float64)[..., :3] - 1.0


def _colour_rows(rgb):
    """A sampled (N, C >= 3) colour as the compiled kernels read it, (C, N) contiguous, or
    None where they do not apply (other shapes)."""
    rgb = np.asarray(rgb)
    if not compiled.enabled() or rgb.ndim != 2 or rgb.shape[1] < 3 or \
            rgb.dtype not in (np.float32, np.float64):
        return None
    return np.ascontiguousarray(rgb.T)


def colour_to_derivative(rgb, flip_vertical=False):
    """Listing 2 on a sampled normal-map colour: tspace_normal_to_derivative(decode(rgb))."""
    rows = _colour_rows(rgb)
    if rows is None:
        return L.tspace_normal_to_derivative(decode_normal_map(rgb), flip_vertical)
    out = np.empty((2, rows.shape[1]))
    normal_map_kernels.colour_to_listing2_derivative(rows, -1.0 if flip_vertical else 1.0, out)
    return out.T


def mikktspace_frame(td, uv_map=None):
    """Listing 9's frame (n/|n|, t/|n|, b/|n|) in world space, built as Blender's Normal Map
    node does: tangent, sign and the normal interpolated in object space (the normal
    unnormalised up to 5.0, unit in 5.2: TexelData.normal_map_normal_object),
    b = sign * cross(n, t) there, and all three taken to world space by the normal matrix
    (Cycles combines in object space and transforms the result as a normal)."""
    if compiled.enabled():
        return _mikktspace_frame_compiled(td, uv_map)
    t_obj, sign = td.tangent_object(uv_map)
    n_obj = td.normal_map_normal_object
    b_obj = np.asarray(sign)[:, None] * cross(n_obj, t_obj)
    nm = td.mesh.normal_matrix.T
    n_w, t_w, b_w = transform(n_obj, nm), transform(t_obj, nm), transform(b_obj, nm)
    renorm = 1.0 / length(n_w)
    return n_w * renorm, t_w * renorm, b_w * renorm


def _mikktspace_frame_compiled(td, uv_map=None):
    """mikktspace_frame in one pass per texel (normal_map_kernels.mikktspace_frame)."""
    name = uv_map or td.uv_map
    if name not in td.mesh.tangents:
        td.tangent_object(name)                 # its KeyError names the fix
    normals, unit = td.normal_map_normal_corners()
    nm = np.ascontiguousarray(td.mesh.normal_matrix.T)
    n = td.texel_count
    out = [np.empty((3, n)) for _ in range(3)]
    normal_map_kernels.mikktspace_frame(
        td.corner_table(td.mesh.tangents[name]), td.corner_table(td.mesh.tangent_signs[name]),
        td.corner_table(normals), unit, np.ascontiguousarray(td.tri),
        np.ascontiguousarray(td.barycentric), nm, bool(np.array_equal(nm, np.eye(3))), *out)
    return tuple(o.T for o in out)


def normal_map_node_derivative(rgb, strength=1.0, directx=False):
    """Eq. 15 on the Normal Map node's colour: decode, the node's Strength
    (normal_map_strength), -(x, y) / z; y negated for a DirectX map."""
    rows = _colour_rows(rgb) if np.ndim(strength) == 0 else None
    if rows is not None:
        out = np.empty((2, rows.shape[1]))
        normal_map_kernels.normal_map_node_derivative(
            rows, float(strength), float(np.clip(strength, 0.0, 1.0)), bool(directx), out)
        return out.T
    ms = normal_map_strength(decode_normal_map(rgb), strength)
    # Eq. 15 on the node's colour: its z is already Listing 2's clamp (and > 0).
    deriv = -ms[..., :2] / ms[..., 2:3]
    if directx:
        deriv[..., 1] *= -1.0
    return deriv


def parallax_offset(td, height, view, bump_scale, steps=8, uv_map=None):
    """The parallax-occlusion texture offset (Listing 11's vector, the fixed-step march of
    reference/parallax.py) for unit view directions `view` (N, 3) toward the viewer."""
    n = unit_base_normal(td)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps(uv_map)
    v = project_vec_to_texture_space(n, dpdx, dpdy, dst_dx, dst_dy, view, bump_scale)
    st = td.uv(uv_map)
    height = height_image(height)
    if compiled.enabled() and exact_weights() and height.dtype == np.float64 and \
            height.ndim == 2 and st.dtype == v.dtype == np.float64:
        return parallax_kernels.march(height, st, v, steps)
    return parallax_occlusion_march(lambda q: sample_image(height, q), st, v, steps)


def normal_map_strength(m, strength):
    """The Normal Map node's Strength on a tangent-space normal (Cycles' svm_node_normal_map,
    every supported line): x and y scaled, z blended toward 1 by saturate(strength). Applied
    after Listing 2's z clamp, so 1 is the map, 0 is flat, and from 1 up it scales the
    derivative of Eq. 15 linearly."""
    m = np.array(m, dtype=np.float64 if np.asarray(m).dtype != np.float32 else np.float32)
    ma = np.abs(m)
    # Listing 2's clamp as SG Normal Map's colour makes it, over NODE_Z_FLOOR (vecmath).
    z = np.maximum(ma[..., 2], np.maximum(ma[..., 0], ma[..., 1]) * TSPACE_Z_CLAMP + NODE_Z_FLOOR)
    k = np.clip(strength, 0.0, 1.0)
    m[..., 0] *= strength
    m[..., 1] *= strength
    # (1 - k) + k z >= k z: the floor only undoes rounding, where k = 1 took 1 + (z - 1) to 0
    # for m = 0 (a (0.5, 0.5, 0.5) texel): a NaN derivative, which dropped every other layer
    # added to this one in the resolve.
    m[..., 2] = np.maximum(1.0 + k * (z - 1.0), k * z)
    return m


def normal_map_surfgrad(td, image, uv_map=None, strength=1.0, interpolation="Linear",
                        st=None, directx=False):
    """SG Normal Map: MikkTSpace tangent-space map on a UV map with stored tangents. Listing 2's
    derivative (strength applied) resolved on the frame of Blender's Normal Map node
    (Listings 3 and 9: normalize(n_f - (d.x t + d.y b)) with t, b scaled by 1/|n|), then
    Listing 5 against the shading normal n: resolved against n it lands exactly on the map's
    normal, and it adds to other surface gradients. strength: the Normal Map node's
    (normal_map_strength), so converting the node keeps its look at every Strength.
    directx: the map's green channel points down (DirectX convention; Listing 2's flip)."""
    n_f, t, b = mikktspace_frame(td, uv_map)
    n = unit_base_normal(td)
    deriv = normal_map_node_derivative(
        sample_colour(image, td.uv(uv_map) if st is None else st, interpolation), strength,
        directx)
    if compiled.enabled() and all(a.dtype == np.float64 and a.ndim == 2
                                  for a in (n_f, t, b, deriv, n)):
        out = np.empty((3, len(n)))
        normal_map_kernels.reach_normal(*(np.ascontiguousarray(a.T) for a in (n_f, t, b, deriv, n)),
                                        out)
        return n, out.T
    v = normalize(n_f - L.surfgrad_from_tbn(deriv, t, b))
    # Where v faces away from n (strong non-uniform scale) no tangent surface gradient
    # reaches it; n - v still resolves to it.
    away = dot(n, v) < FLT_EPSILON
    return n, np.where(away, n - v, L.surfgrad_from_perturbed_normal(n, v))


def procedural_basis_surfgrad(td, image, uv_map, strength=1.0, interpolation="Linear"):
    """SG Procedural Basis: a tangent frame generated from the UV map's derivatives (L4)."""
    n = unit_base_normal(td)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps(uv_map)
    t, b = L.gen_basis_tb(n, dpdx, dpdy, dst_dx, dst_dy)
    deriv = colour_to_derivative(sample_colour(image, td.uv(uv_map), interpolation))
    return n, strength * L.surfgrad_from_tbn(deriv, t, b)


def height_map_surfgrad(td, height, variant="hq", bump_scale=1.0, uv_map=None,
                        interpolation="Linear"):
    """SG Height Map: scale-dependent bump (L6) with the height's derivative from Listing 7
    ('forward': three taps along the bake's differentials, as Blender's Bump node takes them),
    or Listing 16 at level 0 ('one-texel', 'hq'). bump_scale: world units per unit height."""
    if variant not in HEIGHT_VARIANTS:
        raise ValueError(f"unknown height-map variant {variant!r}; use one of {HEIGHT_VARIANTS}")
    n = unit_base_normal(td)
    st = td.uv(uv_map)
    height = height_image(height)
    if variant == "forward":
        # Listing 7's screen-space taps, with the differentials a Cycles bake gives its
        # Bump node (the Forward variant is that node), FORWARD_FILTER_WIDTH steps long
        # where the line's Bump node has a Filter Width.
        fw = td.facts.bump_step_scale(FORWARD_FILTER_WIDTH)
        dpdx, dpdy = (fw * d for d in bump_differentials(td))
        h_c = sample_image(height, st, interpolation)
        h_x = sample_image(height, st + uv_step(td, dpdx, uv_map), interpolation)
        h_y = sample_image(height, st + uv_step(td, dpdy, uv_map), interpolation)
        d = stack_last([h_x - h_c, h_y - h_c])
        sg = L.surfgrad_scale_dependent(n, dpdx, dpdy, d, None, None, None,
                                        is_deriv_screen_space=True)
    else:
        dpdx, dpdy, dst_dx, dst_dy = td.texel_steps(uv_map)
        d = deriv_from_height_map(height, st, hq=(variant == "hq"), interpolation=interpolation)
        dim = (np.shape(height)[1], np.shape(height)[0])
        sg = L.surfgrad_scale_dependent(n, dpdx, dpdy, d, dst_dx, dst_dy, dim)
    return n, bump_scale * sg


def noise_gradient_world(td, scale=4.0, octaves=4, coords=None, footprint_filter=False):
    """Fractal-sum noise of the object-space position (or `coords`) and its gradient in world
    space (object gradient times the scale, through the inverse transpose). footprint_filter:
    fade the octaves finer than the footprint SG Noise's Filter Footprint measures from the
    bake's differentials (noise_footprint.footprint_from_differentials)."""
    p = td.position_object if coords is None else coords
    footprint = bake_noise_footprint(td, scale) if footprint_filter else None
    h, g = fractal_sum(p * scale, octaves=octaves, footprint=footprint)
    g *= scale
    return h, transform(g, td.mesh.normal_matrix.T)


def bake_noise_footprint(td, scale):
    """The footprint, in noise coordinates (object position x scale), that SG Noise's Bump
    nodes measure in a bake: the bake's differentials, the shading normal they are taken
    against, and J = scale M^-1 (world to object: v @ M^-T is M^-1 v)."""
    dpdx, dpdy = bump_differentials(td)
    nm = td.mesh.normal_matrix
    jx, jy = (scale * transform(d, nm) for d in (dpdx, dpdy))
    return footprint_from_differentials(dpdx, dpdy, unit_base_normal(td), jx, jy)


def volume_noise_surfgrad(td, scale=4.0, amount=0.05, octaves=4, coords=None,
                          footprint_filter=False):
    """SG Noise through SG Volume Gradient (L8). coords: object-space positions to evaluate
    the noise at (default the texels' own; for bump on a displaced surface, its rest
    position, as in Gustavson's fragment shader). footprint_filter: SG Noise's Filter
    Footprint (octaves finer than the bake's footprint fade out)."""
    n = unit_base_normal(td)
    _, g = noise_gradient_world(td, scale, octaves, coords, footprint_filter)
    return n, amount * L.surfgrad_from_volume_gradient(n, g)


def triplanar_samples(td, image, scale=1.0, interpolation="Linear"):
    """Derivatives of the three planar projections of a normal map, sampled at world (z, y),
    (x, z) and (x, y) times `scale` (Eq. 19's planes)."""
    p = td.position * scale
    return [colour_to_derivative(sample_colour(image, stack_last([p[:, ax[0]], p[:, ax[1]]]),
                                               interpolation))
            for ax in ((2, 1), (0, 2), (0, 1))]


def triplanar_surfgrad(td, image, scale=1.0, k=3.0, strength=1.0, base_normal=None):
    """SG Triplanar (L13 with L14's weights); base_normal replaces the shading normal for
    post-resolve bump mapping (section 4.6: weights and projection follow it)."""
    n = unit_base_normal(td) if base_normal is None else base_normal
    w = L.determine_triplanar_weights(n, k)
    return n, strength * L.surfgrad_from_triplanar_projection(n, w, *triplanar_samples(
        td, image, scale))


def triplanar_height_surfgrad(td, height, scale=1.0, k=3.0, bump_scale=1.0):
    """SG Triplanar Height: a height image on the three planes (or a list of three, for X,
    Y and Z), each plane's one-texel derivative (Listing 16) in world units, into Listing 13
    with Listing 14's weights."""
    n = unit_base_normal(td)
    w = L.determine_triplanar_weights(n, k)
    heights = list(height) if isinstance(height, (list, tuple)) else [height] * 3
    p = td.position * scale
    d = [deriv_from_height_map(hgt, stack_last([p[:, ax[0]], p[:, ax[1]]]))
         * np.array([np.shape(hgt)[1] * scale, np.shape(hgt)[0] * scale])
         for hgt, ax in zip(heights, ((2, 1), (0, 2), (0, 1)))]
    return n, bump_scale * L.surfgrad_from_triplanar_projection(n, w, *d)


def decal_frame(projector):
    """Projector matrix (4x4, object to world of a unit cube [-1, 1]^3) to its unit axes and
    the world-to-projector transform."""
    m = np.asarray(projector, dtype=np.float64)
    axes = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    return axes[:, 0], axes[:, 1], axes[:, 2], np.linalg.inv(m)


def decal_surfgrad(td, image, projector, strength=1.0, falloff=0.2, shape="box",
                   overwrite=False, opacity=1.0, base_sg=None):
    """SG Decal (L15): the map projected along the projector's -z over [-1, 1]^2 of its local
    x, y, weighted by the projector shape's falloff (reference/decals.py; a bump scale,
    footnote 2 of the paper) and by `opacity`; added to `base_sg` (the surface gradient
    underneath) or, with `overwrite`, replacing it by that weight."""
    n = unit_base_normal(td)
    ax, ay, _, to_local = decal_frame(projector)
    local = transform(td.position, to_local[:3, :3].T) + to_local[:3, 3]
    st = local[:, :2] * 0.5 + 0.5
    # A tangent-space normal map is TBN-style (slopes in its own unit frame), so its
    # derivative goes straight onto the unit projector axes, independent of the box size.
    deriv = colour_to_derivative(sample_colour(image, st))
    weight = opacity * D.WEIGHTS[shape](local, falloff)
    sg = strength * opacity * D.SURFGRAD_FROM_DECAL[shape](n, deriv, ax, ay, local, falloff)
    base = np.zeros_like(sg) if base_sg is None else base_sg
    return n, D.decal_layer(base, sg, weight, overwrite)


def resolve(n_sg):
    n, sg = n_sg
    if compiled.enabled() and all(isinstance(a, np.ndarray) and a.dtype == np.float64 and
                                  a.ndim == 2 and a.shape[1:] == (3,) for a in (n, sg)) \
            and n.shape == sg.shape:
        return listing_kernels.resolve(n, sg)
    return L.resolve_normal_from_surface_gradient(n, sg)


def layered_normal(td, normal_image, detail_image, detail_uv="Detail", noise_amount=0.02):
    """The Figure 1 stack: a normal map on the first UV map, generic detail on a second UV map
    through the procedural basis, noise on top; one sum of surface gradients, one resolve."""
    n, sg1 = normal_map_surfgrad(td, normal_image)
    _, sg2 = procedural_basis_surfgrad(td, detail_image, detail_uv, strength=0.5)
    _, sg3 = volume_noise_surfgrad(td, amount=noise_amount)
    return L.resolve_normal_from_surface_gradient(n, sg1 + sg2 + sg3)


# Baselines, evaluated on the same texels for comparison.

def volume_noise_perlin1985(td, scale=4.0, amount=0.05, octaves=4):
    _, g = noise_gradient_world(td, scale, octaves)
    return perturb_normal_perlin1985(unit_base_normal(td), amount * g)


def triplanar_geiss_normal(td, image, scale=1.0, k=3.0):
    n = unit_base_normal(td)
    p = td.position * scale
    ms = [decode_normal_map(sample_colour(image, stack_last([p[:, ax[0]], p[:, ax[1]]])))
          for ax in ((2, 1), (0, 2), (0, 1))]
    return triplanar_geiss(n, L.determine_triplanar_weights(n, k), *ms)


def height_map_lxengine(td, height, bump_scale=1.0, uv_map=None):
    n = unit_base_normal(td)
    dpdx, dpdy, dst_dx, dst_dy = td.texel_steps(uv_map)
    d = bump_scale * deriv_three_tap(height, td.uv(uv_map), dst_dx, dst_dy)
    return bump_screen_derivative_lxengine(n, dpdx, dpdy, d[:, 0], d[:, 1])
