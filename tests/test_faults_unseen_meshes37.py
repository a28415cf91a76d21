"""Red team 37c: `bake-normal-map` and `compare` on meshes and objects the project had not seen.

1. A UV map that a modifier writes in renders only, or in the viewport only (a Geometry Nodes
   Store Named Attribute of a 2D vector on face corners, e.g. a slow UV Unwrap kept out of the
   viewport), read by name by the material's Normal Map node: the check that refuses nodes
   naming a UV map the mesh lacks read the viewport's mesh, while the bake renders the render
   mesh. Before: the render-only UV map was refused, exit 2 ("reads UV map 'Auto', which mesh
   'Plane' does not have"), though Cycles bakes it; the viewport-only one passed and baked a
   flat map (every texel (0.502, 0.502, 1.0) in object space), exit 0. Now the check reads
   the mesh the bake renders (addon/image_checks.uv_reference_problems on bake_uvs.baked_mesh).
"""

import hashlib
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import exit_codes  # noqa: E402
from test_faults_scene_settings import _bake, _pixels, _scene, plain  # noqa: E402,F401

pytestmark = pytest.mark.tier("bake")


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _stored_uv_map(obj, name, render, viewport):
    """A Geometry Nodes modifier storing the vertices' x, y as UV map `name` (the plane lies
    on its UVs: the same UVs as 'UVMap'), on in renders and / or the viewport."""
    tree = bpy.data.node_groups.new("Store UV", "GeometryNodeTree")
    for side in ("INPUT", "OUTPUT"):
        tree.interface.new_socket("Geometry", in_out=side, socket_type="NodeSocketGeometry")
    inp, out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    store = tree.nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "FLOAT2", "CORNER"
    store.inputs["Name"].default_value = name
    value = next(s for s in store.inputs if s.name == "Value" and s.enabled)
    tree.links.new(tree.nodes.new("GeometryNodeInputPosition").outputs[0], value)
    tree.links.new(inp.outputs[0], store.inputs[0])
    tree.links.new(store.outputs[0], out.inputs[0])
    modifier = obj.modifiers.new("Store UV", "NODES")
    modifier.node_group = tree
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
