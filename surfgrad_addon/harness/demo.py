"""demo.blend, built by code: one labelled exhibit per idea, the usual way on the left and the
surface-gradient way on the right, textures generated and packed (the pieces: demo_scene.py;
the Cycles renders of every exhibit for the README: demo_pictures.py).

    python -m surfgrad_addon demo-blend --out demo.blend [--pictures DIR]
"""

import math
from pathlib import Path

import numpy as np

from . import demo_scene as S
from ..reference import images as T
from ..addon import compat
from ..addon import groups as G
from ..addon.sampler_zone import has_closures

EXHIBIT_SPACING = 8.0          # wider than any exhibit camera sees of its neighbours
HEIGHT_BUMP = 1.0 
NOISE_AMOUNT = 0.16          # strong enough that Perlin's unprojected addition shows
# The layered exhibit's second UV map: the first turned 180 degrees and tiled twice around
# (a sphere's u spans twice the length of its v: the detail's domes stay round). An engine
# that decodes it with the first map's tangents lights its domes from the opposite side.
LAYERED_UV = "Detail turned"
LAYERED_TILING = (2.0, 1.0)
# The height exhibit: a 16 px height image, magnified (a texel is ~50 px in the picture), so
# the methods' derivatives differ where a reader can see them.
HEIGHT_IMAGE = 16
HEIGHT_FREQ = (2.0, 1.0)
HEIGHT_LABELS = {"forward": "forward", "one-texel": "one-texel", "hq": "HQ",
                 "reference": "reference"}


def _add_turned_uv(obj):
    """LAYERED_UV on obj: its first UV map turned 180 degrees about the centre and tiled."""
    layer = obj.data.uv_layers.new(name=LAYERED_UV)
    uv = np.empty(2 * len(obj.data.loops), dtype=np.float32)
    obj.data.uv_layers["UVMap"].data.foreach_get("uv", uv)
    uv = 0.5 - (uv.reshape(-1, 2) - 0.5) * np.asarray(LAYERED_TILING, dtype=np.float32)
    layer.data.foreach_set("uv", uv.ravel())
    obj.data.uv_layers.active = obj.data.uv_layers["UVMap"]


def _wave_normal_image(size, freq, slope):
    """A smooth tangent-space normal map (colour) from wave_height: the macro layer."""
    _, d = T.wave_height(T.texel_centres(size, size), freq)
    n = np.concatenate([-slope * d, np.ones(d.shape[:-1] + (1,))], axis=-1)
    return 0.5 * n / np.linalg.norm(n, axis=-1, keepdims=True) + 0.5


# Decal shapes: (shape, SG mode label, overwrite, centre distance in front of the sphere's centre,
# projector size), per column. The cone's apex is at the projector, so it sits further out.
DECAL_SHAPE_COLUMNS = (("box", "add", False, 0.5, 0.62), ("sphere", "add", False, 0.5, 0.62),
                       ("cylinder", "overwrite", True, 0.5, 0.62),
                       ("cone", "overwrite", True, 1.0, 0.75))
SHAPE_RADIUS = 0.8
DECAL_SHAPES_IMAGE = 128     # px: 2 x 2 domes across the decal


