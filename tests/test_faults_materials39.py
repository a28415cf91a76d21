"""Red team 39c: materials as artists wire them by hand, and the tools on them.

- Several Material Output nodes: Cycles renders through an output targeted at Cycles before
  one targeted at All, even when the All one is the active output (Blender's
  ntreeShaderOutputNode; pinned here on every line by baking each output's colour). The
  checks before a bake (material_inputs.cycles_output) took the active All output, so an image
  the Cycles output reads was never checked: a missing one baked Cycles' magenta with exit 0.
  Freeze took the active output whatever its target: with the stack on an active All output
  and a plain shader on a Cycles one, it reported success and wired in a flat map (every texel
  (0.5, 0.5, 1.0)); with the stack on the Cycles output it was refused ("add one").
  Add Layer Stack (the operator and api.add_layer_stack) wired the stack into the active All
  output's BSDF: nothing changed in a Cycles render.
- A Bump node after the stack (SG Resolve into the Bump's Normal, the Bump into the BSDF):
  Freeze took the Bump node for a second shader fed by a stack and was refused with "2
  different surface-gradient stacks feed the BSDF Normal inputs".
- SG groups inside the artist's own node group (one or two levels): Freeze looked for SG
  groups in the material's tree only and was refused with "no surface-gradient stack feeds a
  BSDF Normal input: add one".
- The stack into a Principled BSDF's Normal and Coat Normal: Freeze wired the frozen map into
  Normal only, so the "frozen" material still ran the whole live stack for the coat (none of
  it framed), at the live stack's cost, not the built-in twin's.
- One stack reaching a second BSDF (a Mix Shader's other branch, a coat) through a reroute:
  Freeze took the reroute for a second stack ("2 different surface-gradient stacks").
- A Color Attribute node as the normal map, naming an attribute the mesh lacks: Cycles bakes
  zero (the SG Normal Map of black: object-space normals 48 degrees off on a plane), and
  bake-normal-map wrote it with exit 0; one naming a UV map crashed the bake (SIGSEGV, exit
  139, measured on every line; at times on 4.2 values near 1e25 instead). A Tangent node
  (UV Map) naming a missing UV map bakes a zero tangent. Both now refused before the bake.
- A second material on the object, its faces unwrapped over the frozen material's (a part per
  material on the whole 0-1 square): Freeze baked every material's faces into the map, and
  theirs overwrote the frozen material's, exit 0 (every texel here). Now the other materials
  bake into a throwaway image (normal_bake.bake_normal_tiles(only=...)).
- The stack switched off by muting its link into the BSDF's Normal: Freeze baked and wired
  it in unmuted (the frozen material showed the stack the live one did not), and Thaw left
  the link unmuted. Now refused, naming the muted link.
- The stack and its BSDF inside the artist's shader group: refused with "add one" (there is
  one); now the group is named, with the fix.
- Normal maps into SG Triplanar (Color X, Y, Z), SG Decal (Color) and SG Blend Normals
  (Color A, B): the warnings about an sRGB, grey or -1..1 map (given for SG Normal Map and
  the Normal Map node) were not given for them, by bake-normal-map or Freeze.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import normal_bake as NB  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.image_checks import (image_problems,  # noqa: E402
                                              uv_reference_problems)
from surfgrad_addon.addon.material_inputs import cycles_output  # noqa: E402
from surfgrad_addon.addon.normal_map_checks import (colour_space_warnings,  # noqa: E402
                                                    normal_map_images)
from surfgrad_addon.harness import scenes as test_scenes  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("bake")

QUIET = dict(log=lambda *_: None)
SIZE = 16
COLOURS = {"R": (1.0, 0.0, 0.0, 1.0), "G": (0.0, 1.0, 0.0, 1.0), "B": (0.0, 0.0, 1.0, 1.0)}


def _emission_outputs(obj, image, spec, active):
    """A material of one Emission per (colour, target) output, output `active` made active."""
    mat = new_material("Outputs")
    tree = mat.node_tree
    tree.nodes.clear()
    outputs = []
    for colour, target in spec:
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        out.target = target
        emission = tree.nodes.new("ShaderNodeEmission")
        emission.inputs[0].default_value = COLOURS[colour]
        tree.links.new(emission.outputs[0], out.inputs["Surface"])
        outputs.append((colour, out))
    outputs[active][1].is_active_output = True
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tree.nodes.active = tex
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    return mat, outputs


def _cycles_plane():
    """A fresh file holding a plane, Cycles on the CPU at 1 sample."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.device = "CPU"
    bpy.ops.mesh.primitive_plane_add()
    return bpy.context.object


