"""Freeze and thaw refuse what they cannot do with a message naming the fix, and leave the
material exactly as it was (a full dump of its nodes, links and properties compares equal), the
file's images as they were and the disk as it was: no active object or material, no
surface-gradient stack, no UV map, an unwritable folder, an existing file without overwrite
(also one that appears during the bake), a cancel after the bake, a frozen material frozen
again, thawing what is not frozen or lost a stack node."""

import os

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.harness import scenes as test_scenes  # noqa: E402
from support.freeze_scene import layered_material  # noqa: E402
from support.material_dump import material_dump  # noqa: E402
from support.materials import diffuse_material  # noqa: E402

pytestmark = pytest.mark.tier("bake")

QUIET = dict(log=lambda *_: None)


@pytest.fixture()
def layered():
    obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    mat, _ = layered_material(obj)
    return obj, mat


def refused(obj, mat, match, folder=None, **kwargs):
    """Freeze is refused with `match` in the message; nothing changed."""
    before = material_dump(mat) if mat is not None else None
    files = sorted(os.listdir(folder)) if folder else None
    with pytest.raises(F.FreezeError, match=match):
        F.freeze(obj, 32, **kwargs, **QUIET)
    if mat is not None:
        assert material_dump(mat) == before
    if folder:
        assert sorted(os.listdir(folder)) == files


def test_no_object_or_material():
    refused(None, None, "no active object: select the mesh")
    obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    images = set(bpy.data.images.keys())
    refused(obj, None, "has no active material with nodes: add a material")
    assert set(bpy.data.images.keys()) == images


def test_no_surface_gradient_stack():
    obj = test_scenes.new_scene(["Sphere"])["Sphere"]
    mat, tree, bsdf = diffuse_material("Builtin")
    obj.data.materials.append(mat)
    refused(obj, mat, r"no surface-gradient stack feeds a BSDF Normal input: add one")
    nmap = tree.nodes.new("ShaderNodeNormalMap")       # a built-in normal map: no SG group
    tree.links.new(nmap.outputs[0], bsdf.inputs["Normal"])
    refused(obj, mat, "no surface-gradient stack feeds")
    tree.links.remove(bsdf.outputs[0].links[0])
    refused(obj, mat, "no shader linked to its Material Output's Surface: link a BSDF")


def test_no_uv_map(layered):
    obj, mat = layered
    while obj.data.uv_layers:
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    refused(obj, mat, "has no UV map; unwrap it first")
    refused(obj, mat, "has no UV map", uv_map="Missing")


def test_unwritable_folder(layered, tmp_path):
    obj, mat = layered
    if os.geteuid() == 0:          # permission bits do not bind root; sysfs takes no new files
        folder = "/sys/kernel"
    else:
        folder = tmp_path / "locked"
        folder.mkdir()
        folder.chmod(0o555)
    refused(obj, mat, "is not writable .*: choose a folder you can write to, or pack",
            folder=folder, filepath=os.path.join(folder, "n.png"))
    refused(obj, mat, "does not exist: create it first",
            filepath=str(tmp_path / "nowhere" / "n.png"))
    refused(obj, mat, "use a .png or .exr file name", filepath=str(tmp_path / "n.jpg"))


def test_existing_file_is_kept_without_overwrite(layered, tmp_path):
    obj, mat = layered
    path = tmp_path / "n.png"
    path.write_bytes(b"the user's file")
    refused(obj, mat, "exists: tick Overwrite to replace it", folder=tmp_path,
            filepath=str(path))
    assert path.read_bytes() == b"the user's file"
    F.freeze(obj, 32, filepath=str(path), overwrite=True, **QUIET)
    assert path.read_bytes()[:4] == b"\x89PNG"


def test_a_file_that_appears_during_the_bake_is_kept(layered, tmp_path):
    obj, mat = layered
    path = tmp_path / "n.png"

    def intruder(stage):                  # another program writes the file meanwhile
        if stage == "baked":
            path.write_bytes(b"written meanwhile")
        return False
    before, images = material_dump(mat), set(bpy.data.images.keys())
    with pytest.raises(F.FreezeError, match="appeared during the bake: tick Overwrite"):
        F.freeze(obj, 32, filepath=str(path), cancel=intruder, **QUIET)
    assert material_dump(mat) == before and set(bpy.data.images.keys()) == images
    assert path.read_bytes() == b"written meanwhile"
    assert os.listdir(tmp_path) == ["n.png"]


@pytest.mark.parametrize("where", ["file", "pack"])
def test_cancel_after_the_bake_puts_everything_back(layered, tmp_path, where):
    obj, mat = layered
    filepath = str(tmp_path / "n.png") if where == "file" else ""
    seen = []

    def cancel(stage):
        seen.append(stage)
        return stage == "baked"
    before, images = material_dump(mat), set(bpy.data.images.keys())
    with pytest.raises(F.FreezeCancelled, match="cancelled"):
        F.freeze(obj, 32, filepath=filepath, cancel=cancel, **QUIET)
    assert seen == ["checked", "baked"]
    assert material_dump(mat) == before and set(bpy.data.images.keys()) == images
    assert os.listdir(tmp_path) == []
    # And a cancel once wired (the last stage) undoes the wiring too.
    with pytest.raises(F.FreezeCancelled):
        F.freeze(obj, 32, filepath=filepath, cancel=lambda stage: stage == "wired", **QUIET)
    assert material_dump(mat) == before and set(bpy.data.images.keys()) == images
    assert os.listdir(tmp_path) == []                     # the file is written after it


def test_frozen_twice_and_thaw_refusals(layered):
    obj, mat = layered
    with pytest.raises(F.FreezeError, match="is not frozen: nothing to thaw"):
        F.thaw(mat)
    with pytest.raises(F.FreezeError, match="no active material"):
        F.thaw(None)
    F.freeze(obj, 32, **QUIET)
    refused(obj, mat, "is frozen already: thaw it first")
    record = F.frozen_record(mat)
    resolve = mat.node_tree.nodes[record["links"][0][0]]
    resolve.name = "Renamed"                              # the stack's end is gone by name
    frozen = material_dump(mat)
    with pytest.raises(F.FreezeError, match="is gone or changed.*undo to before"):
        F.thaw(mat)
    assert material_dump(mat) == frozen
    resolve.name = record["links"][0][0]
    F.thaw(mat)
    assert F.RECORD not in mat
