"""The mesh a bake sees, and the UDIM tiles its UV maps cover there.

Blender's bake renders the object's mesh as Cycles evaluates it for a render (object_bake_api.cc
builds a RENDER depsgraph): modifiers at their render settings. Modifiers can move UVs (UV Warp,
UV Project, Array's and Mirror's UV offsets, Geometry Nodes) and can be shown in renders only or
in the viewport only, so the tiles a bake writes and the faces it covers are those of that mesh,
not of the mesh data: a layout checked on the mesh data bakes a blank map, or leaves a tile out,
with exit 0. An object without modifiers is read from the viewport's depsgraph
(the same mesh, and no render-mode pass); one with modifiers through render_mesh.py.
"""

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ..reference import tiles as T
from .bake_target import bake_target_problem
from .facing_away import facing_away_triangles
from .flat_frames import frame_mismatch_faces
from .mesh_triangles import triangle_uvs, triangles
from .read_once import ReadOnce
from .unrealized_instances import read_instances


def not_rendered_problem(obj_name, uv_map, rendered, obj=None, faces=None):
    """The refusal of UV map `uv_map` of the object, which the mesh as it renders lacks (it
    has the UV maps `rendered`), with the fix. Where it has none at all (a Remesh, a Geometry
    Nodes tree making the mesh anew or storing its UVs as a 3D vector), "pick one of those"
    offers nothing: the modifiers shown in renders of `obj` are named instead. faces: how
    many faces the mesh as it renders has, where the caller knows (none: no_faces_problem)."""
    if not rendered and obj is not None and faces is not None:
        problem = no_faces_problem(obj, faces)
        if problem:                     # no faces, so no UV map: the faces are the problem
            return problem
    if rendered or obj is None:
        return (f"UV map {uv_map!r} of object {obj_name!r} is not on the mesh as it renders (a "
                f"modifier removes it, or a Geometry Nodes Store Named Attribute writes its "
                f"name on another domain than Face Corner or as another type than 2D Vector; "
                f"the rendered mesh has {sorted(rendered)}): pick one of those, or fix the "
                f"modifiers")
    named = _shown_modifiers(obj)
    shown = [m.type for m in obj.modifiers if m.show_render]
    fixes = []
    if "REMESH" in shown:
        fixes.append("a Remesh makes new faces without UVs: apply it (or its result, "
                     "Object > Convert > Mesh) and unwrap the mesh (UV > Unwrap)")
    if "NODES" in shown:
        fixes.append(f"in a Geometry Nodes tree, store the UVs as {uv_map!r} with a Store "
                     f"Named Attribute of type 2D Vector on Face Corner")
    fixes = fixes or ["apply the modifiers and unwrap the mesh (UV > Unwrap)"]
    return (f"UV map {uv_map!r} of object {obj_name!r} is not on the mesh as it renders, which "
            f"has no UV map at all: its modifier(s) shown in renders ({named or 'none'}) "
            f"leave the mesh without one; {'; or '.join(fixes)}")


def _shown_modifiers(obj):
    """The modifiers of obj shown in renders, as a refusal names them."""
    return ", ".join(f"{m.name!r} ({m.type.replace('_', ' ').title()})"
                     for m in obj.modifiers if m.show_render)


def no_faces_problem(obj, faces):
    """None, or the refusal of obj whose mesh data has faces but whose mesh as it renders
    (`faces` of them) has none: its modifiers make points, curves or nothing (Geometry Nodes'
    Mesh to Points or Mesh to Curve, a Delete Geometry), which a bake cannot take."""
    if faces or not len(obj.data.polygons):
        return None
    return (f"object {obj.name!r} has no faces as it renders, though mesh {obj.data.name!r} "
            f"has {len(obj.data.polygons)}: its modifier(s) shown in renders "
            f"({_shown_modifiers(obj) or 'none'}) leave none (points, curves or nothing, "
            f"which a bake cannot take): make them output faces, or turn them off for "
            f"renders (the camera icon in the modifier's header)")


def long_name_problem(obj_name, uv_map):
    """None, or the refusal of UV map `uv_map`, whose name is longer than Blender's bake
    operator and its UV Map and Normal Map nodes take (63 bytes on every line, where a UV map
    takes 67 up to 5.0 and any length on 5.2): they cut it short and find no such UV map
    (the bake failed after the checks, exit 1; compare's node graph could not be built)."""
    import bpy
    # The nodes' limit; the bake operator's uv_layer is as long (tests pin it).
    longest = bpy.types.ShaderNodeUVMap.bl_rna.properties["uv_map"].length_max - 1
    size = len(uv_map.encode())
    if size <= longest:
        return None
    return (f"UV map {uv_map!r} of object {obj_name!r} has a name of {size} bytes, longer than "
            f"Blender's bake and its UV Map and Normal Map nodes take ({longest} bytes): they "
            f"cut it short and find no such UV map; rename it (Object Data > UV Maps) to "
            f"{longest} bytes or fewer")