def test_the_output_cycles_renders_is_the_one_the_checks_read():
    obj = _cycles_plane()
    image = bpy.data.images.new("Emit", 4, 4, float_buffer=True)
    cases = [([("R", "ALL"), ("G", "CYCLES")], 0),          # active All, inactive Cycles
             ([("G", "CYCLES"), ("R", "ALL")], 1),
             ([("R", "EEVEE"), ("G", "ALL")], 0),
             ([("R", "ALL"), ("G", "ALL")], 1),
             ([("R", "CYCLES"), ("G", "CYCLES")], 1),
             ([("R", "CYCLES"), ("G", "ALL"), ("B", "ALL")], 2)]
    for spec, active in cases:
        mat, outputs = _emission_outputs(obj, image, spec, active)
        bpy.ops.object.bake(type="EMIT")
        texel = np.array(image.pixels[:]).reshape(-1, 4)[0, :3]
        baked = "RGB"[int(texel.argmax())]
        assert texel.max() > 0.9, (spec, texel)
        chosen = cycles_output(mat.node_tree)
        assert [c for c, out in outputs if out == chosen] == [baked], (spec, active)
        bpy.data.materials.remove(mat)
    _, outputs = _emission_outputs(obj, image, [("R", "EEVEE")], 0)
    assert cycles_output(obj.active_material.node_tree) is None       # Cycles renders none


def _beside_a_cycles_output(tree):
    """A Diffuse BSDF into a new Material Output targeted at Cycles, beside the tree's All
    output, made the active one: (the All output, the Cycles output, its Diffuse BSDF)."""
    everyone = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    cycles = tree.nodes.new("ShaderNodeOutputMaterial")
    cycles.target = "CYCLES"
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(diffuse.outputs[0], cycles.inputs["Surface"])
    everyone.is_active_output = True
    return everyone, cycles, diffuse


def test_an_image_on_the_cycles_output_is_checked_beside_an_active_all_output():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.object
    mat = new_material("Two outputs")
    tree = mat.node_tree
    everyone, cycles, diffuse = _beside_a_cycles_output(tree)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.name = "CyclesBumps"
    tex.image = bpy.data.images.new("gone.png", 4, 4)
    tex.image.source = "FILE"
    tex.image.filepath = "/nonexistent/surfgrad/gone.png"
    tree.links.new(tex.outputs["Color"], diffuse.inputs["Normal"])   # (a Color is not baked)
    obj.data.materials.append(mat)
    assert everyone.is_active_output and not cycles.is_active_output
    text = "\n".join(image_problems(obj))
    assert "'CyclesBumps'" in text and "gone.png" in text, text


@pytest.fixture(scope="module")
def sphere():
    obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    mat, bsdf = layered_material(obj)
    return obj, mat, bsdf


def frozen_pixels(obj, mat):
    """Freeze, read the map, thaw: the material back exactly as it was."""
    before = material_dump(mat)
    record = F.freeze(obj, SIZE, **QUIET)
    image = bpy.data.images[record["image"]]
    pixels = np.array(image.pixels[:]).reshape(SIZE, SIZE, 4)[..., :3].copy()
    F.thaw(mat)
    assert material_dump(mat) == before
    return pixels


@pytest.fixture(scope="module")
def plain(sphere):
    obj, mat, _ = sphere
    pixels = frozen_pixels(obj, mat)
    covered = pixels.sum(-1) > 0
    assert np.percentile(np.abs(pixels[covered] - (0.5, 0.5, 1.0)).max(-1), 50) > 0.05  # a stack
    return pixels


