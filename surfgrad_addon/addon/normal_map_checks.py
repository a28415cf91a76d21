"""Normal maps an artist got wrong, warned before a bake (bake_request.check) and baked as
they are: the bake takes the normals Cycles renders, so it never changes them, but says what
bends them, naming the image, the node and the fix.

- An image read in a colour space that is not data (sRGB, the usual slip): the colour is
  converted before the node decodes it, which bends every normal; the fix is the image's
  colour space. The file's working space (Linear Rec.709 unless a 5.x file says otherwise,
  the default for an EXR) converts nothing and is not warned about.

- An image whose file holds one or two channels (a grey or grey+alpha PNG, a grey JPEG or
  EXR): Blender reports 4 channels once it is loaded, having spread the grey over R, G and
  B, so every normal leans along (1, 1) in the tangent plane. (An EXR with two colour
  channels, an R, G normal map, or alpha alone is refused: image_channels.py.) The file's
  header says it (image_headers.py); formats it does not cover are not warned about.
- A float image whose normals are stored in -1..1, not 0..1 (more than NEGATIVE_SHARE of its
  texels below 0 in R or in G; a 0..1 map has none): the Normal Map node takes 0.5 as no
  tilt, so every normal is pulled toward (-1, -1).
- An image wired straight into a normal input (a BSDF's Normal or Coat Normal, a Bump node's
  Normal, an SG group's base Normal) with no Normal Map node between: Blender takes its colour,
  0..1 in each axis, as a world-space direction, so every normal leans toward (1, 1, 1) in
  world space. A decode in between (Vector Math, as an object-space workflow does) is taken as
  meant and not warned about.
- A float image with texels above 1 in R, G or B (1e30 from a broken export, values of a
  height or world-space map): they hold no normal a 0..1 map can, and tilt as their values
  happen to point; the warning counts them and says the largest.
- An image in the working space with alpha below 1 under an Alpha mode Cycles multiplies
  the colour by (premultiplied_problem; per line: LineFacts.byte_alpha_multiplied): those
  normals bend (74 degrees at alpha 0.5). Non-Color never is.
- More than NEGATIVE_SHARE of a map's texels with blue at or below 0.5 (blue_problem): a
  two-channel (RG, BC5) map saved without its blue; the Normal Map node bakes them into the
  surface. These two judge the image's own pixels (float_pixels.colour_facts).
Channels and range are judged in every file the bake reads: each UDIM tile's (of the tiles
baked; of a packed UDIM image, each tile's packed data), the frame file an Image Sequence reads
now, and the warning names it.
"""

import re

from .float_pixels import PixelsTooLarge, colour_facts, file_facts, pixel_facts
from .image_checks import (data_key, image_files, objects_nodes, packed_tile_files,
                           packed_tiled, sampler_textures, sequence_file, textures_feeding)
from .header_reads import path_headers
from .image_channels import cut_short_file, layered_file, path_channels, read_channels

# The nodes' inputs that take a tangent-space normal map (0..1, three channels).
NORMAL_MAP_INPUTS = {"Normal Map": ("Color",), "SG Normal Map": ("Color",),
                     "SG Tangent Normal": ("Color",), "SG Decal": ("Color",),
                     "SG Triplanar": ("Color X", "Color Y", "Color Z"),
                     "SG Triplanar (Sampler)": ("Sampler",),          # 5.0+: its zone's image
                     "SG Blend Normals": ("Color A", "Color B")}
NORMAL_MAP_GROUPS = tuple(name for name in NORMAL_MAP_INPUTS if name.startswith("SG "))
# ... with a per-UV-map suffix ("SG Normal Map [Detail]") or Blender's copy number (".001")
_GROUP_NAME = re.compile(rf"({'|'.join(map(re.escape, NORMAL_MAP_GROUPS))})( \[.*\])?(\.\d+)?")
# The working (scene linear) space before 5.0 made it a file setting (bpy.data.colorspace):
# the scene_linear role of the colour configuration 4.2 and 4.5 ship.
WORKING_SPACE_4X = "Linear Rec.709"
# The nodes the colour-space warning follows back to an image, and the inputs it follows (None:
# all): the colour is converted before any of them reads it. USD's scale and bias (Vector Math
# Multiply Add), a DirectX map's green flip (Separate, Math or Invert, Combine); not Invert's
# Factor (a mask is colour), nor a live Mix (not a plain read: tests/test_faults_leftovers41).
# The file checks do not follow them: math may remap a -1..1 map's range on purpose.
COLOUR_MATH = {"ShaderNodeVectorMath": None, "ShaderNodeMath": None,
               "ShaderNodeSeparateColor": None, "ShaderNodeCombineColor": None,
               "ShaderNodeSeparateXYZ": None, "ShaderNodeCombineXYZ": None,
               "ShaderNodeSeparateRGB": None, "ShaderNodeCombineRGB": None,
               "ShaderNodeInvert": ("Color",)}