def modified(obj):
    """obj has modifiers: its rendered mesh may differ from the mesh data and, through their
    render and viewport switches and settings, from the viewport's."""
    return len(obj.modifiers) > 0


def read_as_baked(obj, read):
    """read(evaluated object, depsgraph) for obj evaluated as the bake evaluates it; returns
    what read returns."""
    import bpy
    # An object the bake refuses (linked, outside the view layer) is read as the viewport
    # has it: its refusal names the problem, the render-mode pass could not reach it.
    if modified(obj) and bake_target_problem(obj, bpy.context.view_layer) is None:
        from .render_mesh import read_in_render_mode
        return read_in_render_mode(obj, lambda depsgraph: read(obj.evaluated_get(depsgraph),
                                                                depsgraph))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return read(obj.evaluated_get(depsgraph), depsgraph)


def _tiles_of(tri_uv, faces):
    outside = np.unique(faces[T.triangles_outside(tri_uv)])
    return T.tiles_with_uvs(tri_uv), int(len(outside))


def uv_tiles(mesh, uv_map):
    """The UDIM tiles the faces of `uv_map` cover, sorted, and how many faces lie (partly)
    outside the UDIM range (u in 0..10, v in 0..100). Exact (reference/tiles.py): a tile counts
    when a face's triangle covers part of it, not when only its bounding box reaches in, and
    a face across the range's border still names the tiles its inside part covers."""
    if len(mesh.polygons) == 0:
        return [], 0
    loops, faces = triangles(mesh)
    return _tiles_of(triangle_uvs(mesh, uv_map, loops), faces)


@dataclass(frozen=True)
class BakedMesh:
    """The mesh the bake renders, in float64: every UV map's tiles (uv_tiles), the vertex
    positions, the triangles' vertices, the world matrix and each UV map's triangle UVs; and
    the meshes the object renders as instances, which the bake leaves out
    (unrealized_instances.py)."""
    layout: dict
    positions: np.ndarray
    triangles: np.ndarray
    matrix: np.ndarray
    triangle_uvs: dict
    instances: tuple = ()
    triangle_faces: np.ndarray = None       # (T,) the face of each triangle
    face_materials: np.ndarray = None       # (F,) each face's material index
    slot_materials: tuple = ()              # per material slot of the rendered object: its
    #                                         material (the original data-block) or None
    nonfinite_normals: int = 0              # face corners whose normal is NaN or Inf
    attribute_names: frozenset = frozenset()    # of the rendered mesh (UV maps among them)
    active_uv: str = None                   # its active UV map (tangent_uv.py)
    colour_attributes: tuple = ()           # its colour attributes' names
    facing_away_faces: tuple = ()           # faces with a corner normal facing away (facing_away.py)
    frame_faces: tuple = ()                 # faces a tangent map renders off (flat_frames.py)
    vertex_normals_shaded: bool = False     # Cycles shades smooth faces with vertex normals

    @property
    def filled_slots(self):
        """Per material slot of the rendered object: whether it holds a material."""
        return tuple(m is not None for m in self.slot_materials)


_meshes = ReadOnce()           # {object pointer: BakedMesh} inside one_read()


def one_read():
    """Within this block each object's rendered mesh is read once: a request's checks and
    its bake want it three times, and for an object with modifiers each read is a
    render-mode pass. Nothing may change the mesh within the block."""
    return _meshes.scope()


