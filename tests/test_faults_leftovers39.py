"""Leftovers earlier rounds noticed and left (red team 39b).

- Update surfgrad Groups did not reach the per-image groups an older surfgrad named otherwise
  (up to version 22: the image's name without its library and no extension; "SG Parallax
  [Bumps]" for Bumps with CLIP is "SG Parallax [Bumps] (CLIP)" now): it said "its rebuild did
  not reach it" and the old group stayed, stale. Now such a group takes today's name and is
  rebuilt in place, or, where a group holds that name already (the artist added it again),
  every node using it moves to that one, values and links kept, and the old one is removed.
- Triplanar per-image group names joined the planes' image names with " | ": images "A | B",
  "C", "C" and "A", "B | C", "C" gave one name, so the second use rebuilt the first one's group
  (which the first material uses) for its images. Now each plane's name is escaped.
"""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import group_updates as U  # noqa: E402
from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _image(name):
    return bpy.data.images.new(name, 4, 4)


def _use(mat, tree):
    """A group node for `tree` in `mat`, with a value set and a link in and out (what an
    update must keep)."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    node = nodes.new("ShaderNodeGroup")
    node.node_tree = tree
    uv = nodes.new("ShaderNodeUVMap")
    if "UV" in node.inputs:
        links.new(uv.outputs["UV"], node.inputs["UV"])
    out = nodes.new("ShaderNodeVectorMath")
    links.new(node.outputs[0], out.inputs[0])
    return node, uv, out


def _kept(node, uv, out, tree):
    assert node.node_tree == tree
    assert node.outputs[0].links[0].to_node == out
    if "UV" in node.inputs:
        assert node.inputs["UV"].links[0].from_node == uv


def _tap_images(tree):
    return [n.image.name for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage"]


def test_update_renames_and_rebuilds_older_per_image_groups(fresh):
    """Groups stamped and named as version 22 named them: each ends under today's name,
    current, in place (the same data-block), with its nodes' values and links."""
    mat = new_material("M")
    bumps, rock = _image("Bumps"), _image("Rock")
    clip = G.parallax_group(image=bumps, extension="CLIP")
    hq = G.height_map_group(image=rock, variant="hq", extension="EXTEND")
    made = [(_use(mat, clip), clip), (_use(mat, hq), hq)]
    made[0][0][0].inputs["Depth"].default_value = 0.37
    for tree, old in ((clip, "SG Parallax [Bumps]"), (hq, "SG Height Map HQ [Rock]")):
        tree.name, tree[VERSION_KEY] = old, G.VERSION - 1
    assert {g.name for g in U.stale_groups()} == {"SG Parallax [Bumps]",
                                                  "SG Height Map HQ [Rock]"}
    updated, left = U.update_stale_groups()
    assert left == []
    assert updated == ["SG Height Map HQ [Rock] (now SG Height Map HQ [Rock] (EXTEND))",
                       "SG Parallax [Bumps] (now SG Parallax [Bumps] (CLIP))"]
    assert clip.name == "SG Parallax [Bumps] (CLIP)" and clip[VERSION_KEY] == G.VERSION
    assert hq.name == "SG Height Map HQ [Rock] (EXTEND)" and hq[VERSION_KEY] == G.VERSION
    for used, tree in made:
        _kept(*used, tree)
    assert made[0][0][0].inputs["Depth"].default_value == pytest.approx(0.37)
    assert U.stale_groups() == []
    # Asked again from the menu: the updated group, no second one.
    assert G.parallax_group(image=bumps, extension="CLIP") == clip
    assert sum(g.name.startswith("SG Parallax") for g in bpy.data.node_groups) == 1