NEGATIVE_SHARE = 0.05       # a few percent below 0: no 0..1 map, nor its filtering, has any


def normal_map_images(obj, only=None, through=None, tangent_only=False):
    """[(material, what the node is and its path, image, its Image Texture node)] for every
    image node whose Color output is read (through reroutes, into node groups through their
    inputs, and through the nodes `through` names: image_checks.textures_feeding) into a
    normal map input (NORMAL_MAP_INPUTS: a Normal Map node's Color, SG Normal Map's, SG
    Triplanar's Color X, ...) of a node the object's materials (or material `only`) reach;
    `tangent_only`: not a Normal Map node in Object or World Space (its map's blue may be
    anything)."""
    out = []
    for mat, node, path, outer in objects_nodes(obj, only):
        kind = _normal_map_kind(node)
        if tangent_only and kind == "Normal Map" and node.space != "TANGENT":
            continue
        names = NORMAL_MAP_INPUTS.get(kind, ())
        for name in names:
            socket = node.inputs.get(name)
            texes = sampler_textures(socket) if name == "Sampler" and socket is not None else \
                textures_feeding(socket, outer, through)
            for tex in texes:
                if tex is not None and tex.image is not None:
                    which = f" ({name})" if len(names) > 1 else ""
                    out.append((mat, f"{kind} node {path!r}{which}", tex.image, tex))
    return out


def _normal_map_kind(node):
    if node.bl_idname == "ShaderNodeNormalMap":
        return "Normal Map"
    tree = getattr(node, "node_tree", None) if node.bl_idname == "ShaderNodeGroup" else None
    match = _GROUP_NAME.fullmatch(tree.name) if tree is not None else None
    return match.group(1) if match else None


def unconverted(settings):
    """True where Cycles reads an image in colour space `settings` as it is: data (Non-Color),
    or the file's own working space, into which every other is converted (measured: the same
    map as Non-Color, tests/test_faults_images34.py)."""
    import bpy
    working = getattr(getattr(bpy.data, "colorspace", None), "working_space", None)
    return settings.is_data or settings.name in (working or WORKING_SPACE_4X, "scene_linear")


def data_space():
    """The name of the colour configuration's data space: Non-Color in Blender's own, another
    in a studio's (OCIO), where a warning naming Non-Color named nothing the artist has."""
    import bpy
    probe = bpy.data.images.new(".surfgrad data space", 1, 1)
    try:
        probe.colorspace_settings.is_data = True
        return probe.colorspace_settings.name
    finally:
        bpy.data.images.remove(probe)


def colour_space_warnings(obj, only=None):
    """A warning per image read as colour into a normal map input of a Normal Map node or an
    SG group (normal_map_images): sRGB (or any colour space that is not data)
    bends every texel's normal, and the bake, like Cycles' render, takes the bent one. Also
    through the nodes COLOUR_MATH names (USD's scale and bias: Image > Multiply Add > Normal
    Map; a DirectX map's green flip)."""
    out, data = [], None
    for mat, node, image, _ in normal_map_images(obj, only, through=COLOUR_MATH):
        if unconverted(image.colorspace_settings):
            problem = premultiplied_problem(image)
            if problem:
                data = data or data_space()
                text = (f"image {image.name!r}, read by {node} (material {mat.name!r}), "
                        f"{problem}; set the image's Color Space to {data} (or its Alpha to "
                        f"Channel Packed)")
                if text not in out:
                    out.append(text)
            continue
        data = data or data_space()
        text = (f"image {image.name!r} is read in colour space "
                f"{image.colorspace_settings.name!r} by {node} (material {mat.name!r}): a "
                f"normal map is data, and this bends every normal (the bake takes them as "
                f"Cycles renders them); set the image's Color Space to {data} (Image Texture "
                f"node, or the Image Editor's sidebar)")
        if text not in out:
            out.append(text)
    return out


