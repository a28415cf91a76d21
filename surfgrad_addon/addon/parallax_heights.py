"""Parallax height maps outside 0..1, warned before a bake (bake_request.check) and by Freeze,
and baked as they are. SG Parallax marches its heights from 1 (Depth above the surface) down to
0, so a float height image holding values above 1 or below 0 (heights in centimetres, a map
centred on 0) has its relief cut off where it leaves that range: the group does as the
reference does, but not what the map holds (tests/test_faults_leftovers42a.py)."""

from .image_checks import data_key, objects_nodes, sampler_textures
from .normal_map_checks import own_files, range_facts

PER_IMAGE = "SG Parallax ["          # the per-image group's name: its image inside
SAMPLER = "SG Parallax (Sampler)"    # 5.0+: the image in the Sampler zone linked into it


def parallax_height_images(obj, only=None):
    """[(material, what reads it, Image Texture node)] for the height images SG Parallax groups
    in the object's materials (or `only`) read: the per-image group's own Image Texture, or
    those in the Sampler zone feeding an SG Parallax (Sampler)."""
    out = []
    for mat, node, path, outer in objects_nodes(obj, only):
        if node.bl_idname == "ShaderNodeTexImage" and outer and \
                outer[-1].node_tree.name.startswith(PER_IMAGE):
            out.append((mat, f"SG Parallax node {path.rsplit(' > ', 1)[0]!r}", node))
        group = getattr(node, "node_tree", None) if node.type == "GROUP" else None
        if group is not None and group.name.split(".")[0] == SAMPLER and "Sampler" in node.inputs:
            out += [(mat, f"SG Parallax node {path!r}", tex)
                    for tex in sampler_textures(node.inputs["Sampler"])]
    return out


def parallax_height_warnings(obj, only=None, covered=()):
    """A warning per float height image an SG Parallax reads (parallax_height_images) with
    texels above 1 or below 0 in R, the channel it reads (of a tiled image, the UDIM tiles
    `covered`, all where empty)."""
    out, seen = [], {}
    for mat, what, tex in parallax_height_images(obj, only):
        image = tex.image
        if image is None:
            continue
        files = own_files(image, tex, covered)
        key = (data_key(image), tuple(files))
        if key not in seen:
            seen[key] = [_outside_text(facts, where) for facts, where in
                         range_facts(image, files)]
        for problem in filter(None, seen[key]):
            text = (f"image {image.name!r}, read as heights by {what} (material {mat.name!r}), "
                    f"{problem}")
            if text not in out:
                out.append(text)
    return out


def _outside_text(facts, where):
    above, below = facts.above_one, facts.below_zero[0]
    if not above and not below:
        return None
    counts = " and ".join(part for part in (
        f"{above} above 1 (up to {facts.largest:.3g})" if above else "",
        f"{below} below 0" if below else "") if part)
    return (f"has {counts} of its {facts.texels} texels{where}: SG Parallax marches heights "
            f"0..1 (1 = Depth above the surface), so its relief is cut off beyond them (the "
            f"bake takes it as Cycles renders it); scale the heights into 0..1 and set Depth "
            f"to the range they spanned")
