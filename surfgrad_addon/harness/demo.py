"""demo.blend, built by code: one labelled exhibit per idea, the usual way on the left and the
surface-gradient way on the right, textures generated and packed; and small Cycles renders of
every exhibit (before/after pictures for the README).

    python -m surfgrad_addon demo-blend --out demo.blend [--pictures DIR]
"""

import math
from pathlib import Path

import numpy as np

from .graph import Graph
from ..reference import images as T
from ..addon import groups as G
from ..addon import compat

EXHIBIT_SPACING = 6.0
HEIGHT_BUMP = 0.2


def _image(name, pixels):
    """A float image packed into the file (as OpenEXR: generated images need a format and a
    path before pack() keeps their pixels)."""
    import bpy
    px = np.asarray(pixels, dtype=np.float32)
    if px.ndim == 2:
        px = np.repeat(px[..., None], 3, axis=-1)
    h, w = px.shape[:2]
    px = np.concatenate([px[..., :3], np.ones((h, w, 1), np.float32)], axis=-1)
    img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(px.ravel())
    img.file_format = "OPEN_EXR"
    img.filepath_raw = f"//{name}.exr"
    img.pack()
    return img


def _material(name, build):
    """A Principled BSDF material whose Normal is build(g) (None: the plain normal)."""
    import bpy
    mat = compat.new_material(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.62, 0.6, 0.58, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.45
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    g = Graph(tree.nodes, tree.links)
    normal = build(g)
    if normal is not None:
        tree.links.new(normal, bsdf.inputs["Normal"])
    return mat


def _label(text, location, size=0.32):
    import bpy
    curve = bpy.data.curves.new(text, "FONT")
    curve.body = text
    curve.size = size
    curve.align_x = "CENTER"
    obj = bpy.data.objects.new(f"Label: {text}", curve)
    obj.location = location
    obj.rotation_euler = (math.radians(90), 0, 0)
    bpy.context.scene.collection.objects.link(obj)
    mat = bpy.data.materials.new("Label")
    mat.diffuse_color = (0.05, 0.05, 0.05, 1)
    curve.materials.append(mat)
    return obj


def _mesh(kind, location, name, **kw):
    import bpy
    from . import scenes
    ops = bpy.ops.mesh
    if kind == "sphere":
        ops.primitive_uv_sphere_add(segments=48, ring_count=24, radius=1.0, location=location)
    elif kind == "rock":          # a dense UV sphere; SG Displace makes it a rock
        ops.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0, location=location)
    elif kind == "plane":
        ops.primitive_plane_add(size=2.2, location=location, rotation=(math.radians(70), 0, 0))
    elif kind == "torus":
        ops.primitive_torus_add(major_radius=0.8, minor_radius=0.3, location=location,
                                rotation=(1.1, 0, 0), generate_uvs=True)
    obj = bpy.context.active_object
    return scenes._finish(obj, name)


def _pair(x, title, left, right, kind="sphere", left_label="usual", right_label="surface "
          "gradient", extra=None):
    """Two objects at x +- 1.2 with their materials and a label; returns the objects."""
    a = _mesh(kind, (x - 1.25, 0, 1.1), f"{title} | {left_label}")
    b = _mesh(kind, (x + 1.25, 0, 1.1), f"{title} | {right_label}")
    a.data.materials.append(_material(f"{title}: {left_label}", left))
    b.data.materials.append(_material(f"{title}: {right_label}", right))
    _label(title, (x, 0, 2.65))
    _label(left_label, (x - 1.25, 0, -0.25), 0.2)
    _label(right_label, (x + 1.25, 0, -0.25), 0.2)
    return a, b


