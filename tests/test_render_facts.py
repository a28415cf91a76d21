"""The length of the differentials Cycles' Bump node uses in a camera RENDER (not a bake),
pinned on every line with a Cycles CPU render: 1 sample, BOX pixel filter of width 0.01 (each
pixel is shaded at its centre to 5e-4 px), no denoising, float32 OpenEXR read back through
bpy.data.images (the view transform does not touch EXR output: checked once, not pinned, Standard,
Raw and AgX give the same bits).

Scene: an orthographic camera looking down -Z at the plane z = 0 (Ng = N = +Z), 32 x 32 px,
ortho_scale 2 (one pixel is 1/16 world units). Emission (Strength 1) shows the Bump node's
Normal (Distance 0.25, Strength 1, Filter Width fw = 2; 4.2 has no Filter Width and steps by
exactly dP: fw = 1) for the height h = x^2 + 2 y^2 of Geometry > Position. A second render of
the Position with the same seed gives each pixel's P.

Model (svm/displace.h, kernel/util/differential.h: the same maths on every line):
dPdx, dPdy = r a, r b with a, b = make_orthonormals(Ng) and r = sd->dP, the ray's compact
differential transferred to the hit (orthographic: ray dP only, dD = 0). Then
n . a / n . N = -D (h(P + fw r a) - h(P)) / (fw r), and for a quadratic h the forward
difference is g . a + fw r (a^T H a) / 2, LINEAR in r: each pixel gives r in closed form
along a and along b; a 1-D search of r over the whole image (min of the mean squared angle to
the full svm_node_set_bump model) agrees.

1. Square pixels: r = the world size of one pixel, factor 1 on every line: median
   r / pixel - 1 along a / b, and the 1-D search's r / pixel - 1:
     4.2.23 (fw 1): -2.9e-7 / -5.3e-7, search -3.8e-7 (1st-99th percentile within 3.8e-5)
     4.5.15, 5.0.1: -4.1e-7 / -2.4e-7, search -5.7e-7 (within 1.0e-5)
     5.2.3:         -3.9e-7 / -2.5e-7, search -5.7e-7 (within 1.0e-5)
   So unlike bakes (whose r doubled in 5.2, host side), renders give the same r on all lines.
   With that r the model reproduces the render to 7.2e-5 deg max (4.2; 2.9e-5 on 4.5-5.2),
   median 6e-6 (1e-5 on 4.2). Wrong r: 2 r is off by a median of 3.1 deg (1.6 on 4.2), r / 2 by
   1.6 deg (0.8 on 4.2).
2. Non-square pixels (pixel_aspect_x = 2: footprint dx = 1/16, dy = 1/32) DIFFER by line: up
   to 5.0 r = |dx| (camera/camera.h's orthographic branch sets dP.dy = cam.dx, a typo), in 5.2
   r = 0.5 (|dx| + |dy|) (dP.dy = cam.dy; times kernel_data.cam.differential_scale, new in 5.2,
   which is 1 here; a 50 % resolution render, tried once and not pinned, gave 1 too). Each
   line's rule fits to < 7e-7 (median r) and 4.2e-5 deg (max angle); the other line's rule is
   off by a median of 0.86 deg (0.43 on 4.2).
The file runs in under 1 s per line (each render of 32 x 32 px takes ~5 ms).
"""

import numpy as np
import pytest

pytestmark = pytest.mark.tier("bake")

pytest.importorskip("bpy")

from support import bake_probe as base  # noqa: E402
from support import facts_probe as fp  # noqa: E402
from surfgrad_addon.reference.cycles_bake import make_orthonormals  # noqa: E402

bpy = base.bpy

RES = 32
ORTHO_SCALE = 2.0
HEIGHT_C = 1.0                  # h = C (x^2 + 2 y^2): Hessian diag(2C, 4C, 0)
HESSIAN = np.diag([2.0 * HEIGHT_C, 4.0 * HEIGHT_C, 0.0])
DISTANCE = 0.25
FILTER_WIDTH = 2.0              # where the Bump node has the input (4.5+); 4.2 steps by fw = 1
NG = np.array([0.0, 0.0, 1.0])


def height(p):
    return HEIGHT_C * (p[..., 0] ** 2 + 2.0 * p[..., 1] ** 2)


def height_gradient(p):
    return p @ HESSIAN


