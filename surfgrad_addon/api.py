"""surfgrad's Python API for scripts and pipeline TDs (needs bpy).

    from surfgrad_addon import api          # from a checkout
    tree = api.node_group("SG Normal Map", uv_map="Detail")
    nodes = api.add_layer_stack(bpy.data.materials["Rock"], uv_map="UVMap")
    api.update_precise_far(bpy.data.objects["Rock"])   # Precise Far From Origin by distance
    api.bake_normal_map(bpy.data.objects["Rock"], "rock_nrm.exr", space="tangent")
    api.bake_normal_map(rock, "rock_nrm.<UDIM>.png", samples=16, depth="16")   # UDIM tiles
    report = api.bake_batch(["a.blend", "b.blend"], "maps/{file}/{object}.<UDIM>.png",
                            resolution=2048, samples=16, workers=2)

From an installed extension the same module is `bl_ext.<repo>.surfgrad.api`: it offers only
what the extension does (no harness behind it). The bake-against-reference comparison is the
harness's: `surfgrad_addon.harness.api.compare`, in a checkout. Every function raises
ValueError (or a subclass) with a message that names the problem and the fix.
"""

from contextlib import contextmanager as _contextmanager

from .addon import groups as _groups
from .addon.bake_request import BakeRequest as _Request
from .reference.input_checks import plain_number as _plain

# Options of the groups that take them: name -> the builder's keyword arguments.
_OPTIONS = {
    "SG Normal Map": ("uv_map",),
    "SG Procedural Basis": ("uv_map",),
    "SG Height Map HQ": ("image", "variant", "extension"),
    "SG Height Map Forward": ("filter_width",),
    "SG Triplanar Height": ("image", "extension", "images"),
    "SG Parallax": ("image", "extension"),
}


def group_names():
    """Every group the Add menus offer, shader groups first, in menu order."""
    return [name for name, _ in _groups.MENU_GROUPS] + \
        [name for name, _ in _groups.GEOMETRY_MENU_GROUPS]


def _image(value):
    """An image option: a bpy Image, or the name of one in this file."""
    import bpy
    if value is None or isinstance(value, bpy.types.Image):
        return value
    if isinstance(value, str) and value in bpy.data.images:
        return bpy.data.images[value]
    raise ValueError(f"image {value!r}: give an image of this file (bpy.data.images[name]) "
                     f"or its name" + ("; there is no image of that name"
                                       if isinstance(value, str) else ""))


def _check_uv_map(uv_map):
    import bpy
    longest = bpy.types.ShaderNodeNormalMap.bl_rna.properties["uv_map"].length_max - 1
    if not isinstance(uv_map, str):
        raise ValueError(f"uv_map {uv_map!r}: give the UV map's name (a string)")
    if len(uv_map.encode()) > longest:         # Blender would cut it: another map's name
        raise ValueError(f"uv_map {uv_map!r} is longer than a UV map's name can be "
                         f"({longest} bytes)")


def _checked(options):
    """The options with image names resolved; ValueError for a value no group takes (the
    builders would fail with an AttributeError or a RuntimeError of their own)."""
    import math
    import bpy
    out = dict(options)
    if "image" in out:
        out["image"] = _image(out["image"])
    if out.get("images") is not None:
        out["images"] = [_image(v) for v in out["images"]]
    if "uv_map" in out:
        _check_uv_map(out["uv_map"])
    if "extension" in out:
        allowed = [i.identifier for i in bpy.types.ShaderNodeTexImage.bl_rna
                   .properties["extension"].enum_items]
        if out["extension"] not in allowed:
            raise ValueError(f"extension {out['extension']!r}: use one of "
                             f"{', '.join(allowed)}")
    if out.get("filter_width") is not None:
        fw = out["filter_width"] = _plain(out["filter_width"])
        if isinstance(fw, bool) or not isinstance(fw, (int, float)) or \
                not math.isfinite(fw) or fw <= 0:
            raise ValueError(f"filter_width {fw!r}: give a positive number (the Bump node's "
                             f"Filter Width, in differentials; None for the default)")
    return out


