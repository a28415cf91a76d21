"""Red team 37c: `bake-normal-map` and `compare` on meshes and objects the project had not seen.

1. A UV map that a modifier writes in renders only, or in the viewport only (a Geometry Nodes
   Store Named Attribute of a 2D vector on face corners, e.g. a slow UV Unwrap kept out of the
   viewport), read by name by the material's Normal Map node: the check that refuses nodes
   naming a UV map the mesh lacks read the viewport's mesh, while the bake renders the render
   mesh. Before: the render-only UV map was refused, exit 2 ("reads UV map 'Auto', which mesh
   'Plane' does not have"), though Cycles bakes it; the viewport-only one passed and baked a
   flat map (every texel (0.502, 0.502, 1.0) in object space), exit 0. Now the check reads
   the mesh the bake renders (addon/image_checks.uv_reference_problems on bake_uvs.baked_mesh).
2. compare of a method with a detail layer (procedural-basis, the layered stacks) on a mesh
   whose "Detail" UV map a modifier removes (a Remove Named Attribute): the detail layer was
   given "Detail" from the mesh data, and the reference, reading the rendered mesh, failed.
   Before: exit 2 with a KeyError's text, "\"G: no UV map named 'Detail'; available:
   ['UVMap']\"". Now the layer reads the UV map, as on a mesh without "Detail", within the bar.
3. A mesh of a million faces (a scan, a sculpt): bake-normal-map's checks (the mesh as it
   renders, its UV tiles, its overlaps) ran 12 s with no line after Blender's "Read blend"
   (17.5 s in all at 16^2, 1.6 GB), and compare 69 s with none at all (32^2: bake 22.6 s,
   reference 8.2 s, 3.0 GB). Both finished right. Now each says it is still at work, as the
   bake itself did ("still checking Big: 15 s so far"; compare on stderr, as its bake holds
   stdout). Measured once on this 2-core machine; the test speeds the heartbeat up.
4. A UV map whose name is longer than 63 bytes (an importer's long name: every line names a UV
   map up to 67 bytes, 5.2 of any length), which Blender's bake operator and its UV Map and Normal
   Map nodes cut at 63. Before: bake-normal-map passed its checks and the bake failed, exit 1
   ("No UV layer named ... found in the object"), and compare stopped in its node builder
   ("ShaderNodeUVMap.uv_map reads back ..."). Now both refuse it first, naming the length and
   the fix (addon/bake_uvs.long_name_problem), exit 2.
5. A Geometry Nodes modifier that writes the bake's UV map anew (a Remove and a Store Named
   Attribute of 'UVMap', a second UV map beside it): up to 5.0 the rendered mesh's active UV
   map is then the other one, and Blender's bake takes its tangent frame from the active UV
   map, whatever UV map it is given. Before, on 4.2, 4.5 and 5.0: the tangent-space map was in
   the other map's frame (a quarter turn here: up to 0.49 off in the PNG's 0..1 against the
   same file without the modifier), exit 0; the object-space map was right. Now the bake goes
   through a copy of the render mesh with 'UVMap' active (addon/tangent_uv.py). Also: the
   render-mode pass left the view layer listing its stand-in camera as None (a raw
   AttributeError where the bake's next step read the selection). The checks read the
   rendered mesh once for the tangents and the node names alike: freezing a modified object
   takes two render-mode passes (its check, its bake), as before, and a batch's scan of a file
   one per object (two before this round).
6. An Empty that instances a collection (an asset placed as a collection instance) given as
   the object: refused as before, "object 'Shelf instance' is an empty, not a mesh: pick a
   mesh object", which did not say which objects to bake. Now the refusal names the
   collection it shows and that collection's mesh objects.
"""

