"""Red team 54c: images as artists have them, through bake-normal-map, bake-batch, compare
--image, the api and Freeze.

1. A missing Base Color or Roughness image (a texture folder moved, one file not copied to the
   farm) refused the normal bake (exit 2, "2 problems: image 'Base Color' reads ..., which does
   not exist: Cycles would bake its magenta 'missing' colour"), and Freeze (FreezeError), and
   bake-batch (its planner refused the asset: exit 1, no map). The normal bake never reads
   them: each BSDF stands in as a white Diffuse BSDF fed its Normal (bake_closures.py), so the
   map of a plane fed a normal 60 degrees off the surface is that normal (measured: 0.001
   degrees off) with or without them. Now only an image that can reach the baked normal is
   refused (normal_sources.py: what feeds a BSDF's Normal, a Bump or Displacement height, a
   Mix Shader's Fac, an SG group's inputs, through reroutes, muted nodes and node groups, in
   and out by socket); the others are warned of, naming the image, its node and the material
   (stderr, the api's, the batch's and Freeze's warnings; bake-batch now exits 0 with the
   map, measured by hand: the batch planner shares image_checks.image_problems).
2. The same for a file saved between the checks and the bake (input_stamps.py): a Base Color
   texture the artist re-saved while the bake ran failed it ("image file ... changed while it
   was baked", exit 1, no map), though the map cannot hold it. Now only the files that can
   reach the normal are stamped: the map is written (every texel the normal fed in), and a
   normal map's file changed is still a failure (tests/test_faults_pipeline32.py).
3. A Generated image (Image Texture > New, never painted) read as the normal map: the default
   black Blank one baked every normal 125.3 degrees off the surface's (into it), a Color Grid
   124.9 on average (up to 135), a UV Grid 54.7 (8 x 8), exit 0 and no word (the sRGB, grey
   and range warnings judge files and float pixels). Now warned of, naming the image, the
   node, the tilt of a Blank one and the fix (normal_map_checks.generated_problem); a flat
   (0.5, 0.5, 1) Blank one, or one painted in the session, is not.
"""

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.bake_request import BakeRequestError  # noqa: E402
from surfgrad_addon.addon.image_checks import image_problems  # noqa: E402
from support.baked_normals import baked_normals, degrees_between  # noqa: E402
from support.blender import missing_image  # noqa: E402
from support.materials import plane_with_output  # noqa: E402

pytestmark = pytest.mark.tier("blender")

RES = 16
TILT = math.radians(60.0)
NORMAL = np.array([math.sin(TILT), 0.0, math.cos(TILT)])


def _gone(name):
    return missing_image(name, "surfgrad54c")