def test_freeze_bakes_through_the_output_cycles_renders(sphere, plain):
    obj, mat, bsdf = sphere
    tree = mat.node_tree
    everyone, cycles, other = _beside_a_cycles_output(tree)
    try:
        # The stack on the active All output, which Cycles does not render: refused, named.
        before = material_dump(mat)
        with pytest.raises(F.FreezeError, match=r"through 'Material Output.001', targeted at "
                                                r"Cycles"):
            F.freeze(obj, SIZE, **QUIET)
        assert material_dump(mat) == before
        # The stack's BSDF on the Cycles output: frozen, the same map as with one output.
        tree.links.new(bsdf.outputs[0], cycles.inputs["Surface"])
        tree.links.new(other.outputs[0], everyone.inputs["Surface"])
        assert everyone.is_active_output
        np.testing.assert_allclose(frozen_pixels(obj, mat), plain, atol=1e-6)
    finally:
        if F.RECORD in mat:                             # a freeze that should have failed
            F.thaw(mat)
        tree.links.new(bsdf.outputs[0], everyone.inputs["Surface"])
        tree.nodes.remove(cycles)
        tree.nodes.remove(other)


def test_freeze_takes_a_bump_node_after_the_stack_as_part_of_it(sphere, plain):
    obj, mat, bsdf = sphere
    tree = mat.node_tree
    end = bsdf.inputs["Normal"].links[0].from_socket
    bump = tree.nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.0        # passes the stack's normal on
    tree.links.new(end, bump.inputs["Normal"])
    tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    try:
        np.testing.assert_allclose(frozen_pixels(obj, mat), plain, atol=1e-6)
    finally:
        tree.links.new(end, bsdf.inputs["Normal"])
        tree.nodes.remove(bump)


def test_freeze_wires_the_frozen_map_into_the_coat_normal_too(sphere, plain):
    obj, mat, bsdf = sphere
    tree = mat.node_tree
    end = bsdf.inputs["Normal"].links[0].from_socket
    surface = bsdf.outputs[0].links[0].to_socket
    principled = tree.nodes.new("ShaderNodeBsdfPrincipled")
    for name in ("Normal", "Coat Normal"):
        tree.links.new(end, principled.inputs[name])
    tree.links.new(principled.outputs[0], surface)
    tree.links.remove(bsdf.inputs["Normal"].links[0])   # the Principled BSDF alone uses it
    before = material_dump(mat)
    try:
        record = F.freeze(obj, SIZE, **QUIET)
        frozen = [principled.inputs[name].links[0].from_node for name in ("Normal", "Coat Normal")]
        assert [n.bl_idname for n in frozen] == ["ShaderNodeNormalMap"] * 2, frozen
        frame = tree.nodes[record["frame"]]
        live = [n.name for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"]
        assert live and all(tree.nodes[n].parent == frame for n in live)   # none runs now
        pixels = np.array(bpy.data.images[record["image"]].pixels[:])
        np.testing.assert_allclose(pixels.reshape(SIZE, SIZE, 4)[..., :3], plain, atol=1e-6)
        F.thaw(mat)
        assert material_dump(mat) == before
    finally:
        if F.RECORD in mat:
            F.thaw(mat)
        tree.links.new(bsdf.outputs[0], surface)
        tree.links.new(end, bsdf.inputs["Normal"])
        tree.nodes.remove(principled)


def test_freeze_takes_one_stack_reaching_two_shaders_through_a_reroute(sphere, plain):
    """A Mix Shader of the Diffuse BSDF (the stack straight in) and a Glossy BSDF (the stack
    through a reroute), and a third BSDF in the mix with no stack of its own."""
    obj, mat, bsdf = sphere
    tree = mat.node_tree
    end = bsdf.inputs["Normal"].links[0].from_socket
    surface = bsdf.outputs[0].links[0].to_socket
    mix = tree.nodes.new("ShaderNodeMixShader")
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(bsdf.outputs[0], mix.inputs[1])
    tree.links.new(glossy.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], surface)
    tree.links.new(end, reroute.inputs[0])
    tree.links.new(reroute.outputs[0], glossy.inputs["Normal"])
    before = material_dump(mat)
    try:
        record = F.freeze(obj, SIZE, **QUIET)
        frozen = {n.inputs["Normal"].links[0].from_node.bl_idname for n in (bsdf, glossy)}
        assert frozen == {"ShaderNodeNormalMap"}
        pixels = np.array(bpy.data.images[record["image"]].pixels[:])
        np.testing.assert_allclose(pixels.reshape(SIZE, SIZE, 4)[..., :3], plain, atol=1e-6)
        F.thaw(mat)                                     # the reroute's link back as it was
        assert material_dump(mat) == before
    finally:
        if F.RECORD in mat:
            F.thaw(mat)
        tree.links.new(bsdf.outputs[0], surface)
        for node in (mix, glossy, reroute):
            tree.nodes.remove(node)