def premultiplied_problem(image):
    """What Cycles does to an image in its working space (not data) whose alpha is below 1
    in some texels, under an Alpha mode that LineFacts.byte_alpha_multiplied (or
    float_alpha_multiplied) names, else None: it multiplies the colour by the alpha, so those
    normals bend (measured on every line: a 0..1 PNG normal map, Straight, alpha 0.5, 74
    degrees off; alpha 0 texels 101), where Non-Color, or Alpha Channel Packed or None, reads
    the colour as the file holds it. An EXR loads Premultiplied, which no line multiplies."""
    import bpy
    from ..reference.blender_lines import facts_for
    line = facts_for(bpy.app.version)
    if image.colorspace_settings.is_data or image.alpha_mode not in (
            line.float_alpha_multiplied + line.byte_alpha_multiplied):
        return None
    facts = _colour_facts(image)        # (is_float loads an image: this frees it again)
    if facts is None or not facts.alpha_below or image.alpha_mode not in (
            line.float_alpha_multiplied if facts.is_float else line.byte_alpha_multiplied):
        return None
    mode = _ALPHA_MODES.get(image.alpha_mode, image.alpha_mode)
    return (f"has {facts.share(facts.alpha_below)} with alpha below 1 (down to "
            f"{facts.lowest_alpha:.3g}) and "
            f"is read in colour space {image.colorspace_settings.name!r} with Alpha {mode!r}: "
            f"Cycles multiplies its colour by the alpha before the node decodes it, so those "
            f"normals bend (the bake takes them as Cycles renders them)")


_ALPHA_MODES = {"STRAIGHT": "Straight", "PREMUL": "Premultiplied"}


def _colour_facts(image):
    # Not a file the checks refuse from its header before any load (image_checks): 4.2 never
    # returns from loading a multilayer EXR cut short (the final CI hung there on 4.2).
    if not image.has_data and (layered_file(image) or cut_short_file(image)):
        return None
    try:
        return colour_facts(image)
    except PixelsTooLarge:
        return None                 # (image_checks refuses the bake for it)


def blue_problem(image):
    """What is wrong with a normal map more than NEGATIVE_SHARE of whose texels hold blue at
    or below 0.5 (float_pixels.FLAT_BLUE), normals at or past 90 degrees from the surface's,
    else None. A tangent-space map's normals lean out of the surface (blue above 0.5); these
    are a two-channel (RG, BC5) map saved with blue 0 or 0.5 (measured, a 16 x 16 map tilted
    up to 24 degrees, blue 0: the Normal Map node baked every normal into the surface, 136
    degrees off on average from what R and G mean, exit 0, no word; blue 0.5: 66). Of the
    image's own pixels (its first tile); black texels (a bake's untouched background) and
    the zero vector (0.5, 0.5, 0.5) are not counted."""
    facts = _colour_facts(image)
    if facts is None or facts.blue_flat <= NEGATIVE_SHARE * facts.texels:
        return None
    return (f"has {facts.share(facts.blue_flat)} with blue at or below 0.5: "
            f"their normals point along or into the surface, which no tangent-space normal "
            f"map holds (its blue is above 0.5), so they bake wrong (the bake takes them as "
            f"Cycles renders them); it looks like a two-channel (RG, BC5) map saved without "
            f"its blue: rebuild blue as 0.5 + 0.5 * sqrt(1 - x^2 - y^2), x = 2 R - 1, "
            f"y = 2 G - 1 (or re-export the map as RGB)")


# The inputs that take a world-space normal, on shading nodes and on the SG groups (their base
# normal); an image read there undecoded is no normal map (raw_image_normal_warnings).
WORLD_NORMAL_INPUTS = ("Normal", "Coat Normal", "Clearcoat Normal")


def _shades_with_normal(node):
    """The node bends what the bake takes by its normal input: a closure (its Normal is the
    shading normal), a Bump or Displacement node, an SG group (its base normal). Not a user's
    group (its inside is walked on its own), nor nodes that only read a normal for a value
    (Normal's dot product, Fresnel, Layer Weight, Ambient Occlusion: the map is not bent)."""
    if node.bl_idname == "ShaderNodeGroup":
        tree = node.node_tree
        return tree is not None and (_normal_map_kind(node) is not None
                                     or tree.name.startswith("SG "))
    return node.bl_idname in ("ShaderNodeBump", "ShaderNodeDisplacement") or \
        any(o.type == "SHADER" for o in node.outputs)


