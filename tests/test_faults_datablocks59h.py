"""Red team 59h: Blender's own data tools around SG materials, then surfgrad's bake on the
result. Measured on 5.2 before the fix (main at b7cd287):

1. A preview left in an SG material: Connect to Output (Ctrl+Shift+click in the Shader
   Editor; Node Wrangler's preview before 4.2) links the clicked node's output straight to
   the Material Output's Surface (a colour or a vector where the BSDF was) and leaves the
   BSDF unlinked. A 2 m plane whose Add Layer Stack (SG Normal Map -> SG Combine -> SG
   Resolve -> Diffuse BSDF) reads an image leaning up to 36.9 degrees, with the Image
   Texture's Color (or SG Resolve's Normal) previewed: bake-normal-map wrote the surface's own
   normal, median 20.6 degrees (max 35.9) off the map baked with the BSDF linked, exit 0
   (Cycles renders the value as an emission: no closure). Now refused (exit 2, ValueError
   from the API), naming the material, the node and socket, the BSDF left aside and the fix
   (Ctrl+Shift+click the BSDF); no file written, the material as it was. A material that is
   only a colour into the Surface (no shader node anywhere) bakes as before: the surface's
   normal. A file from Blender 2.8-4.1 whose Node Wrangler preview is left in: an Emission
   node "Emission Viewer" fed the image, into the Surface, the BSDF aside: the same flat map
   (median 20.6, max 35.9 degrees off; 0.002 degrees from the surface's normal), exit 0
   (a shader, so the value check passed it). Now refused alike, naming Node Wrangler's node.
2. The same preview of SG Resolve's Normal: Add Layer Stack wired a second stack (3 nodes)
   into SG Resolve's Normal input (the previewed node has one), FINISHED, no word; Freeze
   refused with "no surface-gradient stack feeds a BSDF Normal input: add one (Add > ...
   Layer Stack)", a stack being there (its fix adds a second one). Now both name the preview
   and its fix; the material as it was.

Probed and fine (5.2): File > Clean Up > Purge Unused Data (recursive) after Add Layer Stack
and Add of SG Height Map HQ, Triplanar Height, Decal, Parallax: nothing purged (every group,
the hidden helpers ".SG Safe Normal", ".SG Surface Gradient", ".SG UV Gradients" too, in use).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from support.baked_normals import baked_normals  # noqa: E402
from support.child import run_python  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from support.materials import diffuse_material, packed_normal_image  # noqa: E402

pytestmark = pytest.mark.tier("bake")

N = 16
LEAN = np.degrees(np.arctan2(0.6, 0.8))         # the image's steepest texel: 36.87 degrees


def _stack_plane():
    """A 2 m plane whose Add Layer Stack reads an image leaning along u, from 0 at the middle
    to LEAN at either side: (object, tree, the Image Texture, the stack's nodes)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2)
    obj = bpy.context.active_object
    mat, tree, _ = diffuse_material("Rock_SG")
    obj.data.materials.append(mat)
    u = np.linspace(-1.0, 1.0, N)
    rgb = np.zeros((N, N, 3))
    rgb[..., 0] = 0.5 + 0.3 * u[None, :]                # x = 0.6 u, z = 0.8: unit
    rgb[..., 1] = 0.5
    rgb[..., 2] = 0.9
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = packed_normal_image("lean", rgb)
    nodes = api.add_layer_stack(mat, uv_map="UVMap")
    tree.links.new(tex.outputs["Color"], nodes["normal_map"].inputs["Color"])
    return obj, tree, tex, nodes


def _off_z(normals):
    return np.degrees(np.arccos(np.clip(normals[..., 2], -1.0, 1.0)))


def test_the_stack_bakes_its_lean_with_the_bsdf_linked(tmp_path):
    obj, *_ = _stack_plane()
    got = baked_normals(obj, tmp_path / "m.exr", "tangent", 32)
    assert LEAN - 3.0 < _off_z(got).max() < LEAN + 0.5


def _viewer(tree, tex):
    """Node Wrangler's preview before 4.2: an Emission node named "Emission Viewer" fed the
    clicked node's output."""
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.name = "Emission Viewer"
    tree.links.new(tex.outputs["Color"], emission.inputs["Color"])
    return emission.outputs[0]


@pytest.mark.parametrize("previewed", ["image", "resolve", "older viewer"])
def test_a_preview_left_in_the_material_is_refused(tmp_path, previewed):
    obj, tree, tex, nodes = _stack_plane()
    socket = {"image": lambda: tex.outputs["Color"], "resolve": lambda: nodes["resolve"].outputs[0],
              "older viewer": lambda: _viewer(tree, tex)}[previewed]()
    tree.links.new(socket, tree.nodes["Material Output"].inputs["Surface"])   # the preview
    before = material_dump(obj.active_material)
    out = tmp_path / "m.exr"
    with pytest.raises(ValueError) as err:      # before: a flat map, 20.6 degrees off, exit 0
        api.bake_normal_map(obj, str(out), resolution=32, margin=0, log=None)
    text = str(err.value)
    assert "'Rock_SG'" in text and repr(socket.node.name) in text
    assert "'Diffuse BSDF'" in text and "Ctrl+Shift+click" in text
    assert not out.exists() and list(tmp_path.iterdir()) == []
    assert material_dump(obj.active_material) == before


@pytest.mark.tier("child")
def test_the_preview_refusal_exits_2_from_the_command_line(tmp_path):
    obj, tree, tex, _ = _stack_plane()
    tree.links.new(tex.outputs["Color"], tree.nodes["Material Output"].inputs["Surface"])
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    out = tmp_path / "m.png"
    done = run_python(["-m", "surfgrad_addon", "bake-normal-map", "--blend", blend, "--object",
                       obj.name, "--output", out, "--resolution", "32"], cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert "Ctrl+Shift+click" in done.stderr and "Traceback" not in done.stderr
    assert not out.exists()


def test_a_colour_only_material_still_bakes_the_surface(tmp_path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=2)
    obj = bpy.context.active_object
    mat, tree, bsdf = diffuse_material("Unlit")
    tree.nodes.remove(bsdf)
    rgb = tree.nodes.new("ShaderNodeRGB")
    tree.links.new(rgb.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    obj.data.materials.append(mat)
    got = baked_normals(obj, tmp_path / "m.exr", "tangent", 32)
    assert _off_z(got).max() < 0.5


def test_add_layer_stack_and_freeze_name_the_preview():
    """The same preview of SG Resolve's Normal: Add Layer Stack wired a second stack into SG
    Resolve's Normal input (the previewed node has one), 3 nodes added, no word; Freeze said
    "no surface-gradient stack feeds a BSDF Normal input: add one", a stack being there."""
    from surfgrad_addon.addon import freeze
    obj, tree, _, nodes = _stack_plane()
    tree.links.new(nodes["resolve"].outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    before = material_dump(obj.active_material)
    with pytest.raises(freeze.FreezeError, match="preview.*'Diffuse BSDF' is left unlinked"):
        freeze.find_stack(tree)
    with pytest.raises(Exception, match="preview.*Ctrl\\+Shift\\+click") as err:
        api.add_layer_stack(obj.active_material, uv_map="UVMap")
    assert isinstance(err.value, ValueError)
    assert material_dump(obj.active_material) == before