def test_freeze_of_a_stack_switched_off_by_a_muted_link_is_refused(sphere):
    """Cycles renders the material as if the muted link were not there: the stack switched
    off. Freeze baked the stack anyway and wired it in through a live link (the look changed),
    and Thaw relinked it unmuted (the file changed)."""
    obj, mat, bsdf = sphere
    link = bsdf.inputs["Normal"].links[0]
    link.is_muted = True
    before = material_dump(mat)
    try:
        with pytest.raises(F.FreezeError, match=r"the link into 'Diffuse BSDF' Normal is muted"):
            F.freeze(obj, SIZE, **QUIET)
        assert material_dump(mat) == before
    finally:
        if F.RECORD in mat:
            F.thaw(mat)
        bsdf.inputs["Normal"].links[0].is_muted = False


def test_freeze_names_the_shader_group_holding_the_stack(sphere):
    """The stack and its BSDF inside the artist's shader group: refused, as before, but with
    "no surface-gradient stack feeds a BSDF Normal input: add one", though there is one."""
    obj, mat, bsdf = sphere
    tree = mat.node_tree
    surface = bsdf.outputs[0].links[0].to_socket
    group = bpy.data.node_groups.new("My Rock Shader", "ShaderNodeTree")
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    normal_map = group.nodes.new("ShaderNodeGroup")
    normal_map.node_tree = api.node_group("SG Normal Map")
    resolve = group.nodes.new("ShaderNodeGroup")
    resolve.node_tree = api.node_group("SG Resolve")
    diffuse = group.nodes.new("ShaderNodeBsdfDiffuse")
    group.links.new(normal_map.outputs[0], resolve.inputs["Surface Gradient"])
    group.links.new(resolve.outputs[0], diffuse.inputs["Normal"])
    group.links.new(diffuse.outputs[0], group.nodes.new("NodeGroupOutput").inputs["Shader"])
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    tree.links.new(node.outputs[0], surface)
    before = material_dump(mat)
    try:
        with pytest.raises(F.FreezeError, match=r"the stack is inside shader node group "
                                                r"'My Rock Shader': .* ungroup it"):
            F.freeze(obj, SIZE, **QUIET)
        assert material_dump(mat) == before
    finally:
        tree.links.new(bsdf.outputs[0], surface)
        tree.nodes.remove(node)


def _chain(name, trees):
    """An artist's group: Color in, Normal out, through one node of each of `trees` in turn
    (the Group Input feeding our inputs)."""
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    group.interface.new_socket("Color", in_out="INPUT", socket_type="NodeSocketColor")
    group.interface.new_socket("Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
    socket = group.nodes.new("NodeGroupInput").outputs["Color"]
    for tree in trees:
        node = group.nodes.new("ShaderNodeGroup")
        node.node_tree = tree
        group.links.new(socket, next(s for s in node.inputs
                                     if s.name in ("Color", "Surface Gradient")))
        socket = node.outputs[0]
    group.links.new(socket, group.nodes.new("NodeGroupOutput").inputs["Normal"])
    return group


def test_freeze_finds_the_stack_inside_the_artists_own_groups(sphere):
    obj, mat, bsdf = sphere
    tree = mat.node_tree
    resolve = bsdf.inputs["Normal"].links[0].from_node
    combined = resolve.inputs["Surface Gradient"].links[0].from_socket
    normal_map = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"
                      and n.node_tree.name.startswith("SG Normal Map"))
    colour = normal_map.inputs["Color"].links[0].from_socket
    tree.links.new(normal_map.outputs[0], resolve.inputs["Surface Gradient"])
    try:
        alone = frozen_pixels(obj, mat)                 # SG Normal Map -> SG Resolve
    finally:
        tree.links.new(combined, resolve.inputs["Surface Gradient"])
    one = _chain("My Normal", [normal_map.node_tree, resolve.node_tree])
    two = _chain("My Look", [one])
    for group in (one, two):                            # no SG group in the material's tree
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        tree.links.new(colour, node.inputs["Color"])
        tree.links.new(node.outputs["Normal"], bsdf.inputs["Normal"])
        try:
            np.testing.assert_allclose(frozen_pixels(obj, mat), alone, atol=1e-6,
                                       err_msg=group.name)
        finally:
            tree.links.new(resolve.outputs[0], bsdf.inputs["Normal"])
            tree.nodes.remove(node)