def raw_image_normal_warnings(obj, only=None):
    """A warning per image whose output reaches a world-space normal input (WORLD_NORMAL_INPUTS)
    through nothing but reroutes and group sockets: Blender reads the colour, 0..1 per axis, as
    a direction, where a normal map needs the Normal Map node's decode and frame."""
    out = []
    for mat, node, path, outer in objects_nodes(obj, only):
        if not _shades_with_normal(node):
            continue
        for socket in node.inputs:
            if socket.name not in WORLD_NORMAL_INPUTS or socket.type != "VECTOR" or \
                    not socket.enabled:
                continue
            for tex in textures_feeding(socket, outer):
                if tex.image is None:
                    continue
                text = (f"image {tex.image.name!r} is wired straight into the {socket.name} "
                        f"input of node {path!r} (material {mat.name!r}): Blender takes its "
                        f"colour, 0..1 per axis, as a world-space direction, so every normal "
                        f"leans toward (1, 1, 1) and the bake takes them so; put a Normal Map "
                        f"node between them (Tangent Space for a tangent-space map)")
                if text not in out:
                    out.append(text)
    return out


def normal_map_warnings(obj, only=None, covered=()):
    """The warnings for every image normal_map_images finds: too few channels in a file it
    reads, or float pixels stored in -1..1 (of a tiled image, the UDIM tiles `covered`, all
    where empty). Each file is read once."""
    out, seen = [], {}
    tangent = {(m.name, n, i.as_pointer()) for m, n, i, _ in
               normal_map_images(obj, only, tangent_only=True)}
    for mat, node, image, tex in normal_map_images(obj, only):
        problem = generated_problem(image)
        if problem:
            text = f"image {image.name!r}, read by {node} (material {mat.name!r}), {problem}"
            if text not in out:
                out.append(text)
            continue
        files = own_files(image, tex, covered)
        key = (data_key(image), tuple(files))   # a library's image may share a name
        if key not in seen:
            seen[key] = _file_problems(image, files, covered)
        problems = [p for p in seen[key] if p]
        # The blue of a file already warned of (a grey file spread over R, G and B; -1..1
        # floats) is that fault's, said once; not texels above 1 (a few from a resize leave
        # a blue-0 map 136 degrees off), nor another UDIM tile's fault (blue reads the first).
        explained = [p for p in seen[key][:2] if p and _of_own_pixels(image, p)]
        if not explained and (mat.name, node, image.as_pointer()) in tangent:
            problems.append(blue_problem(image))
        for problem in problems:
            if problem:
                text = (f"image {image.name!r}, read by {node} (material {mat.name!r}), "
                        f"{problem}")
                if text not in out:
                    out.append(text)
    return out


def _of_own_pixels(image, problem):
    """The file problem is of the pixels blue_problem reads: the image's own, of a UDIM image
    its first tile's (a problem names the tile it is of)."""
    return image.source != "TILED" or "(tile " not in problem or \
        f"(tile {image.tiles[0].number}: " in problem


GENERATED_FLAT_DEG = 1.0      # a Blank image's colour this near (0.5, 0.5, 1): a flat map


def generated_problem(image):
    """What is wrong with a Generated image (Image Texture > New, never painted or saved) read
    as a normal map, else None: a UV Grid or Color Grid is a test pattern (its normals tilt
    up to 170 degrees, measured), and a Blank one of any colour but (0.5, 0.5, 1) tilts every
    normal alike (the default black: straight into the surface). Painted in this session
    (is_dirty) it holds the painting, which is not judged."""
    import math
    if image.source != "GENERATED" or image.is_dirty:
        return None
    fix = "paint it and save it, or load the normal map's file (Image > Open)"
    if image.generated_type != "BLANK":
        kind = {"UV_GRID": "UV Grid", "COLOR_GRID": "Color Grid"}.get(
            image.generated_type, image.generated_type)
        return (f"is a Generated {kind} (a test pattern), not a normal map: its normals "
                f"point every way; {fix}")
    x, y, z = (2.0 * c - 1.0 for c in image.generated_color[:3])
    length = math.sqrt(x * x + y * y + z * z)
    deg = math.degrees(math.acos(max(-1.0, min(1.0, z / length)))) if length > 1e-6 \
        else 180.0
    if deg <= GENERATED_FLAT_DEG:
        return None
    colour = ", ".join(f"{c:.2f}" for c in image.generated_color[:3])
    return (f"is a Generated Blank image of one colour ({colour}), not a normal map: every "
            f"normal tilts {deg:.0f} degrees from the surface's"
            f"{' (into it)' if deg > 90 else ''}; {fix}")


