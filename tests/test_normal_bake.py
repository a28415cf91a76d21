"""The TD bake script: an object's SG material baked to a normal map file reproduces what the
material shows, and refuses bad input clearly."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G, normal_bake
from surfgrad_addon.harness import compare, scenes as test_scenes  # noqa: E402
from surfgrad_addon.harness.graph import Graph  # noqa: E402
from surfgrad_addon.reference import images as T  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("bake")


ROOT = Path(__file__).resolve().parents[1]


def _sg_material(obj, image):
    mat, tree, bsdf = diffuse_material("SG")
    g = Graph(tree.nodes, tree.links)
    nm = g.group(G.normal_map_group("UVMap"), Color=g.image(image, g.uv("UVMap")))
    g.link(g.resolve(nm.outputs[0]), bsdf.inputs["Normal"])
    obj.data.materials.append(mat)
    return mat


def test_tangent_bake_of_an_sg_material_reproduces_its_normal_map(tmp_path):
    """On a plane the tangent frame is constant, so the baked tangent-space map must equal
    the normal map fed to SG Normal Map (up to 8-bit and texel filtering)."""
    obj = test_scenes.new_scene(["Plane"])["Plane"]
    source = T.hemisphere_tile_image(64, tiles=2)
    _sg_material(obj, compare.bpy_float_image("src", source))
    settings_before = (bpy.context.scene.render.engine, bpy.context.scene.cycles.samples)
    out = normal_bake.bake_normal_map(obj, tmp_path / "n.exr", "tangent", 64, margin=0,
                                      log=lambda *_: None)
    assert (bpy.context.scene.render.engine, bpy.context.scene.cycles.samples) == settings_before
    img = bpy.data.images.load(str(out))
    px = np.empty(64 * 64 * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    baked = px.reshape(64, 64, 4)[..., :3] * 2 - 1
    want = source * 2 - 1
    err = compare.angle_deg(baked.reshape(-1, 3), want.reshape(-1, 3))
    assert np.median(err) < 0.5 and np.percentile(err, 95) < 3.0, (np.median(err),
                                                                     np.percentile(err, 95))
    assert compare.angle_deg(want.reshape(-1, 3), want.reshape(-1, 3) * 0 + [0, 0, 1]).max() > 30
    assert len(bpy.data.materials["SG"].node_tree.nodes) == 6       # temporary node removed


def test_bad_input_is_refused(tmp_path):
    obj = test_scenes.new_scene(["Plane"])["Plane"]
    with pytest.raises(normal_bake.NormalBakeError, match="no material"):
        normal_bake.bake_normal_map(obj, tmp_path / "a.png", log=lambda *_: None)
    with pytest.raises(normal_bake.NormalBakeError, match=".png or .exr"):
        normal_bake.bake_normal_map(obj, tmp_path / "a.jpg", log=lambda *_: None)
    (tmp_path / "b.png").write_bytes(b"x")
    with pytest.raises(normal_bake.NormalBakeError, match="--overwrite"):
        normal_bake.bake_normal_map(obj, tmp_path / "b.png", log=lambda *_: None)
    with pytest.raises(normal_bake.NormalBakeError, match="no UV map 'Nope'"):
        _sg_material(obj, None)
        normal_bake.bake_normal_map(obj, tmp_path / "c.png", uv_map="Nope", log=lambda *_: None)


@pytest.mark.tier("child")
def test_command_line_writes_a_png_with_progress(tmp_path):
    blend = tmp_path / "s.blend"
    obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    _sg_material(obj, compare.bpy_float_image("src", T.hemisphere_tile_image(32)))
    # bpy_float_image packs the image already; packing again unpacks it on 5.0 (the saved file
    # then holds no pixels, which the bake request refuses), so pack only what is not packed.
    if bpy.data.images["src"].packed_file is None:
        bpy.data.images["src"].pack()
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    out = subprocess.run([sys.executable, "-m", "surfgrad_addon", "bake-normal-map", "--blend",
                          str(blend), "--object", "Sphere", "--output", str(tmp_path / "s.png"),
                          "--space", "object", "--resolution", "32"], env=env,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "[1/3]" in out.stdout and "[3/3] wrote" in out.stdout
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("resolution,output,message", [
    (0, "n.png", "resolution 0: use a whole number of texels from 4 to 16384"),
    (-5, "n.png", "resolution -5"),
    (100000, "n.png", "resolution 100000"),
    (1.5, "n.png", "resolution 1.5"),
    (64, "", "is a folder: give a file name in it"),
    (64, "maps.png/", "is a folder"),
    (64, "nope/n.png", "does not exist: create it first"),
])
def test_bad_resolution_and_output_are_refused_before_baking(tmp_path, resolution, output,
                                                              message):
    obj = test_scenes.new_scene(["Plane"])["Plane"]
    mat = new_material("SG")
    obj.data.materials.append(mat)
    target = tmp_path / output if output else tmp_path
    if output.endswith("/"):
        target.mkdir()
    before = sorted(p.name for p in tmp_path.rglob("*"))
    with pytest.raises(normal_bake.NormalBakeError, match=message):
        normal_bake.bake_normal_map(obj, target, resolution=resolution, log=lambda *_: None)
    assert sorted(p.name for p in tmp_path.rglob("*")) == before     # nothing written