def render_bump(tmp_path, pixel_aspect_x=1.0):
    """Render the Bump normal and the Position; return (normal (H, W, 3), position (H, W, 3),
    fw, (pixel width, pixel height) in world units from the camera's parameters)."""
    scene = base.new_scene()
    mesh = bpy.data.meshes.new("RenderPlane")
    mesh.from_pydata([(-4.0, -4.0, 0.0), (4.0, -4.0, 0.0), (4.0, 4.0, 0.0), (-4.0, 4.0, 0.0)],
                     [], [(0, 1, 2, 3)])
    obj = bpy.data.objects.new("RenderPlane", mesh)
    scene.collection.objects.link(obj)
    mat = bpy.data.materials.new("RenderBump")
    if mat.node_tree is None:                   # before 5.0 a new material needs use_nodes
        mat.use_nodes = True
    mesh.materials.append(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Strength"].default_value = 1.0
    links.new(emit.outputs["Emission"], out.inputs["Surface"])
    geo = nodes.new("ShaderNodeNewGeometry")
    sep = nodes.new("ShaderNodeSeparateXYZ")
    links.new(geo.outputs["Position"], sep.inputs[0])

    def math(op, a, b):
        n = nodes.new("ShaderNodeMath")
        n.operation = op
        for i, x in enumerate((a, b)):
            if isinstance(x, float):
                n.inputs[i].default_value = x
            else:
                links.new(x, n.inputs[i])
        return n.outputs[0]

    xx = math("MULTIPLY", sep.outputs[0], sep.outputs[0])
    yy = math("MULTIPLY", sep.outputs[1], sep.outputs[1])
    h = math("MULTIPLY", math("ADD", xx, math("MULTIPLY", yy, 2.0)), HEIGHT_C)
    bump = nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 1.0
    bump.inputs["Distance"].default_value = DISTANCE
    fw = 1.0
    if "Filter Width" in bump.inputs:
        fw = FILTER_WIDTH
        bump.inputs["Filter Width"].default_value = fw
    links.new(h, bump.inputs["Height"])

    cam = bpy.data.objects.new("RenderCam", bpy.data.cameras.new("RenderCam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = ORTHO_SCALE
    cam.location = (0.0, 0.0, 5.0)              # identity rotation: looks down -Z, +Y up
    rd = scene.render
    rd.resolution_x = rd.resolution_y = RES
    rd.resolution_percentage = 100
    rd.pixel_aspect_x, rd.pixel_aspect_y = pixel_aspect_x, 1.0
    rd.use_motion_blur = False
    settings = rd.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.color_mode = "RGBA"
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01

    def render(socket, name):
        links.new(socket, emit.inputs["Color"])
        rd.filepath = str(tmp_path / f"{name}.exr")
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(rd.filepath, check_existing=False)
        px = np.empty(RES * RES * 4, np.float32)
        img.pixels.foreach_get(px)
        bpy.data.images.remove(img)
        return px.reshape(RES, RES, 4)[..., :3].astype(np.float64)

    normal = render(bump.outputs["Normal"], "normal")
    position = render(geo.outputs["Position"], "position")
    # Sensor fit AUTO: ortho_scale spans the wider side, measured in aspect-corrected pixels.
    pw = ORTHO_SCALE / RES
    return normal, position, fw, (pw, pw / pixel_aspect_x)


def pixel_centres(footprint):
    pw, ph = footprint
    x = (np.arange(RES) + 0.5 - RES / 2) * pw
    y = (np.arange(RES) + 0.5 - RES / 2) * ph
    xx, yy = np.meshgrid(x, y)                  # row 0 at the bottom (Image.pixels order)
    return np.stack([xx, yy, 0 * xx], -1)


def closed_form_r(normal, position, fw):
    """Per pixel, the r that explains the Bump normal's slope along a and along b (N, 2)."""
    n, p = normal.reshape(-1, 3), position.reshape(-1, 3)
    g = height_gradient(p)
    out = []
    for v in make_orthonormals(NG):
        slope = -(n @ v) / (DISTANCE * (n @ NG))          # (h(P + fw r v) - h(P)) / (fw r)
        out.append((slope - g @ v) / (fw * 0.5 * (v @ HESSIAN @ v)))
    return np.stack(out, -1)


def model_normal(position, r, fw):
    """svm_node_set_bump with dPdx, dPdy = r make_orthonormals(Ng) at the rendered P."""
    p = position.reshape(-1, 3)
    a, b = make_orthonormals(NG)
    dpdx, dpdy = np.broadcast_to(r * a, p.shape), np.broadcast_to(r * b, p.shape)
    n = np.broadcast_to(NG, p.shape)
    return fp.cycles_bump_normal(n, dpdx, dpdy, height(p), height(p + fw * dpdx),
                                 height(p + fw * dpdy), DISTANCE, fw)


def angles(normal, position, r, fw):
    return fp.angle_deg(model_normal(position, r, fw), normal.reshape(-1, 3))


def search_r(normal, position, fw, lo, hi, iters=80):
    """1-D golden-section search of log r minimising the mean squared angle over all pixels."""
    def cost(log_r):
        return np.mean(angles(normal, position, np.exp(log_r), fw) ** 2)
    a, b = np.log(lo), np.log(hi)
    k = (np.sqrt(5.0) - 1.0) / 2.0
    c, d = b - k * (b - a), a + k * (b - a)
    fc, fd = cost(c), cost(d)
    for _ in range(iters):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - k * (b - a)
            fc = cost(c)
        else:
            a, c, fc = c, d, fd
            d = a + k * (b - a)
            fd = cost(d)
    return float(np.exp(0.5 * (a + b)))


def test_render_bump_radius_is_one_pixel_footprint(tmp_path):
    normal, position, fw, (pw, ph) = render_bump(tmp_path)
    assert pw == ph == ORTHO_SCALE / RES
    # Each pixel is shaded at its centre (BOX filter 0.01 px) and the normals are unit.
    assert np.abs(position - pixel_centres((pw, ph))).max() < 1e-4
    assert np.abs(np.linalg.norm(normal, axis=-1) - 1.0).max() < 1e-6

    pixel = 0.5 * (pw + ph)                     # ray dP = 0.5 (|dx| + |dy|) of the camera
    ratio = closed_form_r(normal, position, fw) / pixel
    med = np.median(ratio, axis=0)
    assert np.all(np.abs(med - 1.0) < 3e-6), med                   # measured <= 5.3e-7
    lo, hi = np.percentile(ratio, [1, 99])
    assert 1.0 - 1e-4 < lo and hi < 1.0 + 1e-4, (lo, hi)           # measured <= 3.8e-5
    # Not the bakes' factors (0.25 / 0.5 per texel, i.e. half or one pixel): exactly one.
    r_search = search_r(normal, position, fw, 0.1 * pixel, 10.0 * pixel)
    assert abs(r_search / pixel - 1.0) < 5e-6, r_search / pixel    # measured <= 5.7e-7

    err = angles(normal, position, pixel, fw)
    assert np.median(err) < 5e-5 and np.percentile(err, 99) < 2e-4 and err.max() < 3e-4, (
        np.median(err), np.percentile(err, 99), err.max())
    for wrong in (2.0 * pixel, 0.5 * pixel):
        bad = angles(normal, position, wrong, fw)
        assert np.median(bad) > 0.5 and np.median(bad) > 1e4 * np.median(err), (
            wrong / pixel, np.median(bad))


# Orthographic camera with non-square pixels: Cycles' camera/camera.h up to 5.0 sets the ray's
# dP.dy = cam.dx (so r = |dx|); 5.2 uses cam.dy (r = 0.5 (|dx| + |dy|)).
def _expected_r(footprint):
    pw, ph = footprint
    return 0.5 * (pw + ph) if bpy.app.version >= (5, 2, 0) else pw


def test_render_bump_radius_non_square_pixels_per_line(tmp_path):
    normal, position, fw, footprint = render_bump(tmp_path, pixel_aspect_x=2.0)
    pw, ph = footprint
    assert ph == 0.5 * pw
    assert np.abs(position - pixel_centres(footprint)).max() < 1e-4
    r = _expected_r(footprint)
    ratio = np.median(closed_form_r(normal, position, fw), axis=0) / r
    assert np.all(np.abs(ratio - 1.0) < 3e-6), ratio                # measured <= 6.3e-7
    err = angles(normal, position, r, fw)
    assert np.percentile(err, 99) < 2e-4 and err.max() < 3e-4, err.max()
    # The other line's rule is clearly wrong here (0.75 vs 1 pixel width).
    other = pw if r != pw else 0.5 * (pw + ph)
    assert np.median(angles(normal, position, other, fw)) > 0.3     # measured 0.43-0.86 deg
