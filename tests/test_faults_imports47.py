"""Red team 47c: the product on assets other importers make (FBX through Blender's bundled
add-on, USD, Collada on the lines that still have it, castle-engine/demo-models' and assimp's
files, .blend files saved by Blender 2.45 to 4.3 elsewhere); each finding is built here by
code, a few faces, so no test reads a fetched file.

1. A material with a node tree but Use Nodes off (up to 4.5: an old file's, or an artist's
   switch; Cycles renders it without the tree): the check refused a material without a tree
   but passed this one, and Blender's bake then found no image to write ("No active image
   found"): bake-normal-map failed after its checks, exit 1, "Blender gave no reason (check
   its materials and modifiers)", on 4.2 and 4.5. Now refused before baking, exit 2, naming
   the material and the fix (material_inputs.no_tree_problem, compat.renders_nodes).
   From 5.0 Use Nodes is deprecated and always on (setting it off does nothing), pinned.
2. Freeze of an object with another material that has no node tree (4.2, 4.5: a material of
   an old file, or made by a script, never given Use Nodes): the bake puts an image node in
   every material of the object, and Freeze checked only the frozen one, so it ended in a raw
   "AttributeError: 'NoneType' object has no attribute 'nodes'" from deep in the bake. Now
   refused before baking, naming that material and the fix, as bake-normal-map refuses it
   (freeze._treeless_problems); from 5.0 every material has a tree, and the freeze is done.
3. A flat quad whose two triangles' normals Cycles computes bitwise equal and Blender not (or
   the other way round: -0.0 against 0.0 in one component): MikkTSpace welds corners whose
   normals are bitwise equal, and the reference's temporary mesh took Blender's face normal of
   each flat triangle where Cycles 5.2 feeds its own (Mesh::Triangle::compute_normal), so the
   two welded the quad's diagonal differently. A blade of castle-engine's chopper (an Array of
   2.4x quads, each UV'd to the whole square): compare called a correct SG Normal Map p99 26.8
   / max 29.9 degrees wrong, exit 0; one of its quads, built here at its height and mirrored
   at z = 0, the same on 5.2. Now on 5.2 the temporary mesh takes Cycles' float32 triangle normals
   (mesh_data.cycles_triangle_normals): within the bar, the blade too. 5.0 and 4.5 followed in
   round 48c (test_faults_flat_welds48.py); on 4.2 the mirrored quad at z = 0 cannot be
   welded as Cycles does, and compare refuses it (round 49a: harness/flat_welds.py).
4. Which importers each line has, pinned (a TD's script calls them by name): USD, Alembic,
   OBJ, PLY, STL on every line; FBX and glTF as bundled add-ons (`import_scene.fbx` exists
   only once io_scene_fbx is enabled); Collada (`wm.collada_import`) on 4.2 and 4.5 only,
   removed in 5.0; X3D on no line (an extension from 4.2 on).
"""

import warnings

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import freeze as F  # noqa: E402
from surfgrad_addon.addon.bake_request import BakeRequestError  # noqa: E402
from surfgrad_addon.harness import compare  # noqa: E402
from test_faults_freeze44 import SQUARE, _quads, _tree_state  # noqa: E402
from test_faults_unseen_meshes31 import _object, _within_bar  # noqa: E402
from test_faults_assets44 import RES, _baked_normals, _tilted_plane  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def test_a_material_with_use_nodes_off_is_refused_before_baking(tmp_path):
    """Finding 1: refused, naming the material, nothing written (4.2, 4.5); from 5.0 the
    switch is a no-op and the map is the material's (60 degrees, as fed)."""
    obj, mat, normal = _tilted_plane("ShaderNodeBsdfPrincipled")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)     # 5.0 on
        mat.use_nodes = False
        switched_off = not mat.use_nodes
    assert switched_off == (bpy.app.version < (5, 0, 0))
    out = tmp_path / "n.exr"
    if not switched_off:
        got = _baked_normals(obj, out)
        assert np.degrees(np.arccos(np.clip(got @ normal, -1.0, 1.0))).max() < 0.05
        return
    with pytest.raises(BakeRequestError, match="material 'Imported' has Use Nodes off"):
        api.bake_normal_map(obj, str(out), resolution=RES, margin=0, log=None)
    assert list(tmp_path.iterdir()) == []