def _camera(name, x, z=1.15, distance=7.2):
    import bpy
    cam = bpy.data.cameras.new(name)
    cam.lens = 50
    obj = bpy.data.objects.new(name, cam)
    obj.location = (x, -distance, z)
    obj.rotation_euler = (math.radians(90), 0, 0)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def build_demo(log=print):
    """Build the exhibits into a fresh file; returns the exhibit cameras {title: camera}."""
    import bpy
    from mathutils import Euler, Matrix
    from .bench import baseline_groups as BG
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    world = bpy.data.worlds.new("World")
    world.use_nodes = True if world.node_tree is None else world.use_nodes
    bg = world.node_tree.nodes.get("Background") if world.node_tree else None
    if bg is not None:
        bg.inputs["Color"].default_value = (0.55, 0.58, 0.62, 1.0)
        bg.inputs["Strength"].default_value = 0.9
    world.color = (0.55, 0.58, 0.62)
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 4.0
    sun.data.angle = math.radians(3)
    # Light from the camera's side, high and to the left: it rakes across the bumps.
    sun.rotation_euler = (math.radians(52), 0.0, math.radians(-48))
    scene.collection.objects.link(sun)
    hemi = _image("Hemispheres", T.hemisphere_tile_image(256))
    detail = _image("Detail tile", T.hemisphere_tile_image(256, 8, 0.6))
    height = _image("Height 64", T.wave_height_image(64, (4.0, 2.0)))
    domes = _image("Dome heights", T.hemisphere_tile_height_image(256))
    cams = {}

    def uv(g, name="UVMap"):
        return g.uv(name)

    def nm(g, image, uv_name="UVMap"):
        node = g.group(G.normal_map_group(uv_name), Color=g.image(image, uv(g, uv_name)))
        return node.outputs[0]

    # 1. Layered detail on two UV maps (Figure 1).
    x = 0.0

    def layered_usual(g):
        mix = g.node("ShaderNodeNormalMap", uv_map="UVMap")      # detail on the first map's
        g.link(g.image(detail, uv(g, "Detail")), mix.inputs["Color"])   # tangents
        return mix.outputs[0]

    def layered_sg(g):
        basis = g.group(G.procedural_basis_group(), UV=uv(g, "Detail"))
        tn = g.group(G.tangent_normal_group(), Color=g.image(detail, uv(g, "Detail")),
                     Tangent=basis.outputs[0], Bitangent=basis.outputs[1])
        comb = g.group(G.combine_group(), A=nm(g, hemi), B=tn.outputs[0], Scale_B=1.0)
        return g.resolve(comb.outputs[0])
    _pair(x, "Detail on a second, rotated UV map", layered_usual, layered_sg)
    cams["layered"] = _camera("Camera layered", x, distance=6.4)

    # 2. Triplanar on a rock (Figure 5), and post-resolve triplanar on a normal map (7b).
    x += EXHIBIT_SPACING

    def tri_colors(g):
        coords = g.group(G.triplanar_coordinates_group(), Scale=1.2)
        return [g.image(hemi, coords.outputs[f"UV {a}"]) for a in "XYZ"]

    def tri_usual(g):
        p = g.scale(g.node("ShaderNodeTexCoord").outputs["Object"], 1.2)
        color = g.image(hemi, p, projection="BOX")
        color.node.projection_blend = 0.3
        n = g.node("ShaderNodeNormalMap", uv_map="UVMap")
        g.link(color, n.inputs["Color"])
        return n.outputs[0]

    def tri_sg(g):
        node = g.group(G.triplanar_group())
        for axis, color in zip("XYZ", tri_colors(g)):
            g.link(color, node.inputs[f"Color {axis}"])
        return g.resolve(node.outputs[0])
    def tri_post_resolve(g):
        # Figure 7(b): a baked macro normal map resolved first, then triplanar detail with
        # the resolved normal as the new base normal (weights, projection, second resolve).
        first = g.resolve(g.group(G.normal_map_group("UVMap"),
                                  Color=g.image(macro, uv(g))).outputs[0])
        node = g.group(G.triplanar_group(), Normal=first, Strength=0.6)
        for axis, color in zip("XYZ", tri_colors(g)):
            g.link(color, node.inputs[f"Color {axis}"])
        return g.resolve(node.outputs[0], normal=first)
    macro = _image("Macro normal map", T.hemisphere_tile_image(128, 2, 0.95))
    a, b = _pair(x, "Triplanar on a rock", tri_usual, tri_sg, kind="rock")
    c = _mesh("rock", (x + 3.75, 0, 1.1), "Triplanar on a rock | post-resolve")
    c.data.materials.append(_material("Triplanar: post-resolve on a normal map",
                                      tri_post_resolve))
    _label("post-resolve (7b)", (x + 3.75, 0, -0.25), 0.2)
    for obj in (a, b, c):
        from .methods import add_displace_modifier
        add_displace_modifier(obj, {"Amount": 0.18, "Scale": 1.6, "Octaves": 3})
    cams["triplanar"] = _camera("Camera triplanar", x + 1.25, distance=9.0)

    # 3. Decal across a torus and a plane (Figure 6).
    x += EXHIBIT_SPACING + 3.0          # room for the triplanar exhibit's third rock
    projectors = []
    for dx, side in ((-1.25, "usual"), (1.25, "surface gradient")):
        empty = bpy.data.objects.new(f"Decal projector ({side})", None)
        empty.empty_display_type = "CUBE"
        scene.collection.objects.link(empty)
        empty.matrix_world = (Matrix.Translation((x + dx, 0, 1.1)) @ Euler((0.3, -0.2, 0.4))
                              .to_matrix().to_4x4() @ Matrix.Diagonal((0.8, 0.65, 1.0, 1)))
        projectors.append(empty)

    def decal(projector, sg):
        def build(g):
            tc = g.node("ShaderNodeTexCoord", object=projector)
            coords = g.group(G.decal_coordinates_group())
            g.link(tc.outputs["Object"], coords.inputs[0])
            color = g.image(hemi, coords.outputs[0])
            m = np.array(projector.matrix_world)[:3, :3]
            ax, ay, az = (tuple(m[:, i] / np.linalg.norm(m[:, i])) for i in range(3))
            if not sg:
                return g.group(BG.decal_engine_group(), Decal_Coordinates=tc.outputs["Object"],
                               Color=color, Axis_X=ax, Axis_Y=ay, Axis_Z=az).outputs[0]
            node = g.group(G.decal_group(), Decal_Coordinates=tc.outputs["Object"],
                           Color=color, Axis_X=ax, Axis_Y=ay)
            return g.resolve(node.outputs[0])
        return build
    a, b = _pair(x, "Decal across a torus and a plane", decal(projectors[0], False),
                 decal(projectors[1], True), kind="torus")
    for obj, proj, side in ((a, projectors[0], "usual"), (b, projectors[1], "surface gradient")):
        plane = _mesh("plane", obj.location, f"Decal plane ({side})")
        plane.data.materials.append(obj.data.materials[0])
    cams["decal"] = _camera("Camera decal", x)

    # 4. Volume noise bump (Figure 4).
    x += EXHIBIT_SPACING

    def noise_usual(g):
        noise = g.group(G.noise_group(), Scale=3.0)
        return g.perlin(g.geometry("Normal"), g.scale(noise.outputs["Gradient"], 0.08))

    def noise_sg(g):
        noise = g.group(G.noise_group(), Scale=3.0)
        vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                     Strength=0.08)
        return g.resolve(vg.outputs[0])
    _pair(x, "Volume noise bump", noise_usual, noise_sg, left_label="Perlin 1985")
    cams["noise"] = _camera("Camera noise", x)

    # 5. Height-map derivatives (Figure 8): forward, one-texel, HQ, a real normal map.
    x += EXHIBIT_SPACING
    variants = [("forward", lambda g: g.resolve(g.group(
        G.height_map_forward_group(), Height=g.first(g.image(height, uv(g))),
        Bump_Scale=HEIGHT_BUMP).outputs[0]))]
    for v in ("one-texel", "hq"):
        variants.append((v, lambda g, v=v: g.resolve(g.group(
            G.height_map_group(height, v), UV=uv(g), Bump_Scale=HEIGHT_BUMP).outputs[0])))
    for i, (label, build) in enumerate(variants):
        obj = _mesh("sphere", (x - 2.4 + 1.6 * i, 0, 1.1), f"Height map | {label}")
        obj.scale = (0.72, 0.72, 0.72)
        obj.data.materials.append(_material(f"Height map: {label}", build))
        _label(label, (x - 2.4 + 1.6 * i, 0, 0.05), 0.2)
    obj = _mesh("sphere", (x + 2.4, 0, 1.1), "Height map | normal map")
    obj.scale = (0.72, 0.72, 0.72)
    from .bench.scenarios import bake_normal_map_from_truth, exact_height_surfgrad
    from ..reference import methods as M
    from .mesh_data import mesh_arrays_from_object
    bpy.context.view_layer.update()
    arrays = mesh_arrays_from_object(obj)
    nmap = _image("Normal map from height", bake_normal_map_from_truth(
        arrays, "UVMap", 128, lambda td: M.resolve(exact_height_surfgrad(
            td, T.wave_height(td.uv(), (4.0, 2.0))[1], HEIGHT_BUMP))))
    obj.data.materials.append(_material("Height map: normal map", lambda g: g.resolve(
        g.group(G.normal_map_group("UVMap"), Color=g.image(nmap, uv(g))).outputs[0])))
    _label("normal map", (x + 2.4, 0, 0.05), 0.2)
    _label("Height-map derivatives", (x, 0, 2.65))
    cams["height"] = _camera("Camera height", x, distance=8.5)

    # 6. Gustavson's displacement with bump on top.
    x += EXHIBIT_SPACING

    def bump_on_top(g):
        noise = g.group(G.noise_group(), Vector=g.group(G.rest_position_group()).outputs[0],
                        Scale=9.0, Octaves=2)
        vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                     Strength=0.015)
        return g.resolve(vg.outputs[0])
    a, b = _pair(x, "Displacement with bump on top", lambda g: None, bump_on_top,
                 left_label="displaced, normals recomputed", right_label="analytic + bump")
    from .methods import add_displace_modifier
    for obj, analytic in ((a, False), (b, True)):
        mod = add_displace_modifier(obj, {"Amount": 0.15, "Scale": 1.8, "Octaves": 2})
        compat.set_input(mod, "Analytic Normals", analytic)
    cams["displacement"] = _camera("Camera displacement", x)

    # 7. Parallax with post-resolve detail (Figure 7c).
    x += EXHIBIT_SPACING

    def parallax(detail_on_top):
        def build(g):
            view = g.geometry("Incoming")
            par = g.group(G.parallax_group(domes), UV=uv(g), View=view, Bump_Scale=0.12)
            base = g.resolve(g.group(G.normal_map_group("UVMap"),
                                     Color=g.image(hemi, par.outputs["UV"])).outputs[0])
            if not detail_on_top:
                return base
            noise = g.group(G.noise_group(), Scale=12.0, Octaves=2)
            vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                         Strength=0.01, Normal=base)
            return g.resolve(vg.outputs[0], normal=base)
        return build
    a, b = _pair(x, "Parallax with post-resolve detail", parallax(False), parallax(True),
                 kind="plane", left_label="parallax occlusion", right_label="+ detail on top")
    cams["parallax"] = _camera("Camera parallax", x)

    overview = _camera("Camera overview", x / 2, z=3.0, distance=40.0)
    scene.camera = overview
    log(f"built {len(cams)} exhibits")
    return cams


def save_demo(path, overwrite=False, log=print):
    import bpy
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass --overwrite to replace it")
    reason = G.unavailable_reason("SG Displace")
    if reason:                  # refuse before building anything (docs/versions.md)
        raise G.FeatureUnavailable(f"demo.blend shows Gustavson's displacement, and {reason}; "
                                   f"open the repository's demo.blend instead (saved with 4.5)")
    cams = build_demo(log)
    if path.exists():
        path.unlink()            # told to overwrite: replace it without a .blend1 backup
    bpy.ops.wm.save_as_mainfile(filepath=str(path.resolve()), compress=True)
    log(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return cams


def render_pictures(cams, out_dir, width=360, height=200, samples=24, log=print):
    """A small Cycles CPU render of every exhibit, PNG, into out_dir."""
    import bpy
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.image_settings.file_format = "PNG"
    paths = []
    for i, (name, cam) in enumerate(cams.items()):
        scene.camera = cam
        scene.render.filepath = str((out / f"{name}.png").resolve())
        bpy.ops.render.render(write_still=True)
        paths.append(out / f"{name}.png")
        log(f"  rendered {i + 1}/{len(cams)}: {paths[-1]}")
    return paths