def node_group(name, **options):
    """The node tree of group `name`, built (or updated in place) if needed. Options:
    SG Normal Map and SG Procedural Basis `uv_map` (the per-map group, "<name> [<map>]");
    SG Height Map HQ `image`, `variant` ('hq' or 'one-texel'), `extension`; SG Height Map
    Forward `filter_width`; SG Triplanar Height `image` (or `images`, three), `extension`;
    SG Parallax `image`, `extension`. An image is a bpy Image or the name of one."""
    builders = dict(_groups.MENU_GROUPS) | dict(_groups.GEOMETRY_MENU_GROUPS)
    if name not in builders:
        raise ValueError(f"no surfgrad group named {name!r}; the groups are "
                         f"{', '.join(group_names())}")
    allowed = _OPTIONS.get(name, ())
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ValueError(f"{name} takes no option {', '.join(unknown)}"
                         + (f"; it takes {', '.join(allowed)}" if allowed else ""))
    reason = _groups.unavailable_reason(name)
    if reason:
        raise _groups.FeatureUnavailable(reason)
    with _rebuild_notes():
        return builders[name](**_checked(options))


@_contextmanager
def _rebuild_notes():
    """Warn on stderr, as the bakes do, of what the groups' rebuilds in the block could not
    carry over (a renamed socket's link, an edit inside an older group): the operators
    report these; a script's caller heard nothing."""
    from .addon.bake_request import warn_stderr
    from .addon.node_builder import take_notes
    take_notes()                               # an earlier caller's, not this call's
    yield
    for text in take_notes():
        warn_stderr(text)


def add_layer_stack(material, uv_map=""):
    """SG Normal Map -> SG Combine -> SG Resolve wired into the material's BSDF Normal (as the
    Add Surface-Gradient Layer Stack operator does). Returns the new nodes by role, "replaced"
    and "uv_map": with no uv_map given, the UV map kept from a replaced tangent-space Normal
    Map node ("" if none)."""
    from .addon import operators
    if material is None or getattr(material, "node_tree", None) is None:
        raise ValueError("give a material that uses nodes")
    _check_uv_map(uv_map)
    with _rebuild_notes():
        return operators.add_layer_stack(material.node_tree, uv_map)


def update_precise_far(obj):
    """Switch the Precise Far From Origin input of every surfgrad group node in obj's materials
    on where obj reaches farther than 64 m from the origin, off nearer (off, the groups' precise
    route costs nothing at render time). Returns how many group nodes were set."""
    from .addon.far_precision import PRECISE_FAR, needs_precise_far, set_precise_far
    if obj is None or not hasattr(obj, "material_slots"):
        raise ValueError("give an object with material slots")
    materials = [slot.material for slot in obj.material_slots
                 if slot.material is not None and slot.material.node_tree is not None]
    # A linked material takes the values but never saves them: refuse before setting any.
    linked = sorted({m.name for m in materials if not m.is_editable and any(
        n.bl_idname == "ShaderNodeGroup" and PRECISE_FAR.name in n.inputs
        for n in m.node_tree.nodes)})
    if linked:
        from .addon.material_inputs import linked_text
        raise ValueError(linked_text(f"material {linked[0]!r}"))
    on = needs_precise_far(obj)
    return sum(set_precise_far(m.node_tree, on) for m in materials)


def _quiet(*_args, **_kwargs):
    """log=None: say nothing."""


