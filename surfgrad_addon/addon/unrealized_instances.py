"""Faces an object renders as instances, which its bake leaves out.

Geometry Nodes instances left unrealized (Instance on Points, Geometry to Instance, Object or
Collection Info with instances), and the object's own vertex / face instancing and particle
instances, are separate objects of the render depsgraph: Cycles renders them with the object,
but Blender's bake renders only the object's realized mesh (object_bake_api.cc bakes the
evaluated mesh of each selected object). Measured on 5.2: a mesh whose second half is an
instance of a part with the same material, UVs in the right half of the square, bakes that
half as the background (every texel flat) with exit 0; with Realize Instances it is baked.

So the map is partial where instance faces that use one of the object's materials cover texels
of the baked tiles that the realized mesh leaves empty: that is refused like faces outside
the UDIM range (allow_partial bakes the rest, with a warning). Instances whose texels the mesh
covers already (copies of the object's own mesh: the same UVs) and instances of other
materials (a scatter with its own textures) do not make this map partial; they get a warning,
as they still are not baked. An instance's UVs do not depend on its transform, so each
instanced mesh is read once however many times it is instanced.
"""

from dataclasses import dataclass

import numpy as np

from ..reference import tiles as T
from ..reference import uv_overlap as UV
from .mesh_triangles import triangle_uvs, triangles

CHECK_SIZE = 512           # texels a side the coverage is compared at (cost bound)
FIX = ("add a Realize Instances node before the Group Output of its Geometry Nodes (or apply "
       "the modifier, or Object > Apply > Make Instances Real)")


@dataclass(frozen=True)
class InstancedMesh:
    """One mesh the object instances: how often, its faces, and per triangle its material's
    name and its UVs in each UV map."""
    name: str
    count: int
    faces: int
    triangle_materials: tuple
    triangle_uvs: dict


def may_instance(obj):
    """obj can make instances (cheap, so the depsgraph's instances are walked only then)."""
    return getattr(obj, "instance_type", "NONE") != "NONE" or any(
        m.type in ("NODES", "PARTICLE_SYSTEM") for m in obj.modifiers)


def read_instances(obj, depsgraph):
    """The InstancedMesh list of the instances obj makes in depsgraph (faces only)."""
    if not may_instance(obj.original):
        return ()
    found = {}
    for inst in depsgraph.object_instances:
        if not inst.is_instance or inst.parent is None or \
                inst.parent.original != obj.original or not inst.show_self:
            continue
        o = inst.object
        if o.type != "MESH" or len(o.data.polygons) == 0:
            continue
        key = o.data.as_pointer()
        if key in found:
            found[key][0] += 1
        else:
            found[key] = [1, _mesh_record(o, obj.name)]
    return tuple(InstancedMesh(rec[0], count, *rec[1:]) for count, rec in found.values())


def _mesh_record(o, instancer):
    mesh = o.data
    loops, index = triangles(mesh, "material_index")
    slots = [s.material.name if s.material else None for s in o.material_slots]
    materials = tuple(slots[i] if 0 <= i < len(slots) else None for i in index)
    uvs = {layer.name: triangle_uvs(mesh, layer.name, loops) for layer in mesh.uv_layers}
    # A Geometry Nodes instance's object takes the instancer's name: name its mesh then.
    name = f"mesh {mesh.name!r}" if o.name == instancer else f"object {o.name!r}"
    return (name, len(mesh.polygons), materials, uvs)


def _covered(uv, tile, size, edges=False):
    return UV.claimed_texels(uv, size, T.tile_uv_offset(tile), edges) > 0 if len(uv) else \
        np.zeros(size * size, dtype=bool)


def _what(instances, obj):
    count = sum(m.count for m in instances)
    faces = sum(m.count * m.faces for m in instances)
    return (f"object {obj.name!r} renders {count} unrealized instance(s) of "
            f"{', '.join(m.name for m in instances[:3])}{', ...' if len(instances) > 3 else ''}"
            f" ({faces} faces), which Blender's bake leaves out (it bakes only the realized "
            f"mesh)")


def compare_warning(instances, obj):
    """compare's warning for obj's unrealized instances (None without any): its figures are
    those of the realized mesh alone."""
    if not instances:
        return None
    return f"{_what(instances, obj)}: they are not compared; to compare them, {FIX}"


def instance_problems(instances, obj, mesh_uv, uv_map, tiles, resolution, allow_partial,
                      only=None):
    """(problems, warnings) for obj's unrealized instances: instance faces of obj's own
    materials (or material `only`: Freeze's) on texels of `tiles` that the realized mesh
    (triangle UVs `mesh_uv`) leaves empty make the map partial (a problem, unless
    allow_partial; None: there is no such option to name, as in Freeze); other instances a
    warning."""
    if not instances:
        return [], []
    own = {only.name} if only is not None else \
        {s.material.name for s in obj.material_slots if s.material}
    size = min(int(resolution or CHECK_SIZE), CHECK_SIZE)
    theirs = []                  # the UV triangles of instance faces of obj's materials
    for m in instances:
        uv = m.triangle_uvs.get(uv_map)
        mine = np.array([name in own for name in m.triangle_materials], dtype=bool)
        if uv is not None and mine.any():
            theirs.append(uv[mine])
    missing = 0
    # A tile only instances reach is not baked at all: all their texels there are missing.
    reached = sorted(set(tiles).union(*(T.tiles_with_uvs(uv) for uv in theirs)))
    for tile in reached if theirs else ():
        baked = mesh_uv is not None and tile in tiles
        base = _covered(mesh_uv, tile, size, edges=True) if baked else \
            np.zeros(size * size, dtype=bool)
        reach = np.zeros(size * size, dtype=bool)
        for uv in theirs:
            reach |= _covered(uv, tile, size)
        missing += int(np.count_nonzero(reach & ~base))
    what = _what(instances, obj)
    if missing:
        text = (f"{what}; they use its material(s) on {missing} texel(s) (counted at "
                f"{size}^2 a tile) that the realized mesh leaves empty, so the map would "
                f"lack them")
        if allow_partial is None:
            return [f"{text}: {FIX}"], []
        if not allow_partial:
            return [f"{text}: {FIX}, or bake the rest on purpose with --allow-partial (api: "
                    f"allow_partial=True; settings file: \"allow_partial\": true)"], []
        return [], [f"{text}: baked without them (--allow-partial)"]
    return [], [f"{what}; the map is complete without them (they reach no texel the mesh "
                f"leaves empty, or use other materials): if they belong in it, {FIX}"]


def only_instances_problems(baked, obj):
    """[the problem] when obj's rendered mesh has no faces but its instances do (Geometry to
    Instance at the end of the tree), else []."""
    if len(baked.triangles) or not baked.instances:
        return []
    count = sum(m.count for m in baked.instances)
    return [f"object {obj.name!r} renders all its faces as {count} unrealized instance(s) "
            f"and Blender's bake renders only the realized mesh, which has none: {FIX}"]