def test_freeze_refuses_another_material_without_a_node_tree(fresh):
    """Finding 2: quad 2's material 'Old' has no tree where the line allows it (before 5.0):
    refused naming it, the stack as it was; from 5.0 it has one, and the freeze is done."""
    obj, mat = _quads(fresh, [SQUARE, SQUARE])
    old = bpy.data.materials.new("Old")
    obj.data.materials.append(old)
    obj.data.polygons[1].material_index = 1
    assert (old.node_tree is None) == (bpy.app.version < (5, 0, 0))
    before = _tree_state(mat)
    if old.node_tree is not None:
        F.freeze(obj, 16)
        assert F.RECORD in mat
        return
    with pytest.raises(F.FreezeError, match="^material 'Old' has no node tree"):
        F.freeze(obj, 16)
    assert _tree_state(mat) == before


# A quad of the chopper's blade (object space, as the file has it, at its height z = 0.11259):
# its triangles' Blender face normals are (1.5e-7, 0, -1) and (0, 0, -1), Cycles' both
# (0, 0, -1). At z = 0 and mirrored (its corners reversed), Blender's are equal and Cycles'
# differ in the sign of a zero.
BLADE = [(0.15449, 0.33284), (0.24313, 0.37922), (0.28552, 0.34841), (0.26882, 0.24978)]


@pytest.mark.parametrize("z, order", [(0.11259, (0, 1, 2, 3)), (0.0, (0, 3, 2, 1))])
def test_a_flat_quad_welds_its_diagonal_as_cycles_does(fresh, z, order):
    """Finding 3 (before, on 5.2, each: p99 26.8 / max 29.9 degrees). On 4.2 the mirrored
    quad at z = 0 (its triangles' normals equal in Blender's form, not in Cycles') cannot be
    welded as Cycles does (round 48c: p99 26.8 deg there); since round 49a compare refuses it,
    its every texel (the whole UV square: 32^2) being one it would have to leave out
    (harness/flat_welds.py)."""
    uvs = {0: (0.0, 0.0), 1: (1.0, 0.0), 2: (1.0, 1.0), 3: (0.0, 1.0)}
    obj = _object("Blade", [(x, y, z) for x, y in BLADE], [order], [uvs[i] for i in order],
                  smooth=False)
    obj.data.materials.append(bpy.data.materials.new("Blade"))
    if z == 0.0 and bpy.app.version < (4, 5, 0):
        with pytest.raises(compare.CompareError, match=f"^'Blade': {32 * 32} of its "
                           f"{32 * 32} texels .* on Blender 4.2 .*nothing was compared"):
            compare.compare(obj, "normal-map", 32)
        return
    _within_bar(compare.compare(obj, "normal-map", 32), 1000)


@pytest.mark.tier("blender")
def test_the_importers_each_line_has():
    """Finding 4, per line (bpy.app.version)."""
    import addon_utils

    def has(module, name):
        try:
            getattr(getattr(bpy.ops, module), name).get_rna_type()
            return True
        except KeyError:
            return False

    for module, name in (("wm", "usd_import"), ("wm", "alembic_import"), ("wm", "obj_import"),
                         ("wm", "ply_import"), ("wm", "stl_import")):
        assert has(module, name), name
    assert has("wm", "collada_import") == (bpy.app.version < (5, 0, 0))
    names = {m.__name__ for m in addon_utils.modules()}
    assert {"io_scene_fbx", "io_scene_gltf2"} <= names
    assert "io_scene_x3d" not in names
    was = addon_utils.check("io_scene_fbx")[1]
    addon_utils.enable("io_scene_fbx", default_set=False)
    try:
        assert has("import_scene", "fbx")
    finally:
        if not was:
            addon_utils.disable("io_scene_fbx", default_set=False)
