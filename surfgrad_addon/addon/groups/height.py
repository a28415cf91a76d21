"""Section 3.7 and 4.4: scale-dependent bump from height (Listing 6) with derivatives from an
image (Listing 16, Eq. 20-21: HQ and one-texel) or forward differences (Listing 7), and the
triplanar projection of a height image."""

from ..node_builder import ensure_group
from ...reference.vecmath import FLT_EPSILON
from . import common
from .common import (FORWARD_FILTER_WIDTH, images_stale, normal_input, scaled_position_inputs,
                     sub_group, uv_gradients_group, uv_input)
from .projection import triplanar_surface_gradient, triplanar_weights


def height_image_node(b, image, vector, interpolation, extension):
    node = b.node("ShaderNodeTexImage", interpolation=interpolation, extension=extension)
    node.image = image
    b.link(vector, node.inputs["Vector"])
    return b.separate(node.outputs["Color"])[0]


def height_map_group(image=None, variant="hq", extension="REPEAT"):
    """SG Height Map for one height image: Listing 16 at level 0 ('one-texel': three Linear
    taps one texel apart; 'hq': the 4x4 Closest block of Eq. 20/21), through Listing 6 in
    surface gradients: grad_S H = W dH/du grad s + H dH/dv grad t."""
    if variant not in ("one-texel", "hq"):
        raise ValueError(f"height map variant {variant!r}: use 'one-texel' or 'hq' (the "
                         f"forward variant is SG Height Map Forward)")
    w, h = (image.size[0], image.size[1]) if image is not None else (1024, 1024)

    def build(b):
        n = normal_input(b)
        uv = uv_input(b, "Texture coordinate of the height image (link a UV Map node for another map)")
        scale = b.input("Bump Scale", "FLOAT", "World units of displacement per unit of height",
                        default=0.05, min_value=-1000.0, max_value=1000.0)
        grads = sub_group(b, uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
        if variant == "one-texel":
            with b.frame("Listing 16 (level 0): forward differences one texel apart"):
                hc = height_image_node(b, image, uv, "Linear", extension)
                hr = height_image_node(b, image, b.vmath("ADD", uv, (1.0 / w, 0.0, 0.0)),
                                        "Linear", extension)
                hu = height_image_node(b, image, b.vmath("ADD", uv, (0.0, 1.0 / h, 0.0)),
                                        "Linear", extension)
                du, dv = b.math("SUBTRACT", hr, hc), b.math("SUBTRACT", hu, hc)
        else:
            with b.frame("Eq. 20/21: Sobel derivatives of the 4x4 block, bilinearly blended"):
                f = b.vmath("SUBTRACT", b.vmath("MULTIPLY", uv, (float(w), float(h), 0.0)),
                            (0.5, 0.5, 0.0))
                fl = b.vmath("FLOOR", f)
                tx, ty, _ = b.separate(b.sub(f, fl))
                ax, ay = b.math("SUBTRACT", 1.0, tx), tx
                bx, by = b.math("SUBTRACT", 1.0, ty), ty

                def weights(p, q):
                    smooth = [b.math("MULTIPLY", p, 0.25),
                              b.math("MULTIPLY", b.math("ADD", b.math("MULTIPLY", p, 2.0), q), 0.25),
                              b.math("MULTIPLY", b.math("ADD", p, b.math("MULTIPLY", q, 2.0)), 0.25),
                              b.math("MULTIPLY", q, 0.25)]
                    diff = [b.math("MULTIPLY", p, -0.5), b.math("MULTIPLY", q, -0.5),
                            b.math("MULTIPLY", p, 0.5), b.math("MULTIPLY", q, 0.5)]
                    return smooth, diff
                smooth_u, diff_u = weights(ax, ay)
                smooth_v, diff_v = weights(bx, by)
                du, dv = 0.0, 0.0
                for i in range(4):          # rows (v)
                    for j in range(4):      # columns (u)
                        centre = b.vmath("DIVIDE", b.vmath("ADD", fl, (j - 0.5, i - 0.5, 0.0)),
                                         (float(w), float(h), 1.0))
                        q = height_image_node(b, image, centre, "Closest", extension)
                        du = b.math("ADD", du, b.math("MULTIPLY", b.math(
                            "MULTIPLY", smooth_v[i], diff_u[j]), q))
                        dv = b.math("ADD", dv, b.math("MULTIPLY", b.math(
                            "MULTIPLY", diff_v[i], smooth_u[j]), q))
        with b.frame("Listing 6 in surface gradients: W dH/du grad s + H dH/dv grad t"):
            sg = b.add(b.scale(grads.outputs[0], b.math("MULTIPLY", du, float(w))),
                       b.scale(grads.outputs[1], b.math("MULTIPLY", dv, float(h))))
        b.output("Surface Gradient", "VECTOR", b.scale(sg, scale), "Surface gradient")
    same_image = images_stale(lambda count: [image] * count)

    def stale(tree):
        # Rebuild when the image it samples was replaced or removed, or changed size.
        return same_image(tree) or tree.get("surfgrad_size") != [w, h]

    label = {"hq": "HQ", "one-texel": "One-Texel"}[variant]
    name = f"SG Height Map {label}" + (f" [{image.name}]" if image is not None else "")
    tree = ensure_group(name, common.VERSION, build,
                        f"Scale-dependent bump from a height image ({label}, Listing 16 and "
                        f"Listing 6); image {image.name if image else '(none: use Add Height Map)'}",
                        stale=stale)
    tree["surfgrad_size"] = [w, h]
    return tree


def height_map_forward_group(filter_width=None):
    """Forward differences through the Bump node, Filter Width differentials apart (default
    FORWARD_FILTER_WIDTH, about a texel; another width gives a variant group, e.g. to keep the
    look of a converted Bump node)."""
    fw = FORWARD_FILTER_WIDTH if filter_width is None else float(filter_width)
    def build(b):
        n = normal_input(b)
        height = b.input("Height", "FLOAT", "Height (link an Image Texture or any scalar "
                         "graph)", default=0.0, hide_value=True)
        scale = b.input("Bump Scale", "FLOAT", "World units of displacement per unit of height",
                        default=0.05, min_value=-1000.0, max_value=1000.0)
        with b.frame("Listing 7: forward differences along the render's differentials "
                     "(the Bump node, inverted: g = N - n / (n . N))"):
            bump = b.node("ShaderNodeBump")
            bump.inputs["Strength"].default_value = 1.0
            bump.inputs["Distance"].default_value = 1.0
            if "Filter Width" in bump.inputs:
                bump.inputs["Filter Width"].default_value = fw
            b.link(height, bump.inputs["Height"])
            b.link(n, bump.inputs["Normal"])
            nb = bump.outputs[0]
            g = b.sub(n, b.scale(nb, b.math("DIVIDE", 1.0, b.dot(nb, n))))
        b.output("Surface Gradient", "VECTOR", b.scale(g, scale), "Surface gradient")
    name = "SG Height Map Forward" + ("" if fw == FORWARD_FILTER_WIDTH else f" (filter {fw:g})")
    return ensure_group(name, common.VERSION, build,
                        "Scale-dependent bump from any height by forward differences "
                        "(Listing 7, Listing 6)")


def bump_strength_group():
    """The Bump node's Strength on a surface gradient (for a converted Bump node, whose look must
    not change): Cycles and EEVEE blend the bumped normal toward the base, normalize(s nb + (1 -
    s) N) with nb = normalize(N - g), which is no linear scale of g. Listing 5 turns the blend
    back into a surface gradient; N - v where it faces away from N (s > 1 can tip it over)."""
    def build(b):
        n = normal_input(b, "Base normal, as the converted Bump node's Normal (leave unlinked: "
                            "the shading normal)")
        g = b.input("Surface Gradient", "VECTOR", "Surface gradient at Strength 1 (SG Height "
                    "Map Forward)", hide_value=True)
        s = b.input("Strength", "FLOAT", "As the Bump node's Strength: 1 keeps the gradient, "
                    "0 is flat, between them the bumped normal is blended toward the base",
                    default=1.0, min_value=0.0, max_value=10.0)
        with b.frame("The Bump node's blend: v = normalize(s normalize(N - g) + (1 - s) N)"):
            s = b.math("MAXIMUM", s, 0.0)
            nb = b.normalize(b.sub(n, g))
            v = b.normalize(b.add(b.scale(nb, s), b.scale(n, b.math("SUBTRACT", 1.0, s))))
        with b.frame("Listing 5: N - v / (N . v); N - v where v faces away from N"):
            k = b.dot(n, v)
            inv = b.math("DIVIDE", 1.0, b.math("MAXIMUM", k, FLT_EPSILON))
            away = b.math("LESS_THAN", k, FLT_EPSILON)
            w = b.math("MULTIPLY_ADD", away, b.math("SUBTRACT", 1.0, inv), inv)
            sg = b.sub(n, b.scale(v, w))
        b.output("Surface Gradient", "VECTOR", sg, "Surface gradient with the Bump node's "
                 "Strength applied")
    return ensure_group(".SG Bump Strength", common.VERSION, build,
                        "The Bump node's Strength (a blend of normals) on a surface gradient")


def triplanar_height_group(image=None, extension="REPEAT", images=None):
    """SG Triplanar Height for height images: `image` on all three planes, or `images`, one
    per plane (X, Y, Z). Per plane the one-texel derivative of Listing 16 (three Linear taps),
    in world units, into Listing 13's volume gradient with Listing 14's weights; Listing 8
    projects it."""
    plane_images = list(images) if images is not None else [image] * 3
    if len(plane_images) != 3:
        raise ValueError("triplanar height needs one image or three (for X, Y and Z)")
    sizes = [(im.size[0], im.size[1]) if im is not None else (1024, 1024)
             for im in plane_images]

    def build(b):
        n = normal_input(b)
        p, scale = scaled_position_inputs(b, "Where to project from (unlinked: world "
                                          "position)")
        k = b.input("Sharpness", "FLOAT", "Blend sharpness k of Listing 14", default=3.0,
                    min_value=1.0, max_value=64.0)
        bump = b.input("Bump Scale", "FLOAT", "World units of displacement per unit of height",
                       default=0.05, min_value=-1000.0, max_value=1000.0)
        weights = triplanar_weights(b, n, k)
        x, y, z = b.separate(p)
        derivs = []
        planes = (("X: (z, y)", (z, y)), ("Y: (x, z)", (x, z)), ("Z: (x, y)", (x, y)))
        for (label, (u, v)), img, (w, h) in zip(planes, plane_images, sizes):
            with b.frame(f"Plane {label}: Listing 16 one-texel derivative, per world unit"):
                uv = b.combine(u, v)
                hc = height_image_node(b, img, uv, "Linear", extension)
                hr = height_image_node(b, img, b.vmath("ADD", uv, (1.0 / w, 0.0, 0.0)),
                                        "Linear", extension)
                hu = height_image_node(b, img, b.vmath("ADD", uv, (0.0, 1.0 / h, 0.0)),
                                        "Linear", extension)
                derivs.append((b.math("MULTIPLY", b.math("SUBTRACT", hr, hc), b.math("MULTIPLY", scale, float(w))),
                               b.math("MULTIPLY", b.math("SUBTRACT", hu, hc), b.math("MULTIPLY", scale, float(h)))))
        sg = triplanar_surface_gradient(b, n, weights, derivs)
        b.output("Surface Gradient", "VECTOR", b.scale(sg, bump), "Surface gradient")

    stale = images_stale(lambda count: [im for im in plane_images for _ in range(3)])

    named = [im.name for im in plane_images if im is not None]
    label = named[0] if len(set(named)) == 1 and len(named) == 3 else " | ".join(named)
    name = "SG Triplanar Height" + (f" [{label}]" if label else "")
    return ensure_group(name, common.VERSION, build,
                        "Listings 13 and 14 from a height image on all three planes",
                        stale=stale)