import hashlib
import time
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import bake_console, bake_request, commands, exit_codes  # noqa: E402
from surfgrad_addon.addon.bake_uvs import baked_mesh, uv_active  # noqa: E402
from surfgrad_addon.addon.render_mesh import read_in_render_mode  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from test_faults_scene_settings import _bake, _pixels, _scene, plain  # noqa: E402,F401
from test_faults_unseen_meshes31 import _within_bar, empty_file  # noqa: E402,F401
from test_faults_unseen_meshes32 import _grid, _object  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _nodes_modifier(obj, name, node_type):
    """A Geometry Nodes modifier whose group runs the geometry through one node (returned
    with the group's tree, the input and output nodes)."""
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    for side in ("INPUT", "OUTPUT"):
        tree.interface.new_socket("Geometry", in_out=side, socket_type="NodeSocketGeometry")
    inp, out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    node = tree.nodes.new(node_type)
    tree.links.new(inp.outputs[0], node.inputs[0])
    tree.links.new(node.outputs[0], out.inputs[0])
    modifier = obj.modifiers.new(name, "NODES")
    modifier.node_group = tree
    return modifier, tree, node


def _stored_uv_map(obj, name, render, viewport):
    """A Geometry Nodes modifier storing the vertices' x, y as UV map `name` (the plane lies
    on its UVs: the same UVs as 'UVMap'), on in renders and / or the viewport."""
    modifier, tree, store = _nodes_modifier(obj, "Store UV", "GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "FLOAT2", "CORNER"
    store.inputs["Name"].default_value = name
    value = next(s for s in store.inputs if s.name == "Value" and s.enabled)
    tree.links.new(tree.nodes.new("GeometryNodeInputPosition").outputs[0], value)
    modifier.show_render, modifier.show_viewport = render, viewport


def _uv_written_by(tmp_path, where):
    """The plain file with its Normal Map node reading UV map 'Auto', which a modifier on in
    `where` only ('render' or 'viewport') writes."""
    _scene(tmp_path)
    obj = bpy.data.objects["Plane"]
    obj.active_material.node_tree.nodes["Normal Map"].uv_map = "Auto"
    _stored_uv_map(obj, "Auto", where == "render", where == "viewport")
    blend = tmp_path / f"{where}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    return blend


def test_a_uv_map_written_in_renders_only_is_baked(tmp_path, capsys, plain):
    """Before: refused, exit 2. Now the plain file's map, texel for texel ('Auto' holds the
    UVs of 'UVMap')."""
    blend = _uv_written_by(tmp_path, "render")
    before = _sha(blend)
    rc, err = _bake(capsys, blend, tmp_path / "n.png")
    assert rc == exit_codes.OK, err[-2000:]
    assert np.abs(_pixels(tmp_path / "n.png") - plain).max() <= 1.5 / 255
    assert _sha(blend) == before


def test_a_uv_map_written_in_the_viewport_only_is_refused(tmp_path, capsys):
    """Before: a flat map, exit 0. Now refused, naming the node, the UV map, the rendered
    mesh's UV maps and the fix; nothing written."""
    blend = _uv_written_by(tmp_path, "viewport")
    before = _sha(blend)
    rc, err = _bake(capsys, blend, tmp_path / "n.png")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert ("node 'Normal Map' (material 'Mat') reads UV map 'Auto', which mesh 'Plane' as it "
            "renders (its modifiers at their render settings) does not have (UV maps: "
            "['UVMap']): the bake would read nothing there; pick one of its UV maps in the "
            "node, or rename the UV map") in err
    assert "Traceback" not in err
    assert not (tmp_path / "n.png").exists() and _sha(blend) == before


def test_compare_reads_the_detail_layer_through_a_uv_map_the_render_has(empty_file):
    """2. Before: KeyError "G: no UV map named 'Detail'" (exit 2 from the command line)."""
    obj = _object("G", [_grid()])
    detail = obj.data.uv_layers.new(name="Detail")
    uv = np.empty(len(obj.data.loops) * 2)
    obj.data.uv_layers["UVMap"].data.foreach_get("uv", uv)
    detail.data.foreach_set("uv", 2.0 * uv)
    _, _, remove = _nodes_modifier(obj, "Remove Detail", "GeometryNodeRemoveAttribute")
    remove.inputs["Name"].default_value = "Detail"
    _within_bar(compare.compare(obj, "procedural-basis", 32), 300)


def _slowed(monkeypatch, module, name):
    """module.name made to take 0.3 s more; heartbeats every 0.02 s."""
    monkeypatch.setattr(bake_console, "HEARTBEAT_S", 0.02)
    run = getattr(module, name)

    def slow(*args, **kwargs):
        time.sleep(0.3)
        return run(*args, **kwargs)
    monkeypatch.setattr(module, name, slow)


def test_long_checks_and_compares_say_they_are_at_work(tmp_path, capsys, monkeypatch):
    """3. Before: no line while the checks or the compare ran."""
    blend = _scene(tmp_path)
    _slowed(monkeypatch, bake_request, "check")
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(tmp_path / "n.png"), "--resolution", "16"])
    out = capsys.readouterr().out
    assert rc == exit_codes.OK
    assert "      still checking Plane: 0 s so far" in out.splitlines(), out
    _slowed(monkeypatch, compare, "compare")
    compare.run(None, "Plane", "normal-map", 16, tmp_path / "c.json", from_open_file=True,
                log=lambda *_: None)
    assert "surfgrad: still comparing normal-map on Plane: 0 s so far" in \
        capsys.readouterr().err.splitlines()


