"""What a batch does in one Blender session (a worker process, or this one with workers=0):
scan a .blend for its assets, or open it and bake one asset; run_request answers one request."""

import fnmatch
import os
import time
from pathlib import Path

from .. import bake_request as BR
from ..bake_uvs import one_read
from ..bake_target import object_not_a_mesh
from .. import interrupts
from ..exit_codes import MapNotWritten
from ..image_checks import data_key, image_problems
from ..input_stamps import read_files
from ..material_inputs import missing_library_problem
from ..object_names import missing_object_problem
from ..open_blend import BlendOpenError
from .. import normal_bake as NB
from .. import utf8_names

FAULT_ENV = "SURFGRAD_BATCH_FAULT"          # tests: "die:OBJECT", "die-once:OBJECT", "hang:OBJECT",
# "die-published-once:OBJECT" (once its map is in place)


def scan_open_file(objects=None, collections=None, everything=False):
    """The assets of the open file: with `objects` (names or wildcards) and/or `collections`
    (names, their objects and child collections), those; with neither, or with everything,
    (also) every mesh object with a material. Returns {"assets": [...], "errors": [...]}: per
    asset its name, UV maps with the tiles each holds, the active render UV map, and its
    material count."""
    import bpy
    chosen, errors = [], []
    mesh_objects = [o for o in bpy.data.objects if o.type == "MESH"]
    if objects:
        for pattern in objects:
            bad = utf8_names.problem("object", pattern)
            if bad:
                errors.append({"object": pattern, "error": bad})
                continue
            exact = bpy.data.objects.get(pattern)       # a name with * or [ in it is a name
            if exact is None and pattern != pattern.strip():    # a list line's stray spaces
                exact = bpy.data.objects.get(pattern.strip())
            hits = [exact] if exact else \
                [o for o in bpy.data.objects if fnmatch.fnmatchcase(o.name, pattern)]
            if not hits:
                errors.append({"object": pattern, "error": missing_object_problem(pattern)})
            chosen += hits
    for name in collections or ():
        coll = bpy.data.collections.get(name)
        if coll is None:
            errors.append({"object": f"collection:{name}", "error": f"no collection named "
                           f"{name!r} in {Path(bpy.data.filepath).name}; collections: "
                           f"{sorted(c.name for c in bpy.data.collections)}"})
            continue
        chosen += [o for o in coll.all_objects if o.type == "MESH"]
    if everything or (not objects and not collections):
        chosen += [o for o in mesh_objects if any(s.material for s in o.material_slots)]
        # placeholders of objects whose library is missing: named, not silently left out
        chosen += [o for o in bpy.data.objects if o.library and missing_library_problem(o)]
    with one_read():        # each object's rendered mesh read once for all its checks
        seen, assets = set(), []
        for obj in chosen:
            if obj.as_pointer() in seen:
                continue
            seen.add(obj.as_pointer())
            if bpy.data.objects.get(obj.name) is not obj:   # was skipped without a word
                errors.append(_shadowed(obj))
                continue
            missing = missing_library_problem(obj)
            if missing:
                errors.append({"object": obj.name, "error": missing})
                continue
            entry = {"object": obj.name, "type": obj.type, "uv_maps": {}, "active_uv": None,
                     "materials": 0}
            if obj.type == "MESH":
                entry["materials"] = sum(1 for s in obj.material_slots if s.material)
                entry["outside"] = {}
                layout = NB.baked_uv_tiles(obj) if len(obj.data.polygons) else {}
                for uv in obj.data.uv_layers:          # the tiles of the mesh the bake renders
                    entry["uv_maps"][uv.name], entry["outside"][uv.name] = \
                        layout.get(uv.name, ([], 0))
                    if uv.active_render:
                        entry["active_uv"] = uv.name
                    if not entry["uv_maps"][uv.name] and entry["outside"][uv.name]:
                        uvs = NB.baked_mesh(obj).triangle_uvs[uv.name].reshape(-1, 2)
                        entry.setdefault("uv_spans", {})[uv.name] = \
                            [uvs.min(0).tolist(), uvs.max(0).tolist()]   # (told in its refusal)
                entry["modifier_uvs"] = sorted(set(layout) - set(entry["uv_maps"]))
                entry["problems"] = _input_problems(obj)
            else:                   # (an Empty showing a collection names its meshes)
                entry["not_a_mesh"] = object_not_a_mesh(obj, "pick mesh objects")
            assets.append(entry)
    return {"assets": assets, "errors": errors}


def _shadowed(obj):
    """The failure of an object linked from a library under the name of another object of
    the file (a local one): a bake names its object, and that name is the other's."""
    import bpy
    lib = Path(obj.library.filepath).name
    return {"object": f"{obj.name} [{lib}]",
            "error": f"object {obj.name!r} linked from library {obj.library.filepath!r} has "
                     f"the name of another object in {Path(bpy.data.filepath).name}, which a "
                     f"bake of {obj.name!r} takes: bake it in the library file, or make it "
                     f"local (Object > Relations > Make Local), which gives it a name of its own"}


