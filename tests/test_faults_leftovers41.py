"""Red team 41a: leftovers round 40 noticed and left.

1. Muted nodes (node mute, not link mute) between a Material Output and an image: Cycles
   passes on only the inputs a muted node's internal links name (pinned here by EMIT bakes: a
   muted Image Texture bakes the socket's own value; a muted Normal Map node never reads its
   Color (5.2 bakes the socket's own value, 4.2 black); a muted group passes its input on and
   never reads its inside). The image checks walked every input of a muted node and into a
   muted group, so they refused an image Cycles never reads (a missing file behind a muted
   Image Texture: bake refused, exit 1), and the normal-map warnings warned about a muted
   Normal Map node's sRGB image. Now both walks follow what Cycles reads (a muted node's
   internal links: image_checks._reached, texture_feeding).
2. --depth half when Blender's save of the half EXR copy itself fails (a folder in the way of
   the temporary '.<name>.part<pid>.half.exr', a full disk there): BakeFailed, exit 1, naming
   only that temporary file, with no fix. Now the MapNotWritten refusal a failed save of the
   map gets (the output named, the fix), exit 1 all the same, nothing written.
3. `python -m surfgrad_addon` in an ASCII locale starts itself again in UTF-8 mode (round 39);
   a user's script running it through runpy.run_module(..., run_name="__main__") was started
   again too, so the script ran twice. Now only a process started as `python [options] -m
   surfgrad_addon` restarts (sys.orig_argv); another goes on and says how to run in UTF-8.
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes, interrupts  # noqa: E402
from surfgrad_addon.addon.image_checks import image_problems as checked_images  # noqa: E402
from surfgrad_addon.addon.normal_map_checks import colour_space_warnings  # noqa: E402
from support.child import run_python  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_materials39 import _cycles_plane, _emission_outputs  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _red_group(image):
    """A node group passing its Color input by, whose output is an Image Texture of `image`."""
    group = bpy.data.node_groups.new("Inside", "ShaderNodeTree")
    group.interface.new_socket("C", in_out="INPUT", socket_type="NodeSocketColor")
    group.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketColor")
    group.nodes.new("NodeGroupInput")
    tex = group.nodes.new("ShaderNodeTexImage")
    tex.image = image
    group.links.new(tex.outputs[0], group.nodes.new("NodeGroupOutput").inputs[0])
    return group


def test_what_cycles_reads_through_a_muted_node_is_what_the_checks_read():
    obj = _cycles_plane()
    target = bpy.data.images.new("Emit", 4, 4, float_buffer=True)
    mat, _ = _emission_outputs(obj, target, [("G", "ALL")], 0)      # its own value: green
    tree = mat.node_tree
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    red = bpy.data.images.new("Red", 4, 4)
    red.generated_color = (1.0, 0.0, 0.0, 1.0)
    blue = tree.nodes.new("ShaderNodeRGB")
    blue.outputs[0].default_value = (0.0, 0.0, 1.0, 1.0)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = red
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    group = tree.nodes.new("ShaderNodeGroup")
    group.node_tree = _red_group(red)
    tree.links.new(blue.outputs[0], group.inputs[0])

    def baked(node, output):
        """{(muted, the image's colour): the texel baked}."""
        tree.links.new(node.outputs[output], emission.inputs["Color"])
        texels = {}
        for muted in (False, True):
            node.mute = muted
            for colour in ((1.0, 0.0, 0.0, 1.0), (1.0, 1.0, 0.0, 1.0)):
                red.generated_color = colour
                bpy.ops.object.bake(type="EMIT")
                texels[muted, colour[1]] = np.array(target.pixels[:]).reshape(-1, 4)[0, :3]
        node.mute = False
        return texels

    for node, output in ((tex, "Color"), (nmap, "Normal"), (group, 0)):
        texels = baked(node, output)            # live: the image read; muted: never read
        assert not np.allclose(texels[False, 0], texels[False, 1], atol=0.05), node.name
        assert np.allclose(texels[True, 0], texels[True, 1], atol=0.01), (node.name, texels)
        if node == group:                       # passes its input on
            assert np.allclose(texels[True, 0], (0, 0, 1), atol=0.01), texels
        if node == tex:                         # no internal link: the socket's own value
            assert np.allclose(texels[True, 0], (0, 1, 0), atol=0.01), texels

    # The checks: an image whose file is missing behind each muted node is not refused (nor,
    # an Emission's Color, which no baked normal reads, warned of: round 54).
    def image_problems(obj):
        warned = []
        return checked_images(obj, warnings=warned) + warned

    gone = bpy.data.images.new("Gone", 4, 4)
    gone.source, gone.filepath = "FILE", "/nonexistent/gone.png"
    tex.image = gone
    group.node_tree.nodes["Image Texture"].image = gone
    for node, output in ((tex, "Color"), (nmap, "Normal"), (group, 0)):
        tree.links.new(node.outputs[output], emission.inputs["Color"])
        assert any("'Gone'" in p for p in image_problems(obj)), node.name
        node.mute = True
        assert not any("'Gone'" in p for p in image_problems(obj)), node.name
        node.mute = False


def test_a_muted_normal_map_node_or_image_texture_is_not_warned_about():
    obj = _cycles_plane()
    mat, tree, bsdf = diffuse_material("Normals")
    obj.data.materials.append(mat)
    srgb = tree.nodes.new("ShaderNodeTexImage")
    srgb.image = bpy.data.images.new("Bumps", 4, 4)       # read as sRGB: a warned slip
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    a = next(s for s in mix.inputs if s.name == "A" and s.type == "RGBA")
    result = next(s for s in mix.outputs if s.type == "RGBA")
    tree.links.new(srgb.outputs["Color"], a)
    tree.links.new(result, nmap.inputs["Color"])
    tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    assert colour_space_warnings(obj) == []               # a live Mix: not a plain read
    mix.mute = True                                       # passes A on: the image, as read
    (warning,) = colour_space_warnings(obj)
    assert "image 'Bumps' is read in colour space 'sRGB'" in warning, warning
    for node in (nmap, srgb):
        node.mute = True
        assert colour_space_warnings(obj) == [], node.name
        node.mute = False


def test_a_failed_save_of_the_half_exr_copy_is_refused_as_a_map_not_written(tmp_path, capsys):
    obj = _cycles_plane()
    obj.data.materials.append(diffuse_material("M")[0])
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    maps = tmp_path / "maps"
    in_the_way = interrupts.partial_path(maps / "map.exr", ".half.exr")   # this process's
    in_the_way.mkdir(parents=True)
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(maps / "map.exr"), "--resolution", "16",
                           "--depth", "half"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAKE_FAILED, err
    assert f"could not write the map for {str(maps / 'map.exr')!r}" in err, err
    assert "check that the folder still takes files" in err and "Traceback" not in err, err
    assert sorted(p.name for p in maps.iterdir()) == [in_the_way.name]


ASCII_LOCALE = {"LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}
UTF8_ADVICE = "run it in UTF-8 mode (PYTHONUTF8=1 or python -X utf8)"


@pytest.mark.tier("child")
def test_only_python_dash_m_itself_restarts_in_utf8_mode(tmp_path):
    script = tmp_path / "user_script.py"
    script.write_text("import runpy, sys\n"
                      "print('user script ran', flush=True)\n"
                      "sys.argv = ['surfgrad_addon', '--help']\n"
                      "try:\n"
                      "    runpy.run_module('surfgrad_addon', run_name='__main__')\n"
                      "except SystemExit as stop:\n"
                      "    print('exit', stop.code, sys.flags.utf8_mode)\n")
    child = run_python([script], env=ASCII_LOCALE, timeout=120)
    assert child.stdout.count("user script ran") == 1, child.stdout
    assert "usage: python -m surfgrad_addon" in child.stdout and "exit 0 0" in child.stdout
    assert UTF8_ADVICE in child.stderr, child.stderr
    # Options before -m, one of them joined to it: still this module's own process.
    child = run_python(["-X", "faulthandler", "-Bm", "surfgrad_addon", "--help"],
                       env=ASCII_LOCALE, timeout=120)
    assert child.returncode == 0 and "usage: python -m surfgrad_addon" in child.stdout
    assert child.stderr == "", child.stderr           # started again in UTF-8: no advice
