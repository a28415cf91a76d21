"""Red team 42a: leftovers earlier rounds noticed and left.

1. Freeze walked the material itself to find the stack and took muted nodes as live: a stack
   into a muted BSDF, or into a BSDF a muted Mix Shader does not pass on (its first shader
   goes on), is not rendered, yet it was baked through Freeze's Diffuse stand-in and wired
   in, reported as frozen. Now Freeze follows what Cycles renders
   (a muted node passes on only what its internal links name) and refuses such a stack,
   naming the muted node, as it refuses one behind a muted link; the material unchanged.
   A muted Material Output (pinned here by EMIT bakes on every line): 5.0 and 5.2 render
   through it as if it were live; 4.2 and 4.5 render nothing through it (black; the flat
   normal in a normal bake) and take no other output instead (LineFacts.muted_output_renders).
   On 4.2 and 4.5 Freeze baked and wired in a flat map (the stack gone once the output is
   unmuted), bake-normal-map wrote a flat map without a word, and the image checks refused a
   missing image Cycles never reads there. Now Freeze refuses, the bake warns, and the checks
   read nothing behind such an output.
   Muted nodes inside a live stack (a layer, its Image Texture, a Bump or Normal Map node
   after it) were fine: the bake is Cycles', so the frozen map equals a bake of the live
   material to 1e-5 on every line, and Thaw restores it exactly.
2. What a muted SG group passes on: Blender takes a linked input before an unlinked one (its
   find_internally_linked_input; 4.2 and 4.5 do not show a group node's internal links to
   Python). So muting SG Volume Gradient, its Normal unlinked and SG Noise's Gradient linked
   (the usual layer), passes the unprojected gradient on at Bump Scale 1: on the freeze
   tests' sphere 75.9 deg mean (p99 169) from the layer switched off (Bump Scale 0), on every
   line; artists.md called that layer flat, and the sidebar, which took the first vector
   input, said nothing. So for a muted SG Resolve whose Normal is unlinked: its Surface
   Gradient becomes the normal. Now the sidebar names what each muted group passes (the
   internal links where Python shows them, else Blender's rule), pinned by a bake per line.
3. SG Parallax reading a float height image beyond 0..1 (heights in other units, a map centred
   on 0): exit 0 and no word, where a normal map above 1 is warned about (round 41; SG Decal's
   Color is judged as every normal map input is, measured: its texels above 1 and its -1..1
   storage are warned about). The group does as the reference does (compare with heights 0..3
   and -0.5..0.5: p99 0.0005 deg), but the march starts at 1, so the relief beyond is cut off:
   heights 0..2, 0..3, 0..10 against the same relief as 0..1 at Depth x2, x3, x10: mean 4.4,
   11.0, 35.8 deg, p99 65, 71, 116 (the reference, 64^2 on the sphere); heights shifted by
   -0.5: mean 8.0, p99 69. Now bake-normal-map and Freeze warn, naming the image, the counts
   and the fix.
   SG Triplanar (Sampler) (5.0+, its normal map in a Sampler zone) got none of the normal-map
   warnings (an sRGB, grey or out-of-range map) SG Triplanar gets: now judged the same.
4. A per-image group (SG Height Map HQ, SG Parallax, SG Triplanar Height) under the name of an
   image it no longer holds: "SG Parallax [Bumps]" appended from another file into one that
   has an image "Bumps" (the group keeps its name, its image comes in as "Bumps.001"), or its
   image renamed by the artist. Asking for the group of the file's own "Bumps" (Add > Surface
   Gradient with that Image Texture active, api.node_group) rebuilt that group in place for
   it, so the appended material, which uses it, read the other image from then on, without a
   word. Now the group takes the name of the image it holds, and a new one is made. Where
   such a group was built by an older surfgrad, Update surfgrad Groups left it stale ("its
   rebuild did not reach it"): it built a group for its image under that image's name and
   threw it away unused. Now the group takes that name first and is rebuilt in place.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon.image_checks import image_problems  # noqa: E402
from surfgrad_addon.addon.node_vocabulary import VMath  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.image_checks import muted_output_warnings  # noqa: E402
from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.normal_map_checks import colour_space_warnings  # noqa: E402
from surfgrad_addon.addon.parallax_heights import parallax_height_warnings  # noqa: E402
from surfgrad_addon.addon.ui import add_group_node  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from surfgrad_addon.addon.muted_layers import (blender_rule_input, passed_input,  # noqa: E402
                                               wrong_muted_layers)
from support import bake_probe as probe  # noqa: E402
from test_muted_layers import _gradient_groups  # noqa: E402
from surfgrad_addon.reference.blender_lines import facts_for  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from test_faults_materials39 import (QUIET, SIZE, _cycles_plane,  # noqa: E402,F401
                                     _emission_outputs, frozen_pixels, plain, sphere)
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402
from surfgrad_addon.addon.group_updates import update_stale_groups  # noqa: E402

pytestmark = pytest.mark.tier("blender")


@pytest.mark.tier("bake")
def test_a_muted_material_output_renders_as_the_line_fact():
    obj = _cycles_plane()
    target = bpy.data.images.new("Emit", 4, 4, float_buffer=True)
    mat, ((_, out),) = _emission_outputs(obj, target, [("R", "ALL")], 0)
    gone = bpy.data.images.new("Gone", 4, 4)
    gone.source, gone.filepath = "FILE", "/nonexistent/gone.png"
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = gone
    emission = out.inputs["Surface"].links[0].from_node
    mat.node_tree.links.new(tex.outputs["Alpha"], emission.inputs["Strength"])
    renders = facts_for(bpy.app.version).muted_output_renders
    for muted in (False, True):
        out.mute = muted
        bpy.ops.object.bake(type="EMIT")
        texel = np.array(target.pixels[:]).reshape(-1, 4)[0, :3]
        red = (1.0, 0.0, 0.0) if renders or not muted else (0.0, 0.0, 0.0)
        assert np.allclose(texel, red, atol=0.01), (muted, texel)   # (its magenta: not read)
        read = renders or not muted
        warned = []                 # (an Emission's Strength is warned of: round 54)
        assert any("'Gone'" in p for p in image_problems(obj, warnings=warned) + warned) == \
            read, muted
        warned = muted_output_warnings(obj)
        assert (warned == []) == read, warned
    assert "Material Output 'Material Output' is muted" in warned[0] if warned else renders


@pytest.mark.tier("bake")
def test_a_muted_group_passes_a_linked_input_before_an_unlinked_one():
    """Each SG group with two vector inputs or more, and SG Resolve, muted with only its last
    vector input linked: a bake reads what each passes on (its tag: a base-8 digit)."""
    probe.new_scene()
    pr = probe.EmissionProbe(probe.add_uv_plane())
    trees = {**_gradient_groups(), "SG Resolve": G.resolve_group()}
    cases, total = [], None
    for name, tree in sorted(trees.items()):
        node = pr.node("ShaderNodeGroup", node_tree=tree)
        vectors = [s for s in node.inputs if s.type == "VECTOR"]
        if len(vectors) < 2:
            pr.nodes.remove(node)
            continue
        channel, place = divmod(len(cases), 6)
        tag = [0.0, 0.0, 0.0]
        tag[channel] = float(8 ** place)
        pr.link(pr.combine(*tag), vectors[-1])
        node.mute = True
        out = next(s for s in node.outputs if s.type == "VECTOR")
        total = out if total is None else pr.vmath(VMath.ADD, total, out)
        cases.append((name, node, out, vectors[-1]))
    assert {"SG Volume Gradient", "SG Resolve"} <= {name for name, *_ in cases}
    px = pr.bake(total, 2, 2)[0, 0, :3].astype(np.int64)
    for k, (name, node, out, last) in enumerate(cases):
        channel, place = divmod(k, 6)
        assert int(px[channel]) // 8 ** place % 8 == 1, (name, px)     # the linked one
        assert passed_input(node, out).identifier == last.identifier, name
        assert blender_rule_input(node).identifier == last.identifier, name
    warned = sorted(group for _, group, _ in wrong_muted_layers(pr.tree))
    assert warned == sorted(name for name, *_, last in cases if last.name != "A"), warned
    assert "SG Volume Gradient" in warned and "SG Resolve" in warned


def _freeze_refused(obj, mat, match):
    before = material_dump(mat)
    try:
        with pytest.raises(F.FreezeError, match=match):
            F.freeze(obj, SIZE, **QUIET)
    finally:
        if F.RECORD in mat:
            F.thaw(mat)
    assert material_dump(mat) == before


@pytest.mark.tier("bake")
def test_freeze_follows_what_cycles_renders_through_muted_nodes(sphere, plain):
    obj, mat, bsdf = sphere
    tree = mat.node_tree
    out = bsdf.outputs[0].links[0].to_node
    bsdf.mute = True
    try:
        _freeze_refused(obj, mat, r"node 'Diffuse BSDF' is muted, so Cycles renders")
    finally:
        bsdf.mute = False
    mix = tree.nodes.new("ShaderNodeMixShader")       # muted: passes its first shader on
    other = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(other.outputs[0], mix.inputs[1])
    tree.links.new(bsdf.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    mix.mute = True
    try:
        _freeze_refused(obj, mat, rf"node {mix.name!r} is muted")
    finally:
        tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
        tree.nodes.remove(mix)
        tree.nodes.remove(other)
    out.mute = True
    try:
        if facts_for(bpy.app.version).muted_output_renders:
            np.testing.assert_allclose(frozen_pixels(obj, mat), plain, atol=1e-6)
        else:
            _freeze_refused(obj, mat, r"nothing to freeze: its Material Output 'Material "
                                      r"Output' is muted")
    finally:
        out.mute = False

PER_IMAGE = ("SG Height Map HQ", "SG Parallax", "SG Triplanar Height")


def _held(tree):
    return sorted({n.image.name for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"})


def _material_of(path, name):
    with bpy.data.libraries.load(str(path), link=False) as (_, into):
        into.materials = [name]
    return into.materials[0]


def _group_of(mat):
    return next(n.node_tree for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeGroup")


def _appended_beside_an_image_of_its_name(folder, key, older=False):
    """(the appended material's group, the file's own image "Bumps"): the group was built
    for the other file's "Bumps" (by the surfgrad before this one: `older`)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    theirs = bpy.data.images.new("Bumps", 8, 8)
    theirs.pack()
    mat = new_material("Theirs")
    mat.use_fake_user = True                    # (saved without a user)
    group = api.node_group(key, image=theirs)
    mat.node_tree.nodes.new("ShaderNodeGroup").node_tree = group
    if older:
        group[VERSION_KEY] -= 1
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "theirs.blend"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mine = bpy.data.images.new("Bumps", 4, 4)
    return _group_of(_material_of(folder / "theirs.blend", "Theirs")), mine


