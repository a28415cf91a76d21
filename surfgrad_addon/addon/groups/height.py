"""Section 3.7 and 4.4: scale-dependent bump from height (Listing 6) with derivatives from an
image (Listing 16, Eq. 20-21: HQ and one-texel) or forward differences (Listing 7), and the
triplanar projection of a height image."""

from ..node_vocabulary import Math, VMath
from ...reference import socket_specs as S
from . import common
from .common import (FORWARD_FILTER_WIDTH, ImageTaps, SamplerTaps, bump_surface_gradient, ensure,
                     held_images_name, image_group_name, images_stale, normal_input,
                     scaled_position_inputs, sub_group, surfgrad_reaching, texel_count_inputs,
                     uv_gradients_group, uv_input)
from .projection import triplanar_surface_gradient, triplanar_weights, weighted_derivatives


def height_image_node(b, image, vector, interpolation, extension):
    return ImageTaps(b, image, extension).height(vector, interpolation)


def _texel_offset(b, uv, du, dv):
    """uv + (du, dv): constants fold into one Vector Math node, sockets into a Combine XYZ."""
    if isinstance(du, float) and isinstance(dv, float):
        return b.vmath(VMath.ADD, uv, (du, dv, 0.0))
    return b.add(uv, b.combine(du, dv))


def _per_texel(b, x, size):
    return b.math(Math.MULTIPLY, x, size)


def _height_derivatives(b, taps, uv, w, h, variant):
    """dH/du and dH/dv (per texel) of Listing 16 at level 0; w, h floats (per-image groups)
    or sockets (sampler groups)."""
    const = isinstance(w, float)
    inv_w = 1.0 / w if const else b.math(Math.DIVIDE, 1.0, w)
    inv_h = 1.0 / h if const else b.math(Math.DIVIDE, 1.0, h)
    if variant == "one-texel":
        with b.frame("Listing 16 (level 0): forward differences one texel apart"):
            hc = taps.height(uv, "Linear")
            hr = taps.height(_texel_offset(b, uv, inv_w, 0.0), "Linear")
            hu = taps.height(_texel_offset(b, uv, 0.0, inv_h), "Linear")
            return b.math(Math.SUBTRACT, hr, hc), b.math(Math.SUBTRACT, hu, hc)
    with b.frame("Eq. 20/21: Sobel derivatives of the 4x4 block, bilinearly blended"):
        size = (w, h, 0.0) if const else b.combine(w, h, 0.0)
        f = b.vmath(VMath.SUBTRACT, b.vmath(VMath.MULTIPLY, uv, size), (0.5, 0.5, 0.0))
        fl = b.vmath(VMath.FLOOR, f)
        tx, ty, _ = b.separate(b.sub(f, fl))
        ax, ay = b.math(Math.SUBTRACT, 1.0, tx), tx
        bx, by = b.math(Math.SUBTRACT, 1.0, ty), ty

        def weights(p, q):
            def quarter(x):
                return b.math(Math.MULTIPLY, x, 0.25)
            smooth = [quarter(p), quarter(b.math(Math.ADD, b.math(Math.MULTIPLY, p, 2.0), q)),
                      quarter(b.math(Math.ADD, p, b.math(Math.MULTIPLY, q, 2.0))), quarter(q)]
            diff = [b.math(Math.MULTIPLY, p, -0.5), b.math(Math.MULTIPLY, q, -0.5),
                    b.math(Math.MULTIPLY, p, 0.5), b.math(Math.MULTIPLY, q, 0.5)]
            return smooth, diff
        smooth_u, diff_u = weights(ax, ay)
        smooth_v, diff_v = weights(bx, by)
        inv = (1.0 / w, 1.0 / h, 1.0) if const else b.combine(inv_w, inv_h, 1.0)
        du, dv = 0.0, 0.0
        for i in range(4):          # rows (v)
            for j in range(4):      # columns (u)
                # Texel centres: Closest taps of a per-image group; a sampler's Linear
                # interpolation returns the texel's own value there.
                centre = b.vmath(VMath.MULTIPLY, b.vmath(VMath.ADD, fl, (j - 0.5, i - 0.5, 0.0)),
                                 inv)
                q = taps.height(centre, "Closest")
                du = b.math(Math.ADD, du, b.math(Math.MULTIPLY, b.math(
                    Math.MULTIPLY, smooth_v[i], diff_u[j]), q))
                dv = b.math(Math.ADD, dv, b.math(Math.MULTIPLY, b.math(
                    Math.MULTIPLY, diff_v[i], smooth_u[j]), q))
        return du, dv