def _decal_shapes(x, hemi_small, detail):
    """Four spheres with the fine detail map, a decal of each shape across each: the engines'
    way on top (the projector's normal blended over), surface gradients below (add mode for box
    and sphere: the detail continues through the decal; overwrite for cylinder and cone: the
    decal replaces it)."""
    from .bench import baseline_groups as BG
    from ..reference.decals import DECAL_SHAPES
    rows = (("usual", 2.3), ("surface gradient", 0.15))
    crops = []
    for i, (shape, mode, overwrite, ahead, size) in enumerate(DECAL_SHAPE_COLUMNS):
        cx = x + (i - 1.5) * 2.2
        for row, z in rows:
            # Projection axis toward the camera (-Y), tilted: a decal across the curved front.
            proj = S.decal_projector(f"Decal {shape} ({row})",
                                    (cx - 0.12 * ahead, -ahead, z + 0.1 * ahead),
                                    (math.radians(105), math.radians(12), math.radians(8)),
                                    (size, size, size))
            m = np.array(proj.matrix_world)[:3, :3]
            ax, ay, az = (tuple(m[:, k] / np.linalg.norm(m[:, k])) for k in range(3))

            def build(g, proj=proj, row=row, ax=ax, ay=ay, az=az, shape=shape,
                      overwrite=overwrite):
                tc = g.node("ShaderNodeTexCoord", object=proj)
                coords = g.group(G.decal_coordinates_group())
                g.link(tc.outputs["Object"], coords.inputs[0])
                color = g.image(hemi_small, coords.outputs[0], extension="CLIP")
                uv = g.uv("UVMap")
                if row == "usual":
                    under = g.node("ShaderNodeNormalMap", uv_map="UVMap")
                    under.inputs["Strength"].default_value = 0.6
                    g.link(g.image(detail, uv), under.inputs["Color"])
                    return g.group(BG.decal_engine_group(), Normal=under.outputs[0],
                                   Decal_Coordinates=tc.outputs["Object"], Color=color,
                                   Axis_X=ax, Axis_Y=ay, Axis_Z=az, Falloff=0.15,
                                   Shape=DECAL_SHAPES.index(shape)).outputs[0]
                under = g.group(G.normal_map_group("UVMap"), Color=g.image(detail, uv),
                                Strength=0.6)
                node = g.group(G.decal_group(), Decal_Coordinates=tc.outputs["Object"],
                               Color=color, Axis_X=ax, Axis_Y=ay, Falloff=0.15,
                               Shape=DECAL_SHAPES.index(shape), Overwrite=overwrite,
                               Base_Gradient=under.outputs[0])
                return g.resolve(node.outputs[0])
            obj = S.mesh("sphere", (cx, 0, z), f"Decal shapes | {shape} | {row}")
            obj.scale = (SHAPE_RADIUS,) * 3
            obj.data.materials.append(S.material(f"Decal shapes: {shape} {row}", build))
            label = "usual" if row == "usual" else f"SG, {mode}"
            S.label(label, (cx, 0, z - SHAPE_RADIUS - 0.3), 0.22)
            crops.append((f"{shape}: {label}", obj, (0.0, -SHAPE_RADIUS, 0.12)))
        S.label(shape, (cx, 0, 3.22), 0.28)
    S.label("Decal shapes: usual (top) against surface gradients (bottom)", (x, 0, 3.8), 0.26)
    # Crops: each shape's usual against its surface-gradient sphere.
    order = [crops[k] for i in range(4) for k in (2 * i, 2 * i + 1)]
    return S.camera("Camera decal-shapes", x, z=1.55, distance=13.0, crops=order)


SAMPLER_IMAGES = (("waves", lambda: T.wave_height_image(32, (4.0, 2.0))),
                  ("domes", lambda: T.hemisphere_tile_height_image(32, 4, 0.85)))
SAMPLER_BUMP = 0.3           # world units per unit of height


def _sampler_exhibit(x):
    """Blender 5.0+: one SG Height Map HQ (Sampler) group for two height images (each in its
    own Sampler zone), against Blender's Bump node on the same images."""
    from ..addon.sampler_zone import sampler_zone
    crops = []
    bump_scale = SAMPLER_BUMP
    for i, (name, pixels) in enumerate(SAMPLER_IMAGES):
        S.label(f"{name}, 32 x 32 px", (x + (2 * i - 1) * 2.5, 0, 2.35), 0.26)
        image = S.image(f"Height {name} 32", pixels())
        for j, side in enumerate(("usual", "surface gradient")):
            cx = x + (2 * i + j - 1.5) * 2.5

            def build(g, image=image, side=side):
                uv = g.uv("UVMap")
                if side == "usual":
                    bump = g.node("ShaderNodeBump")
                    bump.inputs["Distance"].default_value = bump_scale
                    g.link(g.first(g.image(image, uv)), bump.inputs["Height"])
                    return bump.outputs["Normal"]
                tex = g.node("ShaderNodeTexImage", interpolation="Linear")
                tex.image = image
                zone, _, _ = sampler_zone(g.nodes, g.links, tex)
                node = g.group(G.height_map_sampler_group("hq"), UV=uv, Bump_Scale=bump_scale,
                               Sampler=zone.outputs[0], Image_Width=image.size[0],
                               Image_Height=image.size[1])
                return g.resolve(node.outputs[0])
            obj = S.mesh("sphere", (cx, 0, 1.1), f"Sampler | {name} | {side}")
            obj.data.materials.append(S.material(f"Sampler: {name}, {side}", build))
            label = "usual: Bump node" if side == "usual" else "SG Height Map HQ\n(Sampler)"
            S.label(label, (cx, 0, -0.22), 0.22)
            crops.append((f"{name}: {label.replace(chr(10), ' ')}", obj, S.FRONT_SPOT))
    S.label("One Sampler group for both images (Blender 5.0+)", (x, 0, 3.0))
    return S.camera("Camera sampler", x, distance=14.5, crops=crops)