def _emission_of(obj, image, make_source):
    """Bake (EMIT, 4 x 4) |what make_source(tree) outputs| on obj; returns the first texel."""
    mat = new_material("Emitted")
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    absolute = tree.nodes.new("ShaderNodeVectorMath")
    absolute.operation = "ABSOLUTE"
    tree.links.new(make_source(tree).outputs[0], absolute.inputs[0])
    tree.links.new(absolute.outputs[0], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tree.nodes.active = tex
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    bpy.ops.object.bake(type="EMIT")
    bpy.data.materials.remove(mat)
    return np.array(image.pixels[:]).reshape(-1, 4)[0, :3]


def _node(kind, **settings):
    def make(tree):
        node = tree.nodes.new(kind)
        for key, value in settings.items():
            setattr(node, key, value)
        return node
    return make


def test_a_colour_attribute_or_tangent_the_mesh_lacks_is_refused(tmp_path):
    obj = _cycles_plane()
    colours = obj.data.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    colours.data.foreach_set("color", [0.6, 0.5, 0.9, 1.0] * len(colours.data))
    image = bpy.data.images.new("Emit", 4, 4, float_buffer=True)
    # What Cycles bakes for them on this line: zero (the normal map's colour then decodes to a
    # normal 48 degrees off); the colour attribute named, its colour.
    lacking = {"Color Attribute": _node("ShaderNodeVertexColor", layer_name="Missing"),
               "Tangent": _node("ShaderNodeTangent", direction_type="UV_MAP", uv_map="Missing")}
    for make in lacking.values():
        assert np.abs(_emission_of(obj, image, make)).max() == 0.0
    np.testing.assert_allclose(_emission_of(obj, image, _node(
        "ShaderNodeVertexColor", layer_name="Col")), [0.6, 0.5, 0.9], atol=1e-6)

    mat = new_material("Painted")
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    painted = tree.nodes.new("ShaderNodeVertexColor")
    normal_map = tree.nodes.new("ShaderNodeGroup")
    normal_map.node_tree = api.node_group("SG Normal Map")
    resolve = tree.nodes.new("ShaderNodeGroup")
    resolve.node_tree = api.node_group("SG Resolve")
    tree.links.new(painted.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs[0], resolve.inputs["Surface Gradient"])
    tree.links.new(resolve.outputs[0], bsdf.inputs["Normal"])
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    output = tmp_path / "painted.png"
    for name in ("Col", ""):                            # named, or the render one: baked
        painted.layer_name = name
        assert uv_reference_problems(obj) == []
    for name in ("Missing", "UVMap"):                   # a UV map: garbage, or a crash
        painted.layer_name = name
        with pytest.raises(ValueError) as refused:
            api.bake_normal_map(obj, str(output), resolution=8, **QUIET)
        assert f"node 'Color Attribute' (material 'Painted') reads colour attribute {name!r}" \
            in str(refused.value) and "(colour attributes: ['Col'])" in str(refused.value)
        assert not output.exists()
    painted.layer_name = ""
    obj.data.color_attributes.remove(obj.data.color_attributes["Col"])
    assert "reads the active render colour attribute" in uv_reference_problems(obj)[0]
    tangent = tree.nodes.new("ShaderNodeTangent")
    tangent.direction_type = "UV_MAP"
    tangent.uv_map = "Missing"
    tree.links.new(tangent.outputs[0], bsdf.inputs["Tangent"])
    assert any("node 'Tangent' (material 'Painted') reads UV map 'Missing'" in p
               for p in uv_reference_problems(obj))


def _quads(count):
    """`count` unit quads side by side, each unwrapped onto the whole 0-1 square (as a
    material per part often is), the layered stack's material on every face."""
    scene_obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    verts = [(x + 2 * i, y, 0.0) for i in range(count) for x, y in ((0, 0), (1, 0), (1, 1),
                                                                    (0, 1))]
    mesh = bpy.data.meshes.new("Parts")
    mesh.from_pydata(verts, [], [tuple(range(4 * i, 4 * i + 4)) for i in range(count)])
    uv = mesh.uv_layers.new(name="UVMap")
    uv.data.foreach_set("uv", [0, 0, 1, 0, 1, 1, 0, 1] * count)
    obj = bpy.data.objects.new("Parts", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.data.objects.remove(scene_obj)
    bpy.context.view_layer.objects.active = obj
    mat, _ = layered_material(obj)
    return obj, mat


def test_freeze_bakes_the_frozen_materials_faces_alone(tmp_path):
    """A second material on faces whose UVs overlap the frozen material's: Blender's bake
    writes every material's faces, and they overwrote the frozen map (every texel of it
    here, up to 0.94 off in 0..1, exit 0)."""
    obj, mat = _quads(1)
    alone = frozen_pixels(obj, mat)
    obj, mat = _quads(2)
    other, tree, bsdf = diffuse_material("Other part")
    tilted = tree.nodes.new("ShaderNodeNormalMap")
    tilted.inputs["Color"].default_value = (1.0, 0.5, 0.6, 1.0)
    tree.links.new(tilted.outputs[0], bsdf.inputs["Normal"])
    obj.data.materials.append(other)
    obj.data.polygons[1].material_index = 1
    images = set(bpy.data.images.keys())
    np.testing.assert_allclose(frozen_pixels(obj, mat), alone, atol=1e-6)
    assert set(bpy.data.images.keys()) == images        # the throwaway image is gone
    stranger = new_material("Not on Parts")
    with pytest.raises(NB.NormalBakeError, match="does not render material 'Not on Parts'"):
        NB.bake_normal_tiles(obj, tmp_path / "n.png", resolution=SIZE, log=QUIET["log"],
                             only=stranger)
    assert list(tmp_path.iterdir()) == []


def test_the_layer_stack_goes_into_the_shader_cycles_renders():
    """Add Layer Stack wired the stack into the BSDF of the active All output beside a Cycles
    one, which Cycles does not render: no change in a Cycles render."""
    obj = _cycles_plane()
    mat = new_material("Two outputs")
    tree = mat.node_tree
    _, _, rendered = _beside_a_cycles_output(tree)
    obj.data.materials.append(mat)
    nodes = api.add_layer_stack(mat)
    assert rendered.inputs["Normal"].links[0].from_node == nodes["resolve"]
    assert nodes["resolve"].outputs[0].links[0].to_node == rendered


def test_normal_maps_into_triplanar_decal_and_blend_normals_are_judged():
    """An sRGB (or grey, or -1..1) normal map into SG Triplanar, SG Decal or SG Blend Normals
    bends every normal as it does in SG Normal Map, which was warned about; these were not:
    the bake (and Freeze) said nothing."""
    obj = _cycles_plane()
    image = bpy.data.images.new("Bricks normal", 4, 4)
    image.colorspace_settings.name = "sRGB"
    mat = new_material("Three ways")
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    resolve = tree.nodes.new("ShaderNodeGroup")
    resolve.node_tree = api.node_group("SG Resolve")
    total = resolve.inputs["Surface Gradient"]
    for name, inputs in [("SG Triplanar", ["Color X", "Color Z"]), ("SG Decal", ["Color"]),
                         ("SG Blend Normals", ["Color B"])]:
        node = tree.nodes.new("ShaderNodeGroup")
        node.name = name
        node.node_tree = api.node_group(name)
        for socket in inputs:
            tree.links.new(tex.outputs["Color"], node.inputs[socket])
        add = tree.nodes.new("ShaderNodeVectorMath")          # the layers' gradients summed
        tree.links.new(add.outputs[0], total)
        tree.links.new(node.outputs[0], add.inputs[0])
        total = add.inputs[1]
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    tree.links.new(resolve.outputs[0], bsdf.inputs["Normal"])
    obj.data.materials.append(mat)
    read = sorted(what for _, what, img, _ in normal_map_images(obj) if img == image)
    assert read == ["SG Blend Normals node 'SG Blend Normals' (Color B)", "SG Decal node "
                    "'SG Decal'", "SG Triplanar node 'SG Triplanar' (Color X)",
                    "SG Triplanar node 'SG Triplanar' (Color Z)"], read
    warnings = colour_space_warnings(obj)
    assert len(warnings) == 4 and all("'Bricks normal' is read in colour space 'sRGB'" in w
                                      for w in warnings), warnings