def _file_problems(image, files, covered):
    """(channels problem, range problems) of the image's `files`; of a packed UDIM image, of
    each packed tile the bake reads (its own pixels are its first tile's)."""
    if packed_tiled(image):
        with packed_tile_files(image, covered) as tiles:
            files = [(f"tile {number}: its packed data", path) for number, path in tiles]
            return (_channels_problem(image, files), *_range_problems(image, files))
    return (_channels_problem(image, files), *_range_problems(image, files))


def own_files(image, tex, covered):
    """(what, path) of each file the bake reads from `image` (read by Image Texture `tex`)
    that the image's own load does not: each UDIM tile's (of `covered`, all where empty), the
    frame file an Image Sequence reads now; [] for one file or packed data (the image's)."""
    if image.packed_file is not None or len(getattr(image, "packed_files", ())) or \
            not image.filepath:
        return []
    if image.source == "TILED":
        return [(f"tile {t.number}: {p.name}", p) for t, p in zip(image.tiles, image_files(image))
                if not covered or t.number in covered]
    if image.source == "SEQUENCE":
        path = sequence_file(image, tex)
        return [(f"frame file {path.name}", path)]
    return []


def _channels_problem(image, files):
    """What is wrong with the channels of the image's files (the first of its UDIM tiles, or
    its sequence frame file, that has too few), or None: fine, or a format whose header is
    not read (image_headers)."""
    found_in = [(what, path_channels(p)) for what, p in files] if files else \
        read_channels(image)
    for what, found in found_in:
        if found is None or found.lacking != "grey":     # (lacking colours: image_channels)
            continue
        held = (f"holds {found.channels} channel{'s' * (found.channels > 1)} in its file "
                f"({what}: {found.kind} {found.format})")
        return (f"{held}: Blender spreads the grey over R, G and B, so every normal leans "
                f"along (1, 1) in the tangent plane (the bake takes them as Cycles renders "
                f"them); save the normal map as RGB (three channels)")
    return None


def range_facts(image, files):
    """[(PixelFacts, where: " (the file)" or "")] of each float file of the image (of `files`,
    else the image's own pixels) that can be read."""
    if files:
        reads = [(lambda p=path: file_facts(p), f" ({what})") for what, path in files
                 if not getattr(path_headers(path), "layered", False)]  # (refused: image_checks)
    elif image.source not in ("FILE", "TILED") or (not image.has_data and layered_file(image)):
        reads = []
    else:
        reads = [(lambda: pixel_facts(image), "")]
    found = []
    for read, where in reads:
        try:
            facts = read()  # (read once with image_checks' finite test: float_pixels)
        except PixelsTooLarge:
            continue            # (image_checks refuses the bake for it)
        if facts is not None:
            found.append((facts, where))
    return found


def _range_problems(image, files):
    """(below 0, above 1): of the first float file of the image (range_facts) with more than
    NEGATIVE_SHARE of its texels below 0 in R or G, and of the first with any texel above 1
    (float_pixels.ABOVE_ONE), what is wrong, or None."""
    below = above = None
    for facts, where in range_facts(image, files):
        below = below or _below_text(facts, where)
        above = above or _above_text(facts, where)
    return below, above


def _below_text(facts, where):
    shares = facts.share_below_zero()     # (0, 0) with fewer than two channels
    if max(shares) <= NEGATIVE_SHARE:
        return None
    return (f"has {100 * shares[0]:.0f}% of its texels below 0 in R and "
            f"{100 * shares[1]:.0f}% in G{where}: it looks stored in -1..1, but a normal map "
            f"is read as 0..1 (0.5 is no tilt), so every normal is pulled toward (-1, -1) (the "
            f"bake takes them as Cycles renders them); store it as n * 0.5 + 0.5 (re-export "
            f"it as a 0..1 tangent-space normal map)")


def _above_text(facts, where):
    if not facts.above_one:
        return None
    return (f"has {facts.above_one} of its {facts.texels} texels above 1 in R, G or B (up to "
            f"{facts.largest:.3g}){where}: a normal map is read as 0..1, so those texels hold "
            f"no normal it can store and tilt as their values happen to point (the bake takes "
            f"them as Cycles renders them); clamp the map to 0..1 or re-export it")


def input_warnings(obj, only=None):
    """Every warning about the normal maps the object's materials (or `only`) read: colour
    space, channels, range. The Freeze operator reports them (bake_request.check warns the
    same for the commands)."""
    return colour_space_warnings(obj, only) + raw_image_normal_warnings(obj, only) + \
        normal_map_warnings(obj, only)
