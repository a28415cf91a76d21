"""Red team 59i: a hostile review of round 59's merges (sculpt_normals.own_normals, the colour
facts' scaled copy, preview_links, command_line.end_script).

1. compare (harness api compare / compare_object) of an object in Sculpt Mode that is
   disabled in viewports (Object Properties > Visibility > Show in Viewports off, or the
   outliner's monitor icon, while sculpting; a script's session): own_normals (rt59e) takes
   it out of Sculpt Mode with bpy.ops.object.mode_set, whose poll refuses a hidden object,
   so compare raised a raw RuntimeError ("Operator bpy.ops.object.mode_set.poll() Cannot
   edit hidden object"), no report (5.2; the bake was fine, its visible_for_bake shows the
   object first). Now own_normals shows the object for the mode switch alone: compare gives
   p99 0.0003 deg as in Object Mode, the object is in Sculpt Mode after and still disabled
   in viewports. (A .blend saved so opens in Object Mode: a live session's case only.)
2. bake-normal-map (api, Freeze, bake-batch) of a material with a colour into the Surface and
   a Principled Volume linked into the Volume (a glow/fog material; no BSDF anywhere):
   preview_links (rt59h) counted every shader node as "left unlinked", the linked volume
   too, and refused it as a preview ("'Principled Volume' is left unlinked: link the BSDF
   back to the Surface"), a fix that does not exist (before rt59h it baked, exit 0, the
   surface's own normal, which is what Cycles renders). Now a shader node is left aside only
   where the rendered Material Output does not read it: it bakes, every texel within 0.5 deg
   of flat; a BSDF still linked into an EEVEE-only output, or into a dangling reroute, is
   still a preview, refused (pinned too).
3. The blue and alpha warnings of a byte map above 2048^2 texels (float_pixels.colour_facts,
   rt59f) counted a copy (Image.copy, scaled), which reloads the image's file, packed data or
   generator, not the pixels the image holds: a map painted or set by a script and not saved
   (is_dirty) was judged by its old pixels, and Cycles bakes the new ones. A 4096 x 2048
   UV Grid image filled with flat normals (0.5, 0.5, 1) warned "about 52% of its texels with
   blue at or below 0.5 ... rebuild blue"; a PNG saved with blue 0.3, then painted flat,
   "about 100%" (and the reverse: a flaw painted in, unsaved, went unseen). Now an image
   with unsaved pixels is read in full (as below 2048^2): no warning; no image left behind.

Probed and fine on 5.2 (compare normal-map of a bent 6 x 5 grid at 32^2, p99 0.0003 deg as
the plain file's; mode, active object, data read back unchanged): the mesh shared with a
second object in Sculpt Mode (the first compared); the object in Sculpt Mode not the active
one (the active object given back); hide_set and its collection disabled in viewports; shape
keys (the active one not the Basis, Shape Key Lock on: the key's data, the active index and
the lock unchanged); Multires at sculpt level 1 of 2 (levels, sculpt and render levels, the
vertex count unchanged); Dyntopo on (still on after); custom split normals in Sculpt Mode
through the bake (kept, within 0); another scene active (refused by name).
"""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import asset_scenes as A, compare  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 32
BAR_P99, BAR_MAX = 0.1, 0.5          # compare-all's bar for a correct group


@pytest.fixture
def empty_file():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy


def _sculpted_grid():
    obj = A._link("Grid", A._grid("Grid", nx=6, ny=5, bend=0.35))
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="SCULPT")
    assert obj.mode == "SCULPT"
    return obj


def test_compare_of_an_object_in_sculpt_mode_disabled_in_viewports(empty_file):
    obj = _sculpted_grid()
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    obj.hide_viewport = True
    # Before: RuntimeError "Operator bpy.ops.object.mode_set.poll() Cannot edit hidden object".
    report = compare.compare(obj, "normal-map", RES)
    assert report["p99_deg"] < BAR_P99 and report["max_deg"] < BAR_MAX, report["p99_deg"]
    assert report["texels_compared"] > 100
    assert obj.mode == "SCULPT" and obj.hide_viewport
    assert bpy.context.view_layer.objects.active == obj
    after = np.empty_like(co)
    obj.data.vertices.foreach_get("co", after)
    assert np.array_equal(after, co)