# The defaults are the bake request's (addon/bake_request.py), written once there.
def bake_normal_map(obj, output, space=_Request.space, resolution=_Request.resolution,
                    uv_map=_Request.uv_map, margin=_Request.margin,
                    overwrite=_Request.overwrite, log=print, samples=_Request.samples,
                    depth=_Request.depth, tiles=_Request.tiles,
                    allow_partial=_Request.allow_partial):
    """Bake obj's own materials into a tangent- or object-space normal map (.png or .exr),
    restoring every setting it touches. With <UDIM> in the output name: one file per tile that
    holds UVs (or per tile of `tiles`). samples: per texel (anti-aliasing); depth: '8'/'16'
    (PNG), 'half'/'float' (EXR); allow_partial: bake a layout with faces outside the UDIM
    range (warned on stderr) instead of refusing it. The request is checked first
    (addon/bake_request.py): a BakeRequestError (a ValueError) names every problem, and
    nothing is written. Returns the written path (the name with <UDIM> for tiles). log: called
    with each progress line (None: quiet); an exception it raises reaches the caller as
    raised (after '[3/3] wrote' the map is in place: a note on it says so). Numbers may be
    numpy integers or floats."""
    from pathlib import Path
    from .addon.bake_request import BakeRequestError, bake
    from .addon.normal_bake import brace_token_problem
    if obj is None or not hasattr(obj, "name"):
        raise ValueError("give a mesh object to bake")
    problem = brace_token_problem(output, "api.bake_normal_map", "api.bake_batch")
    if problem:                           # as the command line's (one check, shared)
        raise BakeRequestError([problem])
    request = _Request(obj.name, str(output), space, _plain(resolution), uv_map, _plain(margin),
                       _plain(samples), depth, tiles, overwrite=overwrite,
                       allow_partial=allow_partial)
    bake(request, obj=obj, log=log or _quiet)
    return Path(output)


def bake_batch(blends=None, output="{file}_{object}.<UDIM>.png", objects=None,
               collections=None, settings_file=None, workers=1, force=False, overwrite=False,
               manifest=None, tiles=None, log=print, **settings):
    """Bake many assets into normal maps named by the `output` pattern ({file}, {object},
    {uv}, <UDIM>). blends: .blend paths (each may end in ':Object'; one path alone too), baked
    in `workers` separate Blender processes (the open file is not touched; workers=0 opens
    them in this session: refused with the interface or a file open); None bakes the open,
    saved file in this session. objects / collections: names (or the objects / collections
    themselves) to pick in every file (default: every mesh object with a material).
    settings: uv_map, space, resolution, samples, margin, depth (defaults for every asset;
    settings_file adds per-asset ones). Unchanged assets are skipped unless force. Returns
    the report (also written to the manifest): per asset status baked / skipped / failed,
    settings, timings, warnings, files. Raises ValueError for bad input of the whole call."""
    import os
    import bpy
    from .addon import batch
    unknown = sorted(set(settings) - set(batch.SETTING_KEYS))
    if unknown:
        raise ValueError(f"bake_batch takes no setting {', '.join(unknown)}; the settings are "
                         f"{', '.join(batch.SETTING_KEYS)}")
    # One file, object or collection given alone (a string was taken letter by letter).
    blends = [blends] if isinstance(blends, (str, os.PathLike)) else blends
    objects, collections = ([v] if isinstance(v, str) or hasattr(v, "name") else v
                            for v in (objects, collections))
    # (is_dirty cannot tell: a fresh file is dirty up to 5.0)
    if blends is not None and _plain(workers) == 0 and (bpy.data.filepath or
                                                        not bpy.app.background):
        raise ValueError(f"workers=0 bakes in this session, opening each .blend in place of "
                         f"the open file {bpy.data.filepath or '(unsaved)'!r} (its unsaved "
                         f"changes lost, your objects gone): give workers=1 or more (separate "
                         f"Blender processes), or blends=None to bake the open file")
    names = [o if isinstance(o, str) else o.name for o in objects or ()] or None
    colls = [c if isinstance(c, str) else c.name for c in collections or ()] or None
    settings = {key: _plain(value) for key, value in settings.items()}
    return batch.bake_batch(blends or (), output, names, colls, settings, settings_file,
                            _plain(workers), force, overwrite, manifest, tiles,
                            open_file=blends is None, log=log or _quiet)


def __getattr__(name):
    # compare moved to the harness, which the extension does not ship; say where it went
    # rather than import it (the API offers only what an installed extension can do).
    if name == "compare":
        raise AttributeError("surfgrad_addon.api.compare moved to surfgrad_addon.harness.api."
                             "compare: it needs the proving harness, which only a checkout of "
                             "the repository has (python -m surfgrad_addon compare ...)")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
