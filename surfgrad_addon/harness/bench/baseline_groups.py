"""The baselines the bench measures the framework against, as hidden node groups (".SGB ...";
never in the Add menu). Each mirrors its function in reference/baselines.py."""

from ...addon import groups as G
from ...addon.node_builder import ensure_group
from ...addon.node_vocabulary import Math, VMath
from ...addon.groups.projection import decal_weight
from ...reference.decals import DECAL_SHAPES

VERSION = 3


def _normal(b):
    return G.normal_input(b, "Base normal (unlinked: the shading normal)")


def _plane_colors(b):
    return [b.input(f"Color {a}", "COLOR", f"Normal map sampled for the {a} plane",
                    default=(0.5, 0.5, 1.0, 1.0)) for a in "XYZ"]


def _triplanar_grad(b, weights, derivs):
    w0, w1, w2 = weights
    (dxx, dxy), (dyx, dyy), (dzx, dzy) = derivs
    return b.combine(
        b.math(Math.ADD, b.math(Math.MULTIPLY, w2, dzx), b.math(Math.MULTIPLY, w1, dyx)),
        b.math(Math.ADD, b.math(Math.MULTIPLY, w2, dzy), b.math(Math.MULTIPLY, w0, dxy)),
        b.math(Math.ADD, b.math(Math.MULTIPLY, w0, dxx), b.math(Math.MULTIPLY, w1, dyy)))


def triplanar_geiss_group():
    """Geiss: -m.xy used as the derivative (slopes saturate at 45 degrees), Perlin's
    unprojected addition."""
    def build(b):
        n = _normal(b)
        colors = _plane_colors(b)
        weights = G.triplanar_weights(b, n, 3.0)
        derivs = []
        for c in colors:
            mx, my, _ = b.separate(b.vmath(VMath.SUBTRACT, b.vmath(VMath.MULTIPLY, c, (2.0, 2.0, 2.0)),
                                           (1.0, 1.0, 1.0)))
            derivs.append((b.math(Math.MULTIPLY, mx, -1.0), b.math(Math.MULTIPLY, my, -1.0)))
        grad = _triplanar_grad(b, weights, derivs)
        b.output("Normal", "VECTOR", b.normalize(b.sub(n, grad)), "Perturbed normal")
    return ensure_group(".SGB Triplanar Geiss", VERSION, build, "Geiss's traditional triplanar")


def triplanar_derivative_perlin_group():
    """Figure 5 (middle): Listing 2 derivatives, Perlin's unprojected addition."""
    def build(b):
        n = _normal(b)
        colors = _plane_colors(b)
        weights = G.triplanar_weights(b, n, 3.0)
        grad = _triplanar_grad(b, weights, [G.decode_tangent_normal(b, c) for c in colors])
        b.output("Normal", "VECTOR", b.normalize(b.sub(n, grad)), "Perturbed normal")
    return ensure_group(".SGB Triplanar Derivative Perlin", VERSION, build,
                        "Triplanar derivatives with Perlin's perturbation")


def decal_engine_group():
    """Engines' decal: perturb the projector's own normal (its Z axis) in the decal's frame and
    blend it over the surface normal by the decal's mask and fade."""
    def build(b):
        n = _normal(b)
        q = b.input("Decal Coordinates", "VECTOR", "Projector-space position", hide_value=True)
        color = b.input("Color", "COLOR", "Decal normal map", default=(0.5, 0.5, 1.0, 1.0))
        ax = b.input("Axis X", "VECTOR", "Projector X axis (world)", default=(1.0, 0.0, 0.0))
        ay = b.input("Axis Y", "VECTOR", "Projector Y axis (world)", default=(0.0, 1.0, 0.0))
        az = b.input("Axis Z", "VECTOR", "Projector Z axis (world): the negated projection "
                     "direction", default=(0.0, 0.0, 1.0))
        falloff = b.input("Falloff", "FLOAT", "Fade depth", default=0.2)
        shape = b.input("Shape", "INT", "0 box, 1 sphere, 2 cylinder, 3 cone, 4 wedge, 5 capsule "
                        "(as SG Decal)", default=0, min_value=0, max_value=len(DECAL_SHAPES) - 1)
        alpha = decal_weight(b, q, shape, falloff)
        dx, dy = G.decode_tangent_normal(b, color)
        decal_n = b.normalize(b.sub(b.sub(az, b.scale(ax, dx)), b.scale(ay, dy)))
        b.output("Normal", "VECTOR", b.normalize(b.mix_vector(alpha, n, decal_n)),
                 "Blended normal")
    return ensure_group(".SGB Decal Engine", VERSION, build, "Engine-style decal normal")


def lxengine_group():
    """The LxEngine blog's bump_normal(): a frame rebuilt from the direction of dP/dx and the
    smooth normal (the lengths of dP/dx, dP/dy are thrown away), with the height's screen
    differences taken one bake texel apart."""
    def build(b):
        n = _normal(b)
        uv = b.input("UV", "VECTOR", "Texture coordinate", hide_value=True)
        h_c = b.input("Height", "FLOAT", "Height at UV", default=0.0)
        h_x = b.input("Height +X", "FLOAT", "Height one bake texel along s", default=0.0)
        h_y = b.input("Height +Y", "FLOAT", "Height one bake texel along t", default=0.0)
        scale = b.input("Bump Scale", "FLOAT", "Height scale", default=1.0)
        grads = G.sub_group(b, G.uv_gradients_group(), "UV gradients", UV=uv, Normal=n)
        # dP/dx points along dP/ds: in the tangent plane, perpendicular to grad t.
        dpdx = b.cross(grads.outputs[1], n)
        y = b.normalize(b.cross(n, dpdx))
        x = b.normalize(b.cross(y, n))
        dhdx = b.math(Math.MULTIPLY, b.math(Math.SUBTRACT, h_x, h_c), scale)
        dhdy = b.math(Math.MULTIPLY, b.math(Math.SUBTRACT, h_y, h_c), scale)
        out = b.add(b.sub(b.scale(x, b.math(Math.MULTIPLY, dhdx, -1.0)), b.scale(y, dhdy)), n)
        b.output("Normal", "VECTOR", b.normalize(out), "Perturbed normal")
    return ensure_group(".SGB LxEngine", VERSION, build,
                        "Screen-derivative bump with ad-hoc re-orthonormalisation")