def test_a_colour_into_the_surface_beside_a_volume_is_no_preview(empty_file, tmp_path):
    """Finding 2: a glow material (a colour into the Surface, a Principled Volume into the
    Volume; no BSDF anywhere) bakes the surface's own normal, as Cycles renders it."""
    from surfgrad_addon import api
    obj = A._link("Grid", A._grid("Grid", nx=6, ny=5, bend=0.35))
    mat = bpy.data.materials.new("Glow")
    if bpy.app.version < (5, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        if n.bl_idname != "ShaderNodeOutputMaterial":
            nt.nodes.remove(n)
    out = nt.nodes["Material Output"]
    rgb, vol = nt.nodes.new("ShaderNodeRGB"), nt.nodes.new("ShaderNodeVolumePrincipled")
    nt.links.new(rgb.outputs[0], out.inputs["Surface"])
    nt.links.new(vol.outputs[0], out.inputs["Volume"])
    obj.data.materials.append(mat)
    path = tmp_path / "glow.exr"
    # Before: NormalBakeError "... 'Principled Volume' is left unlinked: link the BSDF back".
    api.bake_normal_map(obj, path, resolution=RES, samples=1, margin=0, log=None)
    img = bpy.data.images.load(str(path))
    try:
        img.colorspace_settings.is_data = True
        px = np.array(img.pixels[:], dtype=np.float64).reshape(-1, 4)[:, :3]
    finally:
        bpy.data.images.remove(img)
    n = px[np.abs(px).sum(1) > 0] * 2 - 1
    assert len(n) > 100
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    deg = np.degrees(np.arccos(np.clip(n[:, 2], -1, 1)))       # tangent space: +Z is flat
    assert deg.max() < 0.5, deg.max()


def _painted(img, rgb):
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    px.reshape(-1, 4)[:] = (*rgb, 1.0)
    img.pixels.foreach_set(px)


@pytest.mark.parametrize("source", ["generated uv grid", "saved file"])
def test_a_large_byte_map_painted_unsaved_is_judged_by_its_pixels(empty_file, tmp_path, source):
    """Finding 3: the colour facts of a byte map above 2048^2 (the blue and alpha warnings)
    judge the pixels Cycles bakes, not a copy reloaded from the file or generator."""
    from surfgrad_addon.addon import normal_map_checks as NC
    img = bpy.data.images.new("Painted", 4096, 2048)
    if source == "saved file":
        _painted(img, (0.9, 0.2, 0.3))              # saved with blue 0.3: would warn
        img.filepath_raw = str(tmp_path / "painted.png")
        img.file_format = "PNG"
        img.save()
    else:
        img.generated_type = "UV_GRID"              # about half its texels blue <= 0.5
    _painted(img, (0.5, 0.5, 1.0))                  # flat normals, unsaved
    assert img.is_dirty
    # Before: "has about 50% (grid) / 100% (file) of its texels with blue at or below 0.5".
    assert NC.blue_problem(img) is None
    names = [i.name for i in bpy.data.images]
    assert names == ["Painted"], names


@pytest.mark.parametrize("aside", ["bsdf linked to the eevee output", "through a reroute"])
def test_a_preview_is_still_refused_where_the_bsdf_is_linked_elsewhere(empty_file, tmp_path,
                                                                       aside):
    """Finding 2's fix counts a shader as left aside unless the rendered output reads it: a
    BSDF still linked into an EEVEE-only output, or left feeding a reroute, is a preview."""
    from surfgrad_addon import api
    obj = A._link("Grid", A._grid("Grid", nx=6, ny=5, bend=0.35))
    mat = bpy.data.materials.new("Rock")
    if bpy.app.version < (5, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    out, bsdf = nt.nodes["Material Output"], nt.nodes["Principled BSDF"]
    if aside == "through a reroute":
        reroute = nt.nodes.new("NodeReroute")
        nt.links.new(bsdf.outputs[0], reroute.inputs[0])
    else:
        out.target = "CYCLES"
        eevee = nt.nodes.new("ShaderNodeOutputMaterial")
        eevee.target = "EEVEE"
        nt.links.new(bsdf.outputs[0], eevee.inputs["Surface"])
    rgb = nt.nodes.new("ShaderNodeRGB")
    nt.links.new(rgb.outputs[0], out.inputs["Surface"])          # the preview
    obj.data.materials.append(mat)
    path = tmp_path / "m.exr"
    with pytest.raises(ValueError) as err:
        api.bake_normal_map(obj, path, resolution=RES, samples=1, margin=0, log=None)
    assert "preview" in str(err.value) and "'Rock'" in str(err.value)
    assert not path.exists()