def build_closure_demo(log=print):
    """demo_closures.blend's content: the sampler exhibit alone (Blender 5.0+)."""
    import bpy
    if not has_closures():
        raise G.FeatureUnavailable(
            f"the Sampler exhibit needs Blender 5.0 or newer (Closure zones), and Blender "
            f"{bpy.app.version_string} has none; open demo.blend for the other exhibits")
    S.new_file()
    cams = {"sampler": _sampler_exhibit(0.0)}
    bpy.context.scene.camera = cams["sampler"]
    log("built the sampler exhibit")
    return cams


def build_demo(log=print):
    """Build the exhibits into a fresh file; returns the exhibit cameras {title: camera}. The
    sampler exhibit needs Blender 5.0 (closures) and is built only there."""
    import bpy
    from mathutils import Euler, Matrix
    from .bench import baseline_groups as BG
    scene = S.new_file()
    hemi = S.image("Hemispheres", T.hemisphere_tile_image(256))
    detail = S.image("Detail tile", T.hemisphere_tile_image(256, 8, 0.6))
    height = S.image(f"Height {HEIGHT_IMAGE}", T.wave_height_image(HEIGHT_IMAGE, HEIGHT_FREQ))
    macro_waves = S.image("Macro waves", _wave_normal_image(128, (3.0, 2.0), 0.06))
    domes = S.image("Dome heights", T.hemisphere_tile_height_image(256))
    cams = {}

    def uv(g, name="UVMap"):
        return g.uv(name)

    def nm(g, image, uv_name="UVMap"):
        node = g.group(G.normal_map_group(uv_name), Color=g.image(image, uv(g, uv_name)))
        return node.outputs[0]

    # 1. Layered detail on a second UV map (Figure 1): the same macro and detail maps on both
    # spheres; only the detail's tangent frame differs.
    x = 0.0

    def layered(detail_frame):
        def build(g):
            color = g.image(detail, uv(g, LAYERED_UV))
            if detail_frame == "UVMap":      # the usual: one tangent frame, the first map's
                tn = g.group(G.normal_map_group("UVMap"), Color=color)
            else:                            # the second map's own basis
                basis = g.group(G.procedural_basis_group(), UV=uv(g, LAYERED_UV))
                tn = g.group(G.tangent_normal_group(), Color=color,
                             Tangent=basis.outputs[0], Bitangent=basis.outputs[1])
            comb = g.group(G.combine_group(), A=nm(g, macro_waves), B=tn.outputs[0],
                           Scale_B=1.0)
            return g.resolve(comb.outputs[0])
        return build
    a, b = S.pair(x, "Detail on a second UV map, turned", layered("UVMap"),
                 layered(LAYERED_UV), left_label="usual: first map's tangents",
                 right_label="surface gradient: its own basis")
    for obj in (a, b):
        _add_turned_uv(obj)
    cams["layered"] = S.camera("Camera layered", x, crops=S.pair_crops(
        a, b, S.FRONT_SPOT, ("usual: first map's tangents", "surface gradient")))

    # 2. Triplanar on a rock (Figure 5).
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
    a, b = S.pair(x, "Triplanar on a rock", tri_usual, tri_sg, kind="rock")
    for obj in (a, b):
        from .methods import add_displace_modifier
        add_displace_modifier(obj, {"Amount": 0.18, "Scale": 1.6, "Octaves": 3})
    cams["triplanar"] = S.camera("Camera triplanar", x, crops=S.pair_crops(
        a, b, (0.0, -1.0, 0.1)))

    # 3. Decal across a torus and a plane (Figure 6).
    x += EXHIBIT_SPACING
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
    a, b = S.pair(x, "Decal across a torus and a plane", decal(projectors[0], False),
                 decal(projectors[1], True), kind="torus")
    for obj, proj, side in ((a, projectors[0], "usual"), (b, projectors[1], "surface gradient")):
        plane = S.mesh("plane", obj.location, f"Decal plane ({side})")
        plane.data.materials.append(obj.data.materials[0])
    cams["decal"] = S.camera("Camera decal", x, crops=S.pair_crops(a, b, (0.0, -0.3, 0.0)))

    # 4. Volume noise bump (Figure 4).
    x += EXHIBIT_SPACING

    def noise_usual(g):
        noise = g.group(G.noise_group(), Scale=3.0)
        return g.perlin(g.geometry("Normal"), g.scale(noise.outputs["Gradient"], NOISE_AMOUNT))

    def noise_sg(g):
        noise = g.group(G.noise_group(), Scale=3.0)
        vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                     Bump_Scale=NOISE_AMOUNT)
        return g.resolve(vg.outputs[0])
    a, b = S.pair(x, "Volume noise bump", noise_usual, noise_sg, left_label="Perlin 1985")
    cams["noise"] = S.camera("Camera noise", x, crops=S.pair_crops(a, b, S.FRONT_SPOT,
                                                                 ("Perlin 1985",
                                                                  "surface gradient")))

    # 5. Height-map derivatives (Figure 8) on a magnified 16 px height image: forward
    # differences, one-texel, HQ, and the reference (a normal map baked from the exact height).
    x += EXHIBIT_SPACING
    variants = [("forward", lambda g: g.resolve(g.group(
        G.height_map_forward_group(), Height=g.first(g.image(height, uv(g))),
        Bump_Scale=HEIGHT_BUMP).outputs[0]))]
    for v in ("one-texel", "hq"):
        variants.append((v, lambda g, v=v: g.resolve(g.group(
            G.height_map_group(height, v), UV=uv(g), Bump_Scale=HEIGHT_BUMP).outputs[0])))
    height_objs = []
    for i, (label, build) in enumerate(variants):
        obj = S.mesh("sphere", (x - 2.4 + 1.6 * i, 0, 1.1), f"Height map | {label}")
        height_objs.append((HEIGHT_LABELS[label], obj))
        obj.scale = (0.72, 0.72, 0.72)
        obj.data.materials.append(S.material(f"Height map: {label}", build))
        S.label(HEIGHT_LABELS[label], (x - 2.4 + 1.6 * i, 0, 0.05), 0.2)
    obj = S.mesh("sphere", (x + 2.4, 0, 1.1), "Height map | reference")
    obj.scale = (0.72, 0.72, 0.72)
    from .bench.scenario import bake_normal_map_from_truth, exact_height_surfgrad
    from ..reference import methods as M
    from .mesh_data import mesh_arrays_from_object
    bpy.context.view_layer.update()
    arrays = mesh_arrays_from_object(obj)
    nmap = S.image("Normal map from the exact height", bake_normal_map_from_truth(
        arrays, "UVMap", 128, lambda td: M.resolve(exact_height_surfgrad(
            td, T.wave_height(td.uv(), HEIGHT_FREQ)[1], HEIGHT_BUMP))))
    obj.data.materials.append(S.material("Height map: reference", lambda g: g.resolve(
        g.group(G.normal_map_group("UVMap"), Color=g.image(nmap, uv(g))).outputs[0])))
    height_objs.append((HEIGHT_LABELS["reference"], obj))
    S.label(HEIGHT_LABELS["reference"], (x + 2.4, 0, 0.05), 0.2)
    S.label(f"One {HEIGHT_IMAGE} x {HEIGHT_IMAGE} px height map, magnified", (x, 0, 2.65))
    spot = (-0.2, -0.65, 0.2)          # the front, clear of the pole where the map pinches
    # Orthographic, 1.6 units (the spheres' spacing) = 290 px at 1280 wide: every sphere is
    # seen alike and the crops line up to the pixel, so each can be differenced against the
    # reference's (demo_pictures' error row).
    cams["height"] = S.camera("Camera height", x, distance=9.8,
                             crops=[(label, o, spot) for label, o in height_objs],
                             ortho_scale=1.6 * 1280 / 290,
                             reference=HEIGHT_LABELS["reference"])

    # 6. Gustavson's displacement with bump on top.
    x += EXHIBIT_SPACING

    def bump_on_top(g):
        noise = g.group(G.noise_group(), Vector=g.group(G.rest_position_group()).outputs[0],
                        Scale=9.0, Octaves=2)
        vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                     Bump_Scale=0.015)
        return g.resolve(vg.outputs[0])
    a, b = S.pair(x, "Displacement with bump on top", lambda g: None, bump_on_top,
                 left_label="displaced, normals recomputed", right_label="analytic + bump")
    from .methods import add_displace_modifier
    for obj, analytic in ((a, False), (b, True)):
        mod = add_displace_modifier(obj, {"Amount": 0.15, "Scale": 1.8, "Octaves": 2})
        compat.set_input(mod, "Analytic Normals", analytic)
    cams["displacement"] = S.camera("Camera displacement", x, crops=S.pair_crops(
        a, b, S.FRONT_SPOT, ("normals recomputed", "analytic + bump")))

    # 7. Parallax with post-resolve detail (Figure 7c).
    x += EXHIBIT_SPACING

    def parallax(detail_on_top):
        def build(g):
            view = g.geometry("Incoming")
            par = g.group(G.parallax_group(domes), UV=uv(g), View=view, Depth=0.12)
            base = g.resolve(g.group(G.normal_map_group("UVMap"),
                                     Color=g.image(hemi, par.outputs["UV"])).outputs[0])
            if not detail_on_top:
                return base
            noise = g.group(G.noise_group(), Scale=12.0, Octaves=2)
            vg = g.group(G.volume_gradient_group(), Gradient=noise.outputs["Gradient"],
                         Bump_Scale=0.01, Normal=base)
            return g.resolve(vg.outputs[0], normal=base)
        return build
    a, b = S.pair(x, "Parallax with post-resolve detail", parallax(False), parallax(True),
                 kind="plane", left_label="parallax occlusion", right_label="+ detail on top")
    cams["parallax"] = S.camera("Camera parallax", x, crops=S.pair_crops(
        a, b, (-0.3, -0.1, 0.3), ("parallax occlusion", "+ detail on top")))

    # 8. Decal shapes and modes on curved surfaces.
    x += EXHIBIT_SPACING + 4.0         # a wide exhibit: out of its neighbours' views
    cams["decal-shapes"] = _decal_shapes(x, hemi_small=S.image(
        "Domes 128", T.hemisphere_tile_image(DECAL_SHAPES_IMAGE, 2, 0.9)), detail=detail)

    # 9. Sampler closures (Blender 5.0+): one group, any image.
    if has_closures():
        x += EXHIBIT_SPACING + 4.0
        cams["sampler"] = _sampler_exhibit(x)
    else:
        log("Blender < 5.0: no closures, the sampler exhibit is left out (demo_closures.blend "
            "has it)")

    overview = S.camera("Camera overview", x / 2, z=3.0, distance=40.0)
    scene.camera = overview
    log(f"built {len(cams)} exhibits")
    return cams


def save_demo(path, overwrite=False, log=print, closures=False):
    """Build and save demo.blend (every exhibit; the sampler exhibit only where Blender has
    closures), or with `closures` demo_closures.blend: the sampler exhibit alone, 5.0+."""
    import bpy
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass --overwrite to replace it")
    reason = G.unavailable_reason("SG Displace")
    if reason and not closures:     # refuse before building anything (docs/versions.md)
        raise G.FeatureUnavailable(f"demo.blend shows Gustavson's displacement, and {reason}; "
                                   f"open the repository's demo.blend instead (saved with 4.5)")
    cams = build_closure_demo(log) if closures else build_demo(log)
    path.parent.mkdir(parents=True, exist_ok=True)      # the folder the file was asked into
    if path.exists():
        path.unlink()            # told to overwrite: replace it without a .blend1 backup
    bpy.ops.wm.save_as_mainfile(filepath=str(path.resolve()), compress=True)
    log(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return cams
