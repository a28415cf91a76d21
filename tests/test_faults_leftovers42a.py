"""Red team 42a: leftovers earlier rounds noticed and left.

1. A per-image group (SG Height Map HQ, SG Parallax, SG Triplanar Height) under the name of an
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

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402
from surfgrad_addon.addon.group_updates import update_stale_groups  # noqa: E402

pytestmark = pytest.mark.tier("blender")

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