@pytest.mark.parametrize("key", PER_IMAGE)
def test_an_appended_group_keeps_reading_its_own_image(tmp_path, key):
    group, mine = _appended_beside_an_image_of_its_name(tmp_path, key)
    appended = bpy.data.materials["Theirs"]
    assert (group.name, _held(group)) == (f"{key} [Bumps]", ["Bumps.001"])
    made = api.node_group(key, image=mine)
    assert (made.name, _held(made)) == (f"{key} [Bumps]", ["Bumps"])
    assert _group_of(appended) == group and _held(group) == ["Bumps.001"], _held(group)
    assert group.name == f"{key} [Bumps.001]"
    # Asked for again, each is current: nothing is renamed or rebuilt.
    assert api.node_group(key, image=bpy.data.images["Bumps.001"]) == group
    assert api.node_group(key, image=mine) == made and _held(made) == ["Bumps"]


def test_update_reaches_an_older_group_named_for_another_image(tmp_path):
    key = "SG Parallax"
    group, mine = _appended_beside_an_image_of_its_name(tmp_path, key, older=True)
    assert (group.name, _held(group)) == (f"{key} [Bumps]", ["Bumps.001"])
    updated, left = update_stale_groups()
    assert (updated, left) == ([f"{key} [Bumps] (now {key} [Bumps.001])"], [])
    assert _group_of(bpy.data.materials["Theirs"]) == group and _held(group) == ["Bumps.001"]
    assert group[VERSION_KEY] == api.node_group(key, image=mine)[VERSION_KEY]


