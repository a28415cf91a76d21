"""Red team 47b: leftovers earlier rounds noticed and did not probe.

1. A normal map's image reaching the Normal Map node (or an SG normal-map group) through
   Vector Math (USD's and some glTF imports' scale and bias: Image > Multiply Add > Normal
   Map), or through a DirectX map's green flip (Separate Color, Math, Combine Color):
   read as sRGB it bends every normal as it does wired straight in, but the colour-space
   warning's walk back to the image (image_checks.texture_feeding) stopped at the first such
   node, so bake-normal-map, bake-batch, the API and Freeze baked the bent map with exit 0 and
   no word, on every line (5.2 and 4.2 probed). Now the colour-space warning follows those
   nodes (normal_map_checks.COLOUR_MATH; not an Invert's Factor, where a mask is colour; a
   live Mix stays unwarned, as round 41 decided); the file checks (channels, -1..1 range) do
   not, as math may remap a map's range on purpose. `compare` reads no user material (its own graph, its
   --image as data): nothing to warn there.
2. Freeze checks the images its stack reads, then (a modal run: the artist may save over a
   texture meanwhile) bakes; Cycles loads the files anew. A file removed between the check and
   the bake baked Cycles' magenta into every texel (a 32^2 freeze: 1024 of 1024 texels off,
   up to 0.77 in a channel), one rewritten baked pixels no check saw; both were wired in and
   reported as frozen. bake-normal-map stamps the files and compares after its bake
   (input_stamps.py); now Freeze does too and refuses, the material and the folder as they
   were.
3. A full disk (probed on a 64 kB tmpfs in a user namespace): bake-normal-map, bake-batch,
   Freeze and compare (its JSON and heat map) fail, exit 1, nothing under the final names, the
   folder named. But a disk with room for the map and none for the manifest's record of it
   (the `pending` record of round 44, written before the map is put in place; a failed
   manifest write was passed over there) let the map in unrecorded: bake-batch printed
   "baked", then failed its last manifest write, exit 1, and its rerun once space was freed
   failed the asset, "Rock.png exists", exit 1 (in this process and in a worker alike). Now
   the record's write failing fails the bake as a full disk does (manifest.write_pending; a
   worker gets the reason in the batch's answer to its pending line), nothing put in place.
"""

