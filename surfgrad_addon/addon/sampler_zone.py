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
    (its Vector from the zone, its Color out of it); `tex` None: an empty zone. Links from
    `tex`'s outputs to nodes outside the zone would cross it and are removed. Returns
    (closure output node, number of links removed, the socket that fed `tex`'s Vector or
    None: the caller gives it to the group's UV)."""
    zin, zout = nodes.new(ZONE_INPUT), nodes.new(ZONE_OUTPUT)
    if not zin.pair_with_output(zout):
        raise RuntimeError("Blender did not pair the Closure Input and Output nodes")
    zout.input_items.new("VECTOR", "Vector")
    zout.output_items.new("RGBA", "Color")
    zin.label, zout.label = "Sampler", "Sampler"
    x, y = location
    zin.location, zout.location = (x - 460, y), (x, y)
    removed, vector_source = 0, None
    if tex is not None:
        for out in tex.outputs:
            for link in list(out.links):
                links.remove(link)
                removed += 1
        if tex.inputs["Vector"].is_linked:
            vector_source = tex.inputs["Vector"].links[0].from_socket
            links.remove(tex.inputs["Vector"].links[0])
        links.new(zin.outputs["Vector"], tex.inputs["Vector"])
        links.new(tex.outputs["Color"], zout.inputs["Color"])
        tex.location = (x - 260, y)
    return zout, removed, vector_source