def _height_map_body(b, taps_for, variant, size):
    """The interface and interior shared by the per-image and the sampler height maps."""
    n = normal_input(b)
    uv = uv_input(b)
    scale = b.input(S.BUMP_SCALE)
    taps = taps_for(b)
    w, h = size(b)
    grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
    du, dv = _height_derivatives(b, taps, uv, w, h, variant)
    with b.frame("Listing 6 in surface gradients: W dH/du grad s + H dH/dv grad t"):
        sg = b.add(b.scale(grads.outputs[0], _per_texel(b, du, w)),
                   b.scale(grads.outputs[1], _per_texel(b, dv, h)))
    b.output(S.SURFACE_GRADIENT_OUT, b.scale(sg, scale))


def _check_variant(variant):
    if variant not in ("one-texel", "hq"):
        raise ValueError(f"height map variant {variant!r}: use 'one-texel' or 'hq' (the "
                         f"forward variant is SG Height Map Forward)")


HEIGHT_LABELS = {"hq": "HQ", "one-texel": "One-Texel"}


def _texel_size(image):
    """(width, height) of a height image, its texel step built in (no image: 1024^2). Refused
    where Blender holds no pixels of it (a missing or unreadable file reads 0 x 0): the step
    divided by zero, a raw ZeroDivisionError from the Add menu."""
    if image is None:
        return 1024, 1024
    if not image.size[0] or not image.size[1]:
        raise ValueError(f"image {image.name!r} has no pixels here (its file "
                         f"{image.filepath!r} is missing or unreadable), and the group steps "
                         f"by its texels: fix the image (Image > Replace), then add the group "
                         f"again")
    return image.size[0], image.size[1]


def height_map_group(image=None, variant="hq", extension="REPEAT"):
    """SG Height Map for one height image: Listing 16 at level 0 ('one-texel': three Linear
    taps one texel apart; 'hq': the 4x4 Closest block of Eq. 20/21), through Listing 6 in
    surface gradients: grad_S H = W dH/du grad s + H dH/dv grad t."""
    _check_variant(variant)
    w, h = _texel_size(image)

    def build(b):
        _height_map_body(b, lambda b: ImageTaps(b, image, extension), variant,
                         lambda b: (float(w), float(h)))
    same_image = images_stale(lambda count: [image] * count)

    def stale(tree):
        # Rebuild when the image it samples was replaced or removed, or changed size.
        # (an IDPropertyArray never equals a list: rebuilt at every use)
        return same_image(tree) or list(tree.get("surfgrad_size", ())) != [w, h]

    key = f"SG Height Map {HEIGHT_LABELS[variant]}"
    fields = {"image": image.name_full} if image is not None else {}
    tree = ensure(key, build, image_group_name(key, [image], extension), stale=stale,
                  held_name=held_images_name(key), **fields)
    tree["surfgrad_size"] = [w, h]
    return tree


def height_map_sampler_group(variant="hq"):
    """SG Height Map HQ / One-Texel (Sampler), Blender 5.0+: the same derivatives as
    height_map_group from any image, given as a Sampler closure with its Image Width and Height."""
    _check_variant(variant)
    name = f"SG Height Map {HEIGHT_LABELS[variant]} (Sampler)"
    common.require(name)
    return ensure(name, lambda b: _height_map_body(b, SamplerTaps, variant, texel_count_inputs))


def height_map_forward_group(filter_width=None):
    """Forward differences through the Bump node, Filter Width differentials apart (default
    FORWARD_FILTER_WIDTH, about a texel; another width gives a variant group, e.g. to keep the
    look of a converted Bump node)."""
    fw = FORWARD_FILTER_WIDTH if filter_width is None else float(filter_width)
    def build(b):
        n = normal_input(b)
        height, scale = b.input("Height"), b.input(S.BUMP_SCALE)
        with b.frame("Listing 7: forward differences along the render's differentials "
                     "(the Bump node, inverted: g = N - n / (n . N))"):
            g = bump_surface_gradient(b, height, n, fw, steep=True)
        b.output(S.SURFACE_GRADIENT_OUT, b.scale(g, scale))
    key = "SG Height Map Forward"
    return ensure(key, build, key + ("" if fw == FORWARD_FILTER_WIDTH else f" (filter {fw:g})"))