def _plane():
    """A plane whose Principled BSDF is fed a constant tangent-space normal 60 degrees from the
    surface (RGB -> Normal Map), as an importer wires one. Returns (obj, tree, bsdf)."""
    obj, tree = plane_with_output("Artist")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    tree.links.new(bsdf.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (*(NORMAL * 0.5 + 0.5), 1.0)
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(rgb.outputs[0], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs[0], bsdf.inputs["Normal"])
    return obj, tree, bsdf


def _texture(tree, image, name):
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.name = name
    tex.image = image
    return tex


def _checked(obj):
    """(problems, warnings) of the image checks."""
    warned = []
    return image_problems(obj, warnings=warned), warned


@pytest.mark.tier("bake")
def test_a_missing_base_color_or_roughness_image_bakes_the_map_and_is_warned_of(tmp_path,
                                                                                capsys):
    """Finding 1: the map is the normal fed in, every texel (before: refused, exit 2)."""
    obj, tree, bsdf = _plane()
    for socket in ("Base Color", "Roughness"):
        tree.links.new(_texture(tree, _gone(socket.replace(" ", "")), socket).outputs[0],
                       bsdf.inputs[socket])
    capsys.readouterr()
    got = baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
    assert degrees_between(got, NORMAL).max() < 0.05
    err = capsys.readouterr().err
    for name, node in (("BaseColor", "Base Color"), ("Roughness", "Roughness")):
        assert f"image {name!r} reads '/nonexistent/surfgrad54c/{name}.png', which does not " \
               f"exist" in err, err
        assert f"(read by {node!r} in material 'Artist'; it feeds no normal the bake reads" \
            in err, err
    assert "would bake" not in err                  # it renders magenta; the map does not


@pytest.mark.tier("bake")
def test_a_missing_image_the_normal_reads_is_still_refused(tmp_path):
    """Finding 1: the same image into the Normal Map's Color is refused, nothing written."""
    obj, tree, bsdf = _plane()
    tex = _texture(tree, _gone("Bumps"), "Bumps")
    tree.links.new(tex.outputs[0], tree.nodes["Normal Map"].inputs["Color"])
    with pytest.raises(BakeRequestError, match="image 'Bumps' reads .*which does not exist: "
                                               "Cycles would bake its magenta"):
        baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
    assert list(tmp_path.iterdir()) == []


def _group(name, inputs, outputs):
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for socket, kind in inputs:
        group.interface.new_socket(socket, in_out="INPUT", socket_type=kind)
    for socket, kind in outputs:
        group.interface.new_socket(socket, in_out="OUTPUT", socket_type=kind)
    return group, group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")


def _reroute(tree, socket):
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(socket, reroute.inputs[0])
    return reroute.outputs[0]


def _wire(case, tree, bsdf, tex):
    """Wire Image Texture `tex` into the material as `case` names."""
    link, new = tree.links.new, tree.nodes.new
    out = tree.nodes["Material Output"]
    if case == "normal map through a reroute":
        link(_reroute(tree, tex.outputs[0]), tree.nodes["Normal Map"].inputs["Color"])
    elif case == "bump height":
        bump = new("ShaderNodeBump")
        link(tex.outputs[0], bump.inputs["Height"])
        link(bump.outputs[0], bsdf.inputs["Normal"])
    elif case == "displacement":
        disp = new("ShaderNodeDisplacement")
        link(tex.outputs[0], disp.inputs["Height"])
        link(disp.outputs[0], out.inputs["Displacement"])
    elif case == "mix shader factor":
        mix, flat = new("ShaderNodeMixShader"), new("ShaderNodeBsdfDiffuse")
        link(tex.outputs[0], mix.inputs["Fac"])
        link(bsdf.outputs[0], mix.inputs[1])
        link(flat.outputs[0], mix.inputs[2])
        link(mix.outputs[0], out.inputs["Surface"])
    elif case == "sg normal map":
        sg, resolve = new("ShaderNodeGroup"), new("ShaderNodeGroup")
        sg.node_tree, resolve.node_tree = G.normal_map_group("UVMap"), G.resolve_group()
        link(tex.outputs[0], sg.inputs["Color"])
        link(sg.outputs[0], resolve.inputs[next(s.identifier for s in resolve.inputs
                                                if s.type == "VECTOR" and s.name != "Normal")])
        link(resolve.outputs[0], bsdf.inputs["Normal"])
    elif case == "the vector of the normal's image":
        other = _texture(tree, bpy.data.images.new("Fine", 4, 4), "Fine")
        link(tex.outputs[0], other.inputs["Vector"])
        link(other.outputs[0], tree.nodes["Normal Map"].inputs["Color"])
    elif case in ("the normal of a shader group", "the base color of a shader group"):
        group, gin, gout = _group("Skin", [("Tint", "NodeSocketColor"),
                                           ("Normal", "NodeSocketVector")],
                                  [("BSDF", "NodeSocketShader")])
        inner = group.nodes.new("ShaderNodeBsdfPrincipled")
        group.links.new(gin.outputs["Tint"], inner.inputs["Base Color"])
        group.links.new(gin.outputs["Normal"], inner.inputs["Normal"])
        group.links.new(inner.outputs[0], gout.inputs["BSDF"])
        node = new("ShaderNodeGroup")
        node.node_tree = group
        link(node.outputs[0], out.inputs["Surface"])
        normal_map = new("ShaderNodeNormalMap")
        link(normal_map.outputs[0], node.inputs["Normal"])
        if case == "the normal of a shader group":
            link(tex.outputs[0], normal_map.inputs["Color"])
        else:
            link(tex.outputs[0], node.inputs["Tint"])
    elif case == "a vector group's input":
        group, gin, gout = _group("Detail", [("Map", "NodeSocketColor")],
                                  [("Normal", "NodeSocketVector")])
        inner = group.nodes.new("ShaderNodeNormalMap")
        group.links.new(_reroute(group, gin.outputs["Map"]), inner.inputs["Color"])
        group.links.new(inner.outputs[0], gout.inputs["Normal"])
        node = new("ShaderNodeGroup")
        node.node_tree = group
        link(tex.outputs[0], node.inputs["Map"])
        link(node.outputs[0], bsdf.inputs["Normal"])
    elif case in ("base color", "roughness", "alpha", "coat normal"):
        link(tex.outputs[0], bsdf.inputs[case.title()])
    elif case == "emission":
        add, emit = new("ShaderNodeAddShader"), new("ShaderNodeEmission")
        link(tex.outputs[0], emit.inputs["Color"])
        link(bsdf.outputs[0], add.inputs[0])
        link(emit.outputs[0], add.inputs[1])
        link(add.outputs[0], out.inputs["Surface"])
    else:
        raise AssertionError(case)


REFUSED = ["normal map through a reroute", "bump height", "displacement", "mix shader factor",
           "sg normal map", "the vector of the normal's image", "the normal of a shader group",
           "a vector group's input"]
WARNED = ["base color", "roughness", "alpha", "coat normal", "emission",
          "the base color of a shader group"]


@pytest.mark.parametrize("case", REFUSED + WARNED)
def test_only_a_missing_image_that_reaches_the_baked_normal_is_refused(case):
    """Finding 1: refused where it can reach the map (before too), warned of where it cannot
    (before: refused alike)."""
    obj, tree, bsdf = _plane()
    _wire(case, tree, bsdf, _texture(tree, _gone("Gone"), "Tex"))
    problems, warned = _checked(obj)
    said = problems if case in REFUSED else warned
    quiet = warned if case in REFUSED else problems
    assert len(said) == 1 and "image 'Gone' reads '/nonexistent/surfgrad54c/Gone.png'" in \
        said[0], (problems, warned)
    assert quiet == [], (problems, warned)


def test_an_image_read_for_the_normal_and_a_colour_is_refused_as_the_normals():
    """Finding 1: one image, two Image Texture nodes: the normal's refuses, named."""
    obj, tree, bsdf = _plane()
    image = _gone("Shared")
    tree.links.new(_texture(tree, image, "AsColour").outputs[0], bsdf.inputs["Base Color"])
    tree.links.new(_texture(tree, image, "AsNormal").outputs[0],
                   tree.nodes["Normal Map"].inputs["Color"])
    problems, warned = _checked(obj)
    assert len(problems) == 1 and "(read by 'AsNormal' in material 'Artist')" in problems[0]
    assert warned == []


def _png(path, rgba):
    image = bpy.data.images.new(path.stem, 4, 4)
    image.pixels.foreach_set(np.tile(np.float32(rgba), 16))
    image.filepath_raw, image.file_format = str(path), "PNG"
    image.save()
    bpy.data.images.remove(image)


@pytest.mark.tier("bake")
def test_a_base_color_file_saved_during_the_bake_does_not_fail_it(tmp_path, monkeypatch):
    """Finding 2: the map is written, every texel the normal fed (before: BakeFailed)."""
    from surfgrad_addon.addon import bake_request
    obj, tree, bsdf = _plane()
    colour = tmp_path / "rock_color.png"
    _png(colour, (0.8, 0.3, 0.1, 1.0))
    tex = _texture(tree, bpy.data.images.load(str(colour)), "Colour")
    tree.links.new(tex.outputs[0], bsdf.inputs["Base Color"])
    real = bake_request.NB.bake_normal_tiles

    def saved_then_baked(*args, **kwargs):
        _png(colour, (0.1, 0.3, 0.8, 1.0))          # the painter saves the colour again
        colour.write_bytes(colour.read_bytes() + b"\0" * 64)   # (a size of its own)
        return real(*args, **kwargs)
    monkeypatch.setattr(bake_request.NB, "bake_normal_tiles", saved_then_baked)
    got = baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
    assert degrees_between(got, NORMAL).max() < 0.05


@pytest.mark.tier("bake")
def test_freeze_of_a_stack_beside_a_missing_base_color_image_freezes_and_warns():
    """Finding 1 in Freeze (the operator's own function): a stack added with Add Layer Stack
    (api.add_layer_stack), its Principled BSDF's Base Color a missing image. Before: refused
    ("image 'BaseColor' reads ..., which does not exist"); now frozen and warned of, and the
    frozen map is the stack's (a flat SG Normal Map: the surface's normal)."""
    from surfgrad_addon import api
    from surfgrad_addon.addon import freeze as F
    obj, tree, bsdf = _plane()
    for node in [n for n in tree.nodes if n.bl_idname in ("ShaderNodeRGB",
                                                          "ShaderNodeNormalMap")]:
        tree.nodes.remove(node)
    api.add_layer_stack(obj.active_material)
    tree.links.new(_texture(tree, _gone("BaseColor"), "Colour").outputs[0],
                   bsdf.inputs["Base Color"])
    warned = []
    record = F.freeze(obj, RES, warn=warned.append)
    image = bpy.data.images[record["image"]]
    px = np.array(image.pixels[:]).reshape(RES, RES, 4)[..., :3] * 2.0 - 1.0
    px /= np.linalg.norm(px, axis=-1, keepdims=True)
    assert degrees_between(px, np.array([0.0, 0.0, 1.0])).max() < 1.0
    assert any("image 'BaseColor' reads" in w and "feeds no normal the bake reads" in w
               for w in warned), warned
    F.thaw(obj.active_material)


def _generated(tree, kind, colour=(0.0, 0.0, 0.0), painted=False):
    image = bpy.data.images.new(f"Untitled {kind}", 8, 8)
    image.generated_type, image.generated_color = kind, (*colour, 1.0)
    image.colorspace_settings.is_data = True
    if painted:                                 # as Texture Paint leaves it: dirty
        image.pixels.foreach_set(np.tile(np.float32([0.5, 0.5, 1.0, 1.0]), 64))
        image.update()
    tex = _texture(tree, image, "New")
    tree.links.new(tex.outputs[0], tree.nodes["Normal Map"].inputs["Color"])
    return image


@pytest.mark.tier("bake")
@pytest.mark.parametrize("kind, colour, painted, mean_deg, warned", [
    ("BLANK", (0.0, 0.0, 0.0), False, 125.26, "one colour (0.00, 0.00, 0.00), not a normal "
                                              "map: every normal tilts 125 degrees from the "
                                              "surface's (into it)"),
    ("COLOR_GRID", (0.0, 0.0, 0.0), False, 124.9, "is a Generated Color Grid (a test "
                                                  "pattern), not a normal map"),
    ("UV_GRID", (0.0, 0.0, 0.0), False, 54.74, "is a Generated UV Grid (a test pattern)"),
    ("BLANK", (0.5, 0.5, 1.0), False, 0.0, None),
    ("BLANK", (0.0, 0.0, 0.0), True, 0.0, None)])
def test_a_generated_image_read_as_the_normal_map_is_warned_of(tmp_path, capsys, kind, colour,
                                                               painted, mean_deg, warned):
    """Finding 3: the map is what Cycles renders (the tilt measured from the surface's normal:
    (0, 0, 0) decodes to (-1, -1, -1), acos(-1 / sqrt(3)) = 125.26 degrees), and the warning
    names it (before: no word)."""
    obj, tree, _ = _plane()
    _generated(tree, kind, colour, painted)
    capsys.readouterr()
    got = baked_normals(obj, tmp_path / "n.exr", "tangent", RES)
    deg = degrees_between(got, np.array([0.0, 0.0, 1.0]))
    assert abs(deg.mean() - mean_deg) < 0.5, deg.mean()
    err = capsys.readouterr().err
    if warned:
        assert f"image 'Untitled {kind}', read by Normal Map node 'Normal Map' (material " \
               f"'Artist'), is a Generated" in err and warned in err, err
        assert "load the normal map's file (Image > Open)" in err
    else:
        assert "Generated" not in err, err