def test_a_uv_map_name_longer_than_the_bake_takes_is_refused_first(tmp_path, capsys):
    """4. Before: exit 1 after the checks; compare's BuildError."""
    import _bpy
    for rna, name in ((_bpy.ops.get_rna_type("OBJECT_OT_bake"), "uv_layer"),
                      (bpy.types.ShaderNodeNormalMap.bl_rna, "uv_map")):
        assert rna.properties[name].length_max == 64       # 63 bytes and the closing zero
    blend = _scene(tmp_path)
    obj = bpy.data.objects["Plane"]
    layer = obj.data.uv_layers["UVMap"]
    layer.name = "U" * 1000                  # the line's limit: 67 bytes up to 5.0, none on 5.2
    assert len(layer.name) == (1000 if bpy.app.version >= (5, 2, 0) else 67)
    layer.name = "U" * 66
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    said = (f"UV map {'U' * 66!r} of object 'Plane' has a name of 66 bytes, longer than "
            f"Blender's bake and its UV Map and Normal Map nodes take (63 bytes): they cut it "
            f"short and find no such UV map; rename it (Object Data > UV Maps) to 63 bytes or "
            f"fewer")
    before = _sha(blend)
    rc, err = _bake(capsys, blend, tmp_path / "n.png")
    assert rc == exit_codes.BAD_REQUEST, err[-2000:]
    assert said in err and "Traceback" not in err
    assert not (tmp_path / "n.png").exists() and _sha(blend) == before
    with pytest.raises(compare.CompareError) as error:
        compare.compare(bpy.data.objects["Plane"], "normal-map", 16)
    assert str(error.value) == said


def _explicit_uvs(tmp_path, name, rewrite):
    """The plain file with a second UV map (the first turned a quarter), the material reading
    'UVMap' by name in both nodes; `rewrite`: a modifier writes 'UVMap' anew (its same UVs)."""
    _scene(tmp_path)
    obj = bpy.data.objects["Plane"]
    mesh = obj.data
    uv = np.empty(len(mesh.loops) * 2)
    mesh.uv_layers["UVMap"].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    mesh.uv_layers.new(name="Second").data.foreach_set(
        "uv", np.stack([uv[:, 1], 1.0 - uv[:, 0]], -1).ravel())
    mesh.uv_layers.active = mesh.uv_layers["UVMap"]
    tree = obj.active_material.node_tree
    tree.nodes["Normal Map"].uv_map = "UVMap"
    node = tree.nodes.new("ShaderNodeUVMap")
    node.uv_map = "UVMap"
    tree.links.new(node.outputs[0], tree.nodes["Image Texture"].inputs["Vector"])
    if rewrite:
        _, tree, remove = _nodes_modifier(obj, "Rewrite UV", "GeometryNodeRemoveAttribute")
        remove.inputs["Name"].default_value = "UVMap"
        store = tree.nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type, store.domain = "FLOAT2", "CORNER"
        store.inputs["Name"].default_value = "UVMap"
        value = next(s for s in store.inputs if s.name == "Value" and s.enabled)
        tree.links.new(tree.nodes.new("GeometryNodeInputPosition").outputs[0], value)
        tree.links.new(remove.outputs[0], store.inputs[0])
        tree.links.new(store.outputs[0], tree.nodes["Group Output"].inputs[0])
    blend = tmp_path / f"{name}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    return blend