def baked_mesh(obj):
    """The BakedMesh of obj (read once per object inside one_read())."""
    def read(evaluated, depsgraph):
        instances = read_instances(evaluated, depsgraph)
        mesh = evaluated.to_mesh()
        try:
            loops, faces = triangles(mesh)
            positions = np.empty(len(mesh.vertices) * 3, np.float64)
            mesh.vertices.foreach_get("co", positions)
            tris = np.empty(len(loops), np.int64)
            mesh.loop_triangles.foreach_get("vertices", tris)
            uvs = {uv.name: triangle_uvs(mesh, uv.name, loops) for uv in mesh.uv_layers}
            layout = {name: _tiles_of(uv, faces) if len(mesh.polygons) else ([], 0)
                      for name, uv in uvs.items()}
            materials = np.zeros(len(mesh.polygons), np.int32)
            mesh.polygons.foreach_get("material_index", materials)
            normals = np.empty(len(mesh.loops) * 3, np.float32)
            mesh.corner_normals.foreach_get("vector", normals)
            return BakedMesh(layout, positions.reshape(-1, 3), tris.reshape(-1, 3),
                             np.array(evaluated.matrix_world, dtype=np.float64), uvs,
                             instances, faces, materials,
                             tuple(s.material and s.material.original
                                   for s in evaluated.material_slots),
                             int(np.count_nonzero(~np.isfinite(normals.reshape(-1, 3)).all(1))),
                             frozenset(a.name for a in mesh.attributes),
                             mesh.uv_layers.active.name if mesh.uv_layers.active else None,
                             tuple(a.name for a in mesh.color_attributes),
                             tuple(np.unique(faces[facing_away_triangles(
                                 positions.reshape(-1, 3), tris.reshape(-1, 3),
                                 normals.reshape(-1, 3)[loops].reshape(-1, 3, 3))]).tolist()),
                             *_frame_faces(mesh, positions.reshape(-1, 3), tris.reshape(-1, 3),
                                           faces, loops.reshape(-1, 3),
                                           normals.reshape(-1, 3)))
        finally:
            evaluated.to_mesh_clear()
    return _meshes.get(obj.as_pointer(), lambda: read_as_baked(obj, read))


def _frame_faces(mesh, positions, tris, faces, corners, normals):
    """(faces where a tangent map renders off, whether Cycles shades smooth faces with vertex
    normals): flat_frames.py."""
    import bpy
    from ..reference.blender_lines import facts_for
    facts = facts_for(bpy.app.version)
    flat = np.zeros(len(mesh.polygons), bool)
    if "sharp_face" in mesh.attributes:
        mesh.attributes["sharp_face"].data.foreach_get("value", flat)
    if not flat.any():
        return (), False
    sharp = np.zeros(len(mesh.edges), bool)
    if "sharp_edge" in mesh.attributes:
        mesh.attributes["sharp_edge"].data.foreach_get("value", sharp)
    sharp_edges = bool(sharp.any())
    # Up to 5.0 only custom normals or sharp edges make Cycles shade with corner normals
    # (reference/blender_lines.py, sharp_faces_give_corner_normals).
    shaded = (not facts.sharp_faces_give_corner_normals
              and not mesh.has_custom_normals and not sharp_edges)
    vertex = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("normal", vertex)
    return (frame_mismatch_faces(positions, tris, faces, corners, flat, normals,
                                 vertex.reshape(-1, 3), shaded), shaded)


@contextmanager
def uv_active(mesh, uv_map):
    """For the block, UV map `uv_map` of mesh (the data, not the rendered mesh) is its active
    one, as for the bake; the active one before is put back, none where none was. A mesh
    with UV maps but none active (5.2 loads 2.4x files so: castle-engine's demo-models) was
    refused by Blender's bake, "No active UV layer found in the object", whatever UV map was
    asked for."""
    before = mesh.uv_layers.active.name if mesh.uv_layers.active else None
    if uv_map is None or before == uv_map or uv_map not in mesh.uv_layers:
        yield
        return
    mesh.uv_layers.active = mesh.uv_layers[uv_map]
    try:
        yield
    finally:
        mesh.uv_layers.active = mesh.uv_layers[before] if before is not None else None


def rendered_materials(obj, viewport=False):
    """The distinct materials obj renders with: its own slots' and those the mesh as it
    renders adds (a Geometry Nodes Set Material of a material the object has no slot for:
    Cycles renders and bakes it, and the checks had not read it, so a missing texture there
    baked Cycles' magenta with exit 0). viewport: those of the viewport's evaluated object,
    no render-mode pass (a batch's list of the files a whole .blend reads)."""
    import bpy
    own = [s.material for s in obj.material_slots]
    if not modified(obj):
        added = []
    elif viewport:
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        added = [s.material and s.material.original for s in evaluated.material_slots]
    else:
        added = list(baked_mesh(obj).slot_materials)
    return [m for m in dict.fromkeys(own + added) if m is not None]


def baked_uv_tiles(obj):
    """{UV map name: (tiles, faces outside the UDIM range)} of every UV map of the mesh the
    bake renders (uv_tiles on it)."""
    return baked_mesh(obj).layout