def _input_problems(obj):
    """What bake_request finds wrong with obj's mesh and images (no setting changes these),
    so the planner refuses the asset before any bake."""
    if len(obj.data.polygons) == 0:
        return []                          # the bake's own check names it
    return BR.mesh_problems(obj, None, []) + image_problems(obj)


def dependencies_of_open_file():
    """Absolute paths of the external files the open file uses (not packed), with the files
    its meshes' materials read: each tile of a UDIM image (Blender lists its path with
    <UDIM>, no file: a tile changed, the rerun skipped the map with exit 0), a sequence's
    frame file."""
    import bpy
    try:
        paths = bpy.utils.blend_paths(absolute=True, packed=False, local=False)
    except TypeError:
        paths = bpy.utils.blend_paths(absolute=True)
    paths = [p for p in paths if p and NB.UDIM_TOKEN not in p and NB.UVTILE_TOKEN not in p]
    walked = set()                  # (a kit of many objects shares a few sets of materials)
    for obj in bpy.data.objects:
        materials = tuple(s.material and data_key(s.material) for s in obj.material_slots)
        if obj.type == "MESH" and materials not in walked:
            walked.add(materials)
            paths += read_files(obj, viewport=True)     # (a render-mode pass per object: no)
    return sorted({str(Path(p).resolve()) for p in paths})


_OPENED = [None]        # the file this session opened last (a bake leaves it as it was)


def open_blend(path):
    """Open `path` unless this session opened it last and it is still the open file (every
    bake puts back what it touched); returns the seconds it took."""
    import bpy
    path = os.path.abspath(path)        # a symbolic link opened as one (plan.grouped_entries)
    if _OPENED[0] == path and bpy.data.filepath and os.path.abspath(bpy.data.filepath) == path:
        return 0.0
    t0 = time.perf_counter()
    from ..open_blend import open_mainfile
    open_mainfile(path)                  # scripts off, whatever the Preferences say
    _OPENED[0] = path
    return time.perf_counter() - t0


def run_request(request, log=lambda *_: None, before_publish=None):
    """Do one request in this session: {"op": "scan", blend, objects, collections} or
    {"op": "bake", blend, object, output, settings, tiles, empty_tiles, overwrite}. Returns the
    reply dict (status "ok", or "error" with kind "input" / "output" / "crash" and the
    message; only a crash is retried). before_publish({tile: (final, temporary file)}): the
    batch records the bake's files before they are put in place (normal_bake)."""
    t0, cpu0 = time.perf_counter(), time.process_time()
    reply = {"op": request["op"], "id": request.get("id")}
    try:
        load_s = open_blend(request["blend"]) if request.get("blend") else 0.0
        reply["load_s"] = load_s
        if request["op"] == "scan":
            reply.update(scan_open_file(request.get("objects"), request.get("collections"),
                                        request.get("everything", False)))
            reply["dependencies"] = dependencies_of_open_file()
        else:
            import bpy
            _fault(request)
            obj = bpy.data.objects.get(request["object"])
            if obj is None:
                raise NB.NormalBakeError(missing_object_problem(request["object"]))
            bake_request = BR.BakeRequest.from_settings(
                obj.name, request["output"], request["settings"], tiles=request.get("tiles"),
                empty_tiles=request.get("empty_tiles", "error"),
                overwrite=request.get("overwrite", False), threads=request.get("threads"))
            # warnings travel in the reply: the parent prints them once
            with interrupts.partials_of(request["output"]):     # a stop removes its temps
                res = BR.bake(bake_request, obj, log=log, warn=lambda *_: None,
                              before_publish=before_publish)
            _fault(request, "die-published-once")
            reply.update({"paths": {str(t): str(p) for t, p in res["paths"].items()},
                          "tiles": res["tiles"], "uv_map": res["uv_map"], "depth": res["depth"],
                          "warnings": res["warnings"], "bake_s": res["bake_s"],
                          "save_s": res["save_s"], "dependencies": dependencies_of_open_file()})
        reply["status"] = "ok"
    except (NB.NormalBakeError, BlendOpenError) as err:     # the same in a fresh process
        reply.update(status="error", kind="input", error=str(err))
    except MapNotWritten as err:                # a full disk: the same in a fresh process
        reply.update(status="error", kind="output", error=str(err))
    except Exception as err:                    # noqa: BLE001 - reported, retried once
        reply.update(status="error", kind="crash", error=f"{type(err).__name__}: {err}")
    reply["total_s"] = time.perf_counter() - t0
    reply["cpu_s"] = time.process_time() - cpu0      # every thread of this process (Cycles')
    return reply


def _fault(request, after=None):
    """Test hook (SURFGRAD_BATCH_FAULT): make this worker process die or hang on an asset
    (before its bake; with `after`, that kind once the map is in place)."""
    fault = os.environ.get(FAULT_ENV, "")
    if ":" in fault and request.get("in_worker"):
        kind, name = fault.split(":", 1)
        if name != request["object"]:
            return
        once = request.get("attempt") == 1
        if after is not None:
            if kind == after and once:
                os._exit(70)
            return
        if kind == "die" or (kind == "die-once" and once):
            os._exit(70)
        if kind == "hang":
            time.sleep(24 * 3600)
