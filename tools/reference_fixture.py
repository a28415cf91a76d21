"""Write the reference's float64 values on small rasters to an .npz (tests/data): the
before-values that tests/test_fast_reference.py holds the optimised evaluator to (1e-12).

    python tools/reference_fixture.py OUT.npz   # run from the checkout whose values to record

Every registry method's resolved normal, on three rasters (the sphere; a transformed torus with
its transform applied, 5.2 facts; the same not applied, 4.2 facts), with the rasters stored
too, so the values do not depend on rasterize()'s tie rule. Also the noise, image sampling and
height-map derivatives at fixed random points.
"""

import sys

import numpy as np

from surfgrad_addon import reference as R
from surfgrad_addon.reference import blender_lines
from surfgrad_addon.harness import methods as H
from surfgrad_addon.harness.bench.reference import reference_inputs


def transformed():
    ang = np.radians(35.0)
    rot = np.array([[1, 0, 0], [0, np.cos(ang), -np.sin(ang)], [0, np.sin(ang), np.cos(ang)]])
    m = np.eye(4)
    m[:3, :3] = rot @ np.diag([1.5, 0.7, 1.1])
    m[:3, 3] = [0.3, -0.2, 0.5]
    return m


def rasters():
    sphere = R.meshes.uv_sphere(segments=32, rings=16)
    torus = R.meshes.torus(matrix_world=transformed())
    torus_na = R.meshes.torus(matrix_world=transformed())
    torus_na.transform_applied = False
    for mesh in (sphere, torus, torus_na):
        mesh.point_attributes["sg_rest_position"] = np.asarray(mesh.positions) * 1.05
    return {"sphere": (sphere, 28, blender_lines.LINES["5.2"]),
            "torus": (torus, 24, blender_lines.LINES["5.2"]),
            "torus42": (torus_na, 24, blender_lines.LINES["4.2"])}


def inputs(variant="hq"):
    """The methods' reference inputs at the sizes the values were recorded with."""
    return reference_inputs(variant, normal_size=128, height_size=32)


def cases():
    """Every registry method and variant with a reference of its own (a Sampler method's is its
    per-image twin's, `same_reference_as`; getattr: older checkouts record too)."""
    return [(m.name, v) for m in H.METHODS.values() for v in m.variants
            if not getattr(m, "same_reference_as", None)]


# Cases newer than the recorded commit (a08fc13) have no before-values: the round decal shapes
# and the overwrite mode (issue 15), the wedge and capsule, the height blend and the filtered
# noise (issue 24). The box decal is the old decal, recorded as "hq" (no variants then).
NEW_CASES = {("decal", "sphere"), ("decal", "cylinder"), ("decal", "cone"), ("decal", "wedge"),
             ("decal", "capsule"), ("decal-overwrite", "hq"), ("height-blend", "hq"),
             ("volume-noise-filtered", "hq")}
RECORDED_AS = {("decal", "box"): ("decal", "hq")}


def recorded(case):
    """The (method, variant) a case's before-values are stored under."""
    return RECORDED_AS.get(case, case)


def points(rng, n=2000):
    return {"p": rng.normal(size=(n, 3)) * 3.0, "st": rng.uniform(-1.5, 2.5, size=(n, 2))}


def record(out):
    data = {}
    for key, (mesh, size, facts) in rasters().items():
        td = R.rasterize(mesh, "UVMap", size, size, facts=facts)
        data[f"{key}/triangle"] = td.triangle
        data[f"{key}/pixel"] = td.pixel
        data[f"{key}/barycentric"] = td.barycentric
        for method, variant in cases():
            ref = H.METHODS[method].reference(inputs(variant), td)
            data[f"{key}/{method}/{variant}"] = R.methods.resolve(ref)
    pts = points(np.random.default_rng(13))
    p, st = pts["p"], pts["st"]
    inp = inputs()
    for name, fn in (("gradient_noise", R.gradient_noise), ("fractal_sum", R.fractal_sum),
                     ("turbulence", R.turbulence)):
        v, g = fn(p)
        data[f"points/{name}/value"], data[f"points/{name}/gradient"] = v, g
    for interp in ("Linear", "Closest"):
        for ext in ("REPEAT", "EXTEND"):
            data[f"points/sample/{interp}/{ext}"] = R.sample_image(inp.pixels("normal"), st,
                                                                   interp, ext)
    for hq in (False, True):
        data[f"points/height_deriv/{hq}"] = R.deriv_from_height_map(inp.pixels("height"), st,
                                                                    hq=hq)
    np.savez_compressed(out, **data)


if __name__ == "__main__":
    record(sys.argv[1])