import errno
import os

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon import normal_bake as NB  # noqa: E402
from surfgrad_addon.addon.batch import bake_batch, manifest  # noqa: E402
from surfgrad_addon.addon.normal_map_checks import colour_space_warnings  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from support.materials import diffuse_material  # noqa: E402
from test_faults_materials39 import _cycles_plane  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def test_an_srgb_normal_map_read_through_math_is_warned_about():
    obj = _cycles_plane()
    mat, _, bsdf = diffuse_material("Imported")
    obj.data.materials.append(mat)
    tree = mat.node_tree
    nodes, link = tree.nodes.new, tree.links.new
    tex = nodes("ShaderNodeTexImage")
    tex.image = bpy.data.images.new("Bumps", 4, 4)            # sRGB: a warned slip
    scale_bias = nodes("ShaderNodeVectorMath")                 # USD's scale and bias
    scale_bias.operation = "MULTIPLY_ADD"
    scale_bias.inputs[1].default_value = (1.0, 1.0, 1.0)
    scale_bias.inputs[2].default_value = (0.0, 0.0, 0.0)
    nmap = nodes("ShaderNodeNormalMap")
    link(tex.outputs["Color"], scale_bias.inputs[0])
    link(scale_bias.outputs[0], nmap.inputs["Color"])
    link(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    said = "image 'Bumps' is read in colour space 'sRGB' by Normal Map node 'Normal Map'"
    (warning,) = colour_space_warnings(obj)
    assert said in warning, warning
    assert sum(said in w for w in F.freeze_warnings(obj, mat)) == 1
    # A DirectX map's green flip (Separate Color, 1 - G, Combine Color), then through an
    # Invert of Factor 0 whose Factor a mask sets: the map is warned about, the mask (colour,
    # not a normal) is not.
    split, flip, join = (nodes(k) for k in ("ShaderNodeSeparateColor", "ShaderNodeMath",
                                            "ShaderNodeCombineColor"))
    flip.operation = "SUBTRACT"
    flip.inputs[0].default_value = 1.0
    link(tex.outputs["Color"], split.inputs[0])
    for channel in (0, 2):
        link(split.outputs[channel], join.inputs[channel])
    link(split.outputs[1], flip.inputs[1])
    link(flip.outputs[0], join.inputs[1])
    invert = nodes("ShaderNodeInvert")
    mask = nodes("ShaderNodeTexImage")
    mask.image = bpy.data.images.new("Mask", 4, 4)
    link(join.outputs[0], invert.inputs["Color"])
    link(mask.outputs["Color"], invert.inputs["Fac"])
    link(invert.outputs["Color"], nmap.inputs["Color"])
    assert [said in w for w in colour_space_warnings(obj)] == [True]
    tex.image.colorspace_settings.is_data = True
    assert colour_space_warnings(obj) == []


def _stack_reading_a_file(folder):
    """A plane whose layered stack reads its normal map from an EXR file in `folder`, not
    loaded (Cycles loads it at the bake, as after reopening the file)."""
    obj = _cycles_plane()
    obj.data.uv_layers[0].name = "UVMap"
    mat, _ = layered_material(obj)
    tex = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage")
    packed = tex.image
    packed.filepath_raw = str(folder / "source.exr")
    packed.file_format = "OPEN_EXR"
    packed.save()
    tex.image = bpy.data.images.load(str(folder / "source.exr"))
    tex.image.colorspace_settings.is_data = True
    bpy.data.images.remove(packed)
    return obj, mat


def test_freeze_refuses_an_input_file_removed_between_its_check_and_its_bake(tmp_path):
    obj, mat = _stack_reading_a_file(tmp_path)
    source = tmp_path / "source.exr"
    before = material_dump(mat)
    steps = F.freeze_steps(obj, 16, filepath=str(tmp_path / "frozen.png"))
    assert next(steps) == "checked"
    os.remove(source)              # (one saved over is told by its size, time and inode)
    with pytest.raises(F.FreezeError) as err:
        next(steps)
    assert f"image file {str(source)!r} changed while it was baked" in str(err.value)
    assert "freeze again" in str(err.value)
    assert material_dump(mat) == before
    assert F.RECORD not in mat
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("workers", [0, pytest.param(1, marks=pytest.mark.tier("child"))])
def test_a_batch_whose_manifest_cannot_record_a_map_puts_none_in_place(workers, tmp_path,
                                                                       monkeypatch):
    """A disk with room for the map, none for the manifest's record of it (measured on a
    64 kB tmpfs: the map 1151 bytes, the manifest 2.4 kB). Before: the map was put in place
    unrecorded, exit 1, and the rerun once space was freed failed the asset, 'Rock.png
    exists', exit 1, in this process (workers 0) and in a worker alike."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    maps = tmp_path / "maps"
    write_json = manifest._write_json

    def full_for_records(path, data):
        if any("pending" in a for a in data["assets"].values()):
            raise OSError(errno.ENOSPC, "No space left on device")
        write_json(path, data)
    monkeypatch.setattr(manifest, "_write_json", full_for_records)
    run = dict(defaults={"resolution": 16, "margin": 0}, log=lambda *_: None)
    report = bake_batch([str(blend)], str(maps / "{object}.png"), workers=workers, **run)
    (rock,) = report["assets"].values()
    assert rock["status"] == "failed", rock
    assert (f"could not record the map before it was put in place (No space left on device), "
            f"so none was: free space in {str(maps)!r} (the disk may be full)") in rock["error"]
    assert sorted(p.name for p in maps.iterdir()) == ["surfgrad-bake-manifest.json"]
    monkeypatch.undo()
    report = bake_batch([str(blend)], str(maps / "{object}.png"), workers=0, **run)
    assert report["counts"] == {"baked": 1, "skipped": 0, "failed": 0}, report["assets"]
    assert (maps / "Rock.png").read_bytes().endswith(NB.PNG_END)