def test_a_uv_map_a_modifier_writes_anew_keeps_its_tangent_frame(tmp_path, capsys):
    """5. The map of the file with the modifier is the one without, texel for texel (before:
    0.49 off on 4.2 to 5.0); the object and the file are as they were."""
    rc, err = _bake(capsys, _explicit_uvs(tmp_path, "plain", False), tmp_path / "plain.png")
    assert rc == exit_codes.OK, err[-2000:]
    blend = _explicit_uvs(tmp_path, "rewritten", True)
    obj = bpy.data.objects["Plane"]
    with uv_active(obj.data, "UVMap"):          # why: the line's rendered active UV map
        assert baked_mesh(obj).active_uv == ("UVMap" if bpy.app.version >= (5, 2, 0)
                                             else "Second")
    before = _sha(blend)
    rc, err = _bake(capsys, blend, tmp_path / "n.png")
    assert rc == exit_codes.OK, err[-2000:]
    assert np.abs(_pixels(tmp_path / "n.png") - _pixels(tmp_path / "plain.png")).max() <= \
        1.5 / 255
    obj = bpy.data.objects["Plane"]
    assert obj.data.name == "Plane" and obj.modifiers[0].show_render
    assert obj.data.uv_layers.active.name == "UVMap" and _sha(blend) == before


def test_the_render_mode_pass_leaves_no_stale_camera_in_the_view_layer(empty_file):
    """5. Before: [<the object>, None]."""
    obj = _object("G", [_grid()])
    read_in_render_mode(obj, lambda depsgraph: None)
    assert list(bpy.context.view_layer.objects) == [obj]


def test_freezing_or_scanning_a_modified_object_reads_its_rendered_mesh_once_per_step(
        empty_file, monkeypatch):
    """5. Freeze's check (its tiles, the node names) and its bake (its plan, the tangents' UV
    map) each read it once (read apart: four render-mode passes); a batch's scan once (its
    tiles, mesh and node names: three read apart)."""
    from surfgrad_addon.addon import freeze, render_mesh
    from surfgrad_addon.addon.batch import session
    from support.materials import diffuse_material
    passes, real = [], render_mesh.read_in_render_mode
    monkeypatch.setattr(render_mesh, "read_in_render_mode",
                        lambda *a, **k: passes.append(1) or real(*a, **k))
    obj = _object("G", [_grid()])
    obj.modifiers.new("Subdivision", "SUBSURF")
    mat, _, _ = diffuse_material("M")
    obj.data.materials.append(mat)
    api.add_layer_stack(mat)
    freeze.freeze(obj, resolution=16)
    assert len(passes) == 2
    passes.clear()
    assert session.scan_open_file(objects=["G"])["assets"][0]["problems"] == []
    assert len(passes) == 1


def test_an_empty_showing_a_collection_names_the_meshes_to_bake(empty_file, tmp_path):
    """6. compare and the bake alike (bake_target.object_not_a_mesh)."""
    shelf = bpy.data.collections.new("Shelf")
    shelf.objects.link(_object("Rock", [_grid()]))
    bpy.context.scene.collection.objects.unlink(bpy.data.objects["Rock"])
    empty = bpy.data.objects.new("Shelf instance", None)
    empty.instance_type, empty.instance_collection = "COLLECTION", shelf
    bpy.context.scene.collection.objects.link(empty)
    shows = "; it shows collection 'Shelf', whose mesh object(s) ['Rock'] are what to bake"
    with pytest.raises(compare.CompareError) as error:
        compare.compare(empty, "normal-map", 16)
    assert str(error.value) == f"object 'Shelf instance' is an empty, not a mesh: pick a mesh " \
        f"object{shows}"
    with pytest.raises(ValueError) as error:
        api.bake_normal_map(empty, str(tmp_path / "n.png"), resolution=16)
    assert "object 'Shelf instance' is an empty, not a mesh: pick a mesh object to bake " \
        f"(--object NAME){shows}" in str(error.value)
