"""Red team 58a: a skeptical review of what was merged into main since a0230c3 (rt56c, rt57a,
rt57b, rt57c, rt57d and the coordinator's changes).

1. bpy that is there but will not load. rt57a refused a Python without bpy with the fix
   (command_line._no_bpy_problem asks importlib's find_spec), but a bpy wheel that is
   installed and cannot load (a system library it links missing, as on a bare CUDA container
   or farm node: tools/gpu_bundle.sh notes an H100 image with libX11 alone; "ImportError:
   libXi.so.6: cannot open shared object file") passed that check and then ended in a raw
   ImportError traceback out of interrupts._load_blender, exit 1, for bake-normal-map,
   bake-batch, compare and compare-all alike (measured on 5.2 with a bpy that raises that
   ImportError: 4 of 4 commands, exit 1, "Traceback" on stderr). Now each says in one line
   that it could not load bpy, the loader's words (the library named) and the fix, exit 2
   (BAD_REQUEST, as for no bpy at all), nothing written (command_line._unloadable).

2. Freeze of one material refused for other faces in an empty slot (a regression of rt57b,
   which ran bake-normal-map's empty-slot check in freeze.check): a mesh whose material 'SG'
   holds slot 1 and whose slot 2 is empty (an importer's leftover, a material unlinked) with
   8 of its 30 faces in it: "8 face(s) of object 'Grid' (faces 0-7) use empty material slot 2,
   so the bake writes nothing for them, a hole in the map", FreezeError (5.2), though those
   faces are not the material's and Blender's bake skips them as it skips another
   material's: with the check left out the freeze is done and its 32^2 map is texel for
   texel (max difference 0.0) the map frozen where slot 2 holds a plain material. bake-normal-
   map bakes the whole object, so there the hole is real and the refusal stays. Now Freeze
   refuses only faces in a slot the object fills or lacks (rt57b's Geometry Nodes cases:
   Blender cancels, or bakes them 30 degrees off) (empty_slots.empty_slot_problem's
   own_empty_ok).

3. A copy of a per-UV-map group with a long name on 4.2 and 4.5 (a material appended from a
   file with the same group; a duplicated tree). Those lines name a data-block in 63 bytes and
   name a copy with no room for ".001" by cutting it ('SG Normal Map [<44-byte UV map>]',
   60 bytes: its copy is its first 59 bytes; 61-63 bytes and fitting_name's hashed names:
   the first 59 plus ".001"). rt57a's exact names (group_updates.renamed_away) took those
   for the artist's renames: the sidebar said "were renamed" and Update left the copy with
   "rename it back to its name in the Add menu", a name its original holds (4.2: 3 of 3 UV
   map lengths 44, 47, 63 bytes); and before rt57a too the rebuild never reached them
   (group_names.stale_copies asked for "<name>.NNN": "its rebuild did not reach it"). Now
   group_names.is_copy_name knows Blender's cut copies: surfgrad's, and Update rebuilds them
   to the current version. 5.0 and 5.2 (255 bytes) add ".001" and pass before and after.

Probed and right (5.2 unless said): compare with settings {"directx": True} on every method
reading a normal or detail map (normal-map, procedural-basis, triplanar(-sampler), decal,
decal-overwrite, parallax(-sampler), post-resolve, layered, blend-pd/-whiteout/-udn/-rnm, 32^2
Sphere): p99 0.0001-0.0006, max <= 0.0016 deg, as with DirectX off; object-normal refused.
bake-normal-map, compare and Freeze on a grid whose slot is object-linked (mesh slot empty)
with and without a pass-through Geometry Nodes modifier, on slots [A, empty, B] with a GN
Subdivide, and on an unused trailing empty slot: all baked, compare p99 0.0001. output_problems
on a link to a file, a folder, a link to a folder, a chain of links, /dev/null, a dangling link
(with and without --overwrite): as documented; a folder refused at the bake. The Flamenco job
on 'Rock'/'rock', composed/decomposed 'Cafe', Latin/Cyrillic 'Rock', full-width 'R', 'fi'
ligature, zero-width space: refused exactly where one file results on macOS or Windows.

Noticed and left alone: the Flamenco job folds with toLowerCase, bake-batch with casefold
('Strasse'/'Straße' one name there, two here; 'ΟΔΟΣ'/'οδοσ' not refused though NTFS takes them
as one); a Boolean cutter's empty slot is named as Geometry Nodes' "modifier(s) (none)" by
compare; compare_settings.split takes any truthy "directx" value (API only).
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from surfgrad_addon.addon import exit_codes

pytestmark = pytest.mark.tier("child")

ROOT = Path(__file__).resolve().parents[1]


# Finding 1: bpy there, but it will not load ---------------------------------------------------

_BROKEN_BPY = ('raise ImportError("libXi.so.6: cannot open shared object file: No such file '
               'or directory", name="bpy")\n')


def _args(command, tmp_path):
    blend = str(tmp_path / "a.blend")
    return {"bake-normal-map": ["--blend", blend, "--object", "Plane", "--output",
                                str(tmp_path / "n.png")],
            "bake-batch": [blend, "--output", str(tmp_path / "maps" / "{object}.png")],
            "compare": ["--blend", blend, "--object", "Plane", "--method", "normal-map",
                        "--json", str(tmp_path / "r.json")],
            "compare-all": ["--out", str(tmp_path / "all")]}[command]


@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch", "compare", "compare-all"])
def test_a_bpy_that_will_not_load_is_told_so_not_a_traceback(command, tmp_path):
    broken = tmp_path / "site" / "bpy"
    broken.mkdir(parents=True)
    (broken / "__init__.py").write_text(_BROKEN_BPY)
    work = tmp_path / "work"
    work.mkdir()
    (work / "a.blend").write_bytes(b"BLENDER")
    # (a package first on the path: it stands in for the installed wheel, found by find_spec)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path / "site"), str(ROOT)])}
    run = subprocess.run([sys.executable, "-m", "surfgrad_addon", command,
                          *_args(command, work)], cwd=work, env=env, capture_output=True,
                         text=True, timeout=120)
    # Before: exit 1, a raw "Traceback ... ImportError: libXi.so.6: ..." on stderr.
    assert run.returncode == exit_codes.BAD_REQUEST == 2, (run.returncode, run.stderr)
    assert "Traceback" not in run.stderr + run.stdout, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert line.startswith(f"surfgrad: error: {command} could not load Blender's Python "
                           f"module bpy on this Python ("), line
    assert "libXi.so.6: cannot open shared object file" in line, line
    assert "install what it names" in line and "bpy wheel" in line, line
    # The extension's own commands can run inside Blender; the harness's cannot.
    assert ("blender -c surfgrad" in line) == command.startswith("bake-"), line
    assert sorted(p.name for p in work.iterdir()) == ["a.blend"]


# Finding 2: Freeze of one material, other faces in an empty slot -----------------------------

FREEZE_RES = 32
COLOUR = (0.75, 0.5, 0.933)            # a constant tangent-space map, tilted about v


def _grid_with_stack(other):
    """A 6 x 5 grid whose material 'SG' (a layer stack reading a constant map) holds slot 1,
    slot 2 empty (as an importer leaves one) or, `other`, holding a plain material, the
    first 8 faces in slot 2."""
    import bpy
    import numpy as np
    from surfgrad_addon.addon import operators as O
    from surfgrad_addon.harness import asset_scenes as A
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = A._link("Grid", A._grid("Grid", nx=6, ny=5))
    mat = bpy.data.materials.new("SG")
    if bpy.app.version < (5, 0):        # always on from 5.0 (deprecated)
        mat.use_nodes = True
    O.add_layer_stack(mat.node_tree)
    nt = mat.node_tree
    layer = next(n for n in nt.nodes if n.type == "GROUP" and "Normal Map" in n.node_tree.name)
    rgb = nt.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = COLOUR + (1.0,)
    nt.links.new(rgb.outputs[0], next(s for s in layer.inputs if s.type == "RGBA"))
    obj.data.materials.append(mat)
    plain = bpy.data.materials.new("Other") if other else None
    if plain and bpy.app.version < (5, 0):
        plain.use_nodes = True
    obj.data.materials.append(plain)
    index = np.zeros(len(obj.data.polygons), np.int32)
    index[:8] = 1
    obj.data.polygons.foreach_set("material_index", index)
    obj.data.update()
    obj.active_material_index = 0
    return obj, mat


def _frozen_pixels(obj):
    import bpy
    import numpy as np
    from surfgrad_addon.addon import freeze as F
    result = F.freeze(obj, FREEZE_RES)
    img = bpy.data.images[result["image"]]
    return np.array(img.pixels[:], dtype=np.float64).reshape(FREEZE_RES, FREEZE_RES, -1)[..., :3]


@pytest.mark.tier("bake")
def test_freeze_of_one_material_with_other_faces_in_an_empty_slot_is_done():
    """Before (rt57b's check): "8 face(s) of object 'Grid' (faces 0-7) use empty material slot
    2, so the bake writes nothing for them, a hole in the map", FreezeError, though those faces
    are not the material's: Blender's bake skips them as it skips another material's. Now the
    map is frozen, texel for texel the map of the same grid whose slot 2 holds a material."""
    pytest.importorskip("bpy")
    import numpy as np
    from surfgrad_addon.addon import freeze as F
    obj, mat = _grid_with_stack(False)
    F.check(obj, FREEZE_RES)                # before: FreezeError, the empty slot named
    got = _frozen_pixels(obj)
    assert F.RECORD in mat
    obj, _ = _grid_with_stack(True)       # the same faces, another material's
    want = _frozen_pixels(obj)
    assert np.abs(got - want).max() < 1e-6, np.abs(got - want).max()
    # (and the map is the stack's: most texels the constant colour, 8 faces of 30 elsewhere)
    near = (np.abs(want - np.array(COLOUR)).max(axis=-1) < 0.01).mean()
    assert near > 0.6, near


# Finding 3: a copy of a per-UV-map group with a long name, on 4.2 and 4.5 --------------------

@pytest.mark.tier("blender")
@pytest.mark.parametrize("uv_bytes", [44, 47, 63])
def test_a_copy_of_a_long_per_uv_map_group_is_still_surfgrads(uv_bytes):
    """4.2 and 4.5 name a data-block in 63 bytes and cut the name of a copy with no room for
    ".001" (an appended material's group, a duplicated node tree). Before: renamed_away took
    those for the artist's renames; the sidebar said "were renamed" and Update left the copy
    with "rename it back", to the name its original holds. 5.0 and 5.2 (255 bytes) keep
    ".001": the same expectations hold there unchanged."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.addon import group_updates as U
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.addon.compat import new_material
    from surfgrad_addon.addon.group_names import VERSION_KEY
    bpy.ops.wm.read_factory_settings(use_empty=True)
    original = G.normal_map_group("U" * uv_bytes)
    copy = original.copy()
    short = bpy.types.ID.bl_rna.properties["name"].length_max <= 64
    # The name Blender gave the copy: cut short on 4.x, not ".001"-suffixed as on 5.x.
    assert (not copy.name.endswith("].001")) == short, (copy.name, short)
    copy[VERSION_KEY] = G.VERSION - 1
    new_material("Rock").node_tree.nodes.new("ShaderNodeGroup").node_tree = copy
    assert not U.renamed_away(copy), copy.name           # before: True on 4.2 and 4.5
    text = U.stale_text(U.stale_groups())
    assert "Update surfgrad Groups rebuilds them" in text and "renamed" not in text, text
    updated, left = U.update_stale_groups()
    assert left == [] and len(updated) == 1, (updated, left)
    assert all(g.get(VERSION_KEY) == G.VERSION for g in bpy.data.node_groups if g.users)