def test_update_moves_users_of_an_older_group_to_the_one_added_beside_it(fresh):
    """The artist added the group again after the extension's update (so today's group is
    beside the old one): the old one's users move to it, and the old one is gone."""
    mat = new_material("M")
    bumps = _image("Bumps")
    old = G.parallax_group(image=bumps, extension="CLIP")
    old_use = _use(mat, old)
    old_use[0].inputs["Depth"].default_value = 0.21
    old.name, old[VERSION_KEY] = "SG Parallax [Bumps]", G.VERSION - 1
    new = G.parallax_group(image=bumps, extension="CLIP")
    assert new != old and new.name == "SG Parallax [Bumps] (CLIP)"
    new_use = _use(mat, new)
    updated, left = U.update_stale_groups()
    assert (updated, left) == (["SG Parallax [Bumps] (now SG Parallax [Bumps] (CLIP))"], [])
    assert [g.name for g in bpy.data.node_groups if g.name.startswith("SG Parallax")] == [
        "SG Parallax [Bumps] (CLIP)"]
    _kept(*old_use, new)
    _kept(*new_use, new)
    assert old_use[0].inputs["Depth"].default_value == pytest.approx(0.21)
    assert U.stale_groups() == []


def test_triplanar_planes_whose_names_hold_the_separator_get_groups_of_their_own(fresh):
    ab, c, a, bc = _image("A | B"), _image("C"), _image("A"), _image("B | C")
    first = G.triplanar_height_group(images=[ab, c, c])
    second = G.triplanar_height_group(images=[a, bc, c])
    one = G.triplanar_height_group(image=_image("A | B | C | C"))
    assert len({first, second, one}) == 3
    assert len({first.name, second.name, one.name}) == 3
    assert _tap_images(first) == ["A | B"] * 3 + ["C"] * 6      # not rebuilt for the second
    assert _tap_images(second) == ["A"] * 3 + ["B | C"] * 3 + ["C"] * 3


def test_update_renames_a_triplanar_group_named_before_the_escape(fresh):
    """Version 23 named it without escaping: the update gives it today's name, in place."""
    mat = new_material("M")
    ab, c = _image("A | B"), _image("C")
    tree = G.triplanar_height_group(images=[ab, c, c])
    used = _use(mat, tree)
    today = tree.name
    tree.name = "SG Triplanar Height [A | B | C | C]"
    assert U.stale_groups() == [tree]
    assert U.update_stale_groups() == ([f"SG Triplanar Height [A | B | C | C] (now {today})"],
                                       [])
    assert tree.name == today and U.stale_groups() == []
    _kept(*used, tree)


def test_a_refused_update_gives_the_older_group_its_name_back(fresh):
    """A helper made by a newer surfgrad refuses the update: nothing changes, the name too."""
    bumps = _image("Bumps")
    tree = G.parallax_group(image=bumps, extension="CLIP")
    tree.name, tree[VERSION_KEY] = "SG Parallax [Bumps]", G.VERSION - 1
    bpy.data.node_groups[".SG UV Gradients"][VERSION_KEY] = G.VERSION + 1
    with pytest.raises(ValueError, match="newer surfgrad"):
        U.update_stale_groups()
    assert tree.name == "SG Parallax [Bumps]" and tree[VERSION_KEY] == G.VERSION - 1
    assert sorted(g.name for g in bpy.data.node_groups) == [
        ".SG Surface Gradient", ".SG UV Gradients", "SG Parallax [Bumps]"]


def test_update_renames_a_group_named_for_a_librarys_image_by_its_bare_name(fresh, tmp_path):
    """Up to version 22 a library's image was named without its library: "SG Height Map HQ
    [Rock]" for Rock of lib.blend, today "SG Height Map HQ [Rock [lib.blend]]"."""
    library = tmp_path / "lib.blend"
    bpy.data.libraries.write(str(library), {_image("Rock")})
    bpy.data.images.remove(bpy.data.images["Rock"])
    with bpy.data.libraries.load(str(library), link=True) as (_, into):
        into.images = ["Rock"]
    rock = into.images[0]
    assert rock.library is not None and rock.name_full == "Rock [lib.blend]"
    tree = G.height_map_group(image=rock, variant="hq")
    used = _use(new_material("M"), tree)
    tree.name, tree[VERSION_KEY] = "SG Height Map HQ [Rock]", G.VERSION - 1
    updated, left = U.update_stale_groups()
    assert (updated, left) == (
        ["SG Height Map HQ [Rock] (now SG Height Map HQ [Rock [lib.blend]])"], [])
    assert tree.name == "SG Height Map HQ [Rock [lib.blend]]" and U.stale_groups() == []
    _kept(*used, tree)