def bump_strength_group():
    """The Bump node's Strength on a surface gradient (for a converted Bump node, whose look must
    not change): Cycles and EEVEE blend the bumped normal toward the base, normalize(s nb + (1 -
    s) N) with nb = normalize(N - g), which is no linear scale of g. Listing 5 turns the blend
    back into a surface gradient; N - v where it faces away from N (s > 1 can tip it over)."""
    def build(b):
        n = normal_input(b)
        g, s = b.input(S.SURFACE_GRADIENT), b.input(S.NODE_STRENGTH)
        with b.frame("The Bump node's blend: v = normalize(s normalize(N - g) + (1 - s) N)"):
            s = b.math(Math.MAXIMUM, s, 0.0)
            nb = b.normalize(b.sub(n, g))
            v = b.normalize(b.add(b.scale(nb, s), b.scale(n, b.math(Math.SUBTRACT, 1.0, s))))
        with b.frame("Listing 5: N - v / (N . v); N - v where v faces away from N"):
            sg = surfgrad_reaching(b, n, v, n)
        b.output(S.SURFACE_GRADIENT_OUT, sg)
    return ensure(".SG Bump Strength", build)


def _triplanar_height_body(b, taps_for, sizes):
    n = normal_input(b)
    p, scale = scaled_position_inputs(b)
    k, bump = b.input(S.SHARPNESS), b.input(S.BUMP_SCALE)
    plane_taps = taps_for(b)
    plane_sizes = sizes(b)
    weights = triplanar_weights(b, n, k)
    x, y, z = b.separate(p)
    derivs = []
    planes = (("X: (z, y)", (z, y)), ("Y: (x, z)", (x, z)), ("Z: (x, y)", (x, y)))
    for (label, (u, v)), taps, (w, h) in zip(planes, plane_taps, plane_sizes):
        with b.frame(f"Plane {label}: Listing 16 one-texel derivative, per world unit"):
            uv = b.combine(u, v)
            du, dv = _height_derivatives(b, taps, uv, w, h, "one-texel")
            derivs.append((b.math(Math.MULTIPLY, du, b.math(Math.MULTIPLY, scale, w)),
                           b.math(Math.MULTIPLY, dv, b.math(Math.MULTIPLY, scale, h))))
    sg = triplanar_surface_gradient(b, n, weighted_derivatives(b, weights, derivs))
    b.output(S.SURFACE_GRADIENT_OUT, b.scale(sg, bump))


def triplanar_height_group(image=None, extension="REPEAT", images=None):
    """SG Triplanar Height for height images: `image` on all three planes, or `images`, one
    per plane (X, Y, Z). Per plane the one-texel derivative of Listing 16 (three Linear taps),
    in world units, into Listing 13's volume gradient with Listing 14's weights; Listing 8
    projects it."""
    plane_images = list(images) if images is not None else [image] * 3
    if len(plane_images) != 3 or images is not None and None in plane_images:
        raise ValueError("triplanar height needs one image or three (for X, Y and Z), "
                         "each an image: give `image` for every plane, or three `images`")
    sizes = [tuple(map(float, _texel_size(im))) for im in plane_images]

    def build(b):
        _triplanar_height_body(
            b, lambda b: [ImageTaps(b, im, extension) for im in plane_images],
            lambda b: sizes)

    same_images = images_stale(lambda count: [im for im in plane_images for _ in range(3)])
    stamp = [v for size in sizes for v in size]

    def stale(tree):
        # Rebuild when an image changed size too (its texel step is built in), as HQ does.
        return same_images(tree) or list(tree.get("surfgrad_size", ())) != stamp

    key = "SG Triplanar Height"
    tree = ensure(key, build, image_group_name(key, plane_images, extension), stale=stale,
                  held_name=held_images_name(key, planes=3))
    tree["surfgrad_size"] = stamp
    return tree


def triplanar_height_sampler_group():
    """SG Triplanar Height (Sampler), Blender 5.0+: one height image, given as a Sampler
    closure with its Image Width and Height, on all three planes."""
    name = "SG Triplanar Height (Sampler)"
    common.require(name)

    def build(b):
        _triplanar_height_body(b, lambda b: [SamplerTaps(b)] * 3,
                               lambda b: [texel_count_inputs(b)] * 3)
    return ensure(name, build)
