"""The Sampler closure of the 5.0+ groups: a Closure Zone (Closure Input and Closure Output
nodes, Vector in, Color out) around the artist's own Image Texture node. The zone's Closure
output feeds a sampler group's Sampler input; the group evaluates it at every coordinate it
needs (Evaluate Closure), so one group serves any image. Pinned in tests/test_sampler.py.
"""

ZONE_INPUT, ZONE_OUTPUT = "NodeClosureInput", "NodeClosureOutput"


def has_closures():
    """True on Blender 5.0 and later (the nodes, not the version number, decide)."""
    import bpy
    return all(hasattr(bpy.types, t) for t in (ZONE_INPUT, ZONE_OUTPUT, "NodeEvaluateClosure"))


def sampler_zone(nodes, links, tex=None, location=(0.0, 0.0)):
    """A Closure Zone with a Vector input and a Color output around Image Texture node `tex`
    (its Vector from the zone, its Color out of it); `tex` None: an empty zone. A `tex` whose
    outputs feed other nodes (Base Color, Roughness, ...) keeps them: links out of the zone
    would cross it, so it stays where it is and a copy of it (same image and settings) goes
    into the zone. Returns (closure output node, the node in the zone or None, the socket that
    fed `tex`'s Vector or None: the caller gives it to the group's UV)."""
    zin, zout = nodes.new(ZONE_INPUT), nodes.new(ZONE_OUTPUT)
    if not zin.pair_with_output(zout):
        raise RuntimeError("Blender did not pair the Closure Input and Output nodes")
    zout.input_items.new("VECTOR", "Vector")
    zout.output_items.new("RGBA", "Color")
    zin.label, zout.label = "Sampler", "Sampler"
    x, y = location
    zin.location, zout.location = (x - 460, y), (x, y)
    vector_source = None
    if tex is not None:
        if tex.inputs["Vector"].is_linked:
            vector_source = _outside_zones(tex.inputs["Vector"].links[0].from_socket)
        if any(out.is_linked for out in tex.outputs):
            tex = copy_image_texture(nodes, tex)
        elif vector_source is not None:
            links.remove(tex.inputs["Vector"].links[0])
        links.new(zin.outputs["Vector"], tex.inputs["Vector"])
        links.new(tex.outputs["Color"], zout.inputs["Color"])
        tex.location = (x - 260, y)
    return zout, tex, vector_source


def _outside_zones(socket):
    """`socket`, or where it is inside another Sampler zone (the texture is one a group
    samples already), what feeds that zone's group's UV: a link out of a zone is invalid and
    makes everything downstream of it invalid, up to the Material Output. None when there is
    no such socket (the group's UV then stays the active UV map)."""
    node = socket.node
    if node.bl_idname != ZONE_INPUT:
        upstream, seen = [node], set()
        while upstream:                       # a Mapping inside the zone is inside it too
            n = upstream.pop()
            if n.name in seen:
                continue
            seen.add(n.name)
            if n.bl_idname == ZONE_INPUT:
                return None
            upstream += [lk.from_node for s in n.inputs for lk in s.links]
        return socket
    for link in node.paired_output.outputs[0].links:
        uv = link.to_node.inputs.get("UV")
        if uv is not None and uv.is_linked:
            return uv.links[0].from_socket
    return None


# What makes an Image Texture node sample as it does (node and image-user settings).
_TEX_SETTINGS = ("image", "interpolation", "projection", "projection_blend", "extension")
_USER_SETTINGS = ("frame_duration", "frame_start", "frame_offset", "use_cyclic",
                  "use_auto_refresh")
_MAPPING_SETTINGS = ("vector_type", "translation", "rotation", "scale", "min", "max",
                     "use_min", "use_max", "mapping", "mapping_x", "mapping_y", "mapping_z")


def copy_image_texture(nodes, tex):
    """A new Image Texture node sampling exactly as `tex` does (unlinked)."""
    copy = nodes.new("ShaderNodeTexImage")
    for name in _TEX_SETTINGS:
        setattr(copy, name, getattr(tex, name))
    for name in _USER_SETTINGS:
        if hasattr(tex.image_user, name):
            setattr(copy.image_user, name, getattr(tex.image_user, name))
    for name in _MAPPING_SETTINGS:
        if hasattr(tex.texture_mapping, name):
            setattr(copy.texture_mapping, name, getattr(tex.texture_mapping, name))
    copy.label = tex.label
    return copy