def _height_exr(path, low, high):
    """An 8 x 8 float EXR of heights from `low` to `high` along x, loaded."""
    img = bpy.data.images.new(path.stem, 8, 8, float_buffer=True)
    img.colorspace_settings.is_data = True          # saved as the values are
    ramp = np.linspace(low, high, 8, dtype=np.float32)
    px = np.ones((8, 8, 4), np.float32)
    px[..., :3] = ramp[None, :, None]
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw, img.file_format = str(path), "OPEN_EXR"
    img.save()
    bpy.data.images.remove(img)
    image = bpy.data.images.load(str(path))
    image.colorspace_settings.is_data = True
    return image


@pytest.mark.tier("bake")
def test_parallax_heights_beyond_0_to_1_are_warned(tmp_path, capsys):
    obj = _cycles_plane()
    mat, tree, bsdf = diffuse_material("Steps")
    obj.data.materials.append(mat)
    node = tree.nodes.new("ShaderNodeGroup")
    for low, high, words in ((0.0, 1.0, None), (0.0, 3.0, "has 40 above 1 (up to 3) of its 64"),
                             (-0.5, 0.5, "has 32 below 0 of its 64")):
        image = _height_exr(tmp_path / f"h{low}_{high}.exr", low, high)
        node.node_tree = api.node_group("SG Parallax", image=image)
        tree.links.new(node.outputs[0], bsdf.inputs["Normal"])
        warned = parallax_height_warnings(obj)
        assert warned == [] if words is None else words in warned[0], warned
    assert "read as heights by SG Parallax node 'Group'" in warned[0], warned
    if G.unavailable_reason("SG Parallax (Sampler)") is None:      # 5.0+: in a Sampler zone
        tex = tree.nodes.new("ShaderNodeTexImage")
        tex.image = image
        tree.nodes.active = tex
        sampler = add_group_node(tree, "SG Parallax (Sampler)")
        tree.links.new(sampler.outputs[0], bsdf.inputs["Normal"])
        (warned,) = parallax_height_warnings(obj)
        assert f"by SG Parallax node {sampler.name!r}" in warned and "has 32 below 0" in warned
    blend = tmp_path / "steps.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(tmp_path / "map.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == exit_codes.OK and "SG Parallax marches heights 0..1" in err, err


@pytest.mark.tier("blender")
def test_a_normal_map_in_the_triplanar_sampler_zone_is_judged():
    if G.unavailable_reason("SG Triplanar (Sampler)") is not None:
        pytest.skip("SG Triplanar (Sampler) needs closures (Blender 5.0+)")
    obj = _cycles_plane()
    mat, tree, bsdf = diffuse_material("Rocks")
    obj.data.materials.append(mat)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.new("Bumps", 4, 4)       # read as sRGB: a warned slip
    tree.nodes.active = tex
    node = add_group_node(tree, "SG Triplanar (Sampler)")
    resolve = tree.nodes.new("ShaderNodeGroup")
    resolve.node_tree = G.resolve_group()
    tree.links.new(node.outputs[0], resolve.inputs["Surface Gradient"])
    tree.links.new(resolve.outputs[0], bsdf.inputs["Normal"])
    (warning,) = colour_space_warnings(obj)
    assert f"'Bumps' is read in colour space 'sRGB' by SG Triplanar (Sampler) node " \
           f"{node.name!r}" in warning, warning
    tex.image.colorspace_settings.is_data = True
    assert colour_space_warnings(obj) == []
