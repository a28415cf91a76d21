"""Red team 57a: a skeptical review of round 56's product changes (rt56a to rt56d).

1. An output path that is a symbolic link whose target is not there yet (a pipeline that
   links `maps/rock_nrm.png -> ../publish/v004/rock_nrm.png` before the version exists),
   without --overwrite: bake_request.output_problems asked Path.exists(), which follows the
   link, so the check before the bake passed; the bake ran in full ("[2/3] baking with
   Cycles"), and only placing the map refused it ("out.png exists; pass --overwrite to
   replace it", exit 2): the whole bake's time lost (a 4k bake: minutes) before a refusal the
   request already earned. Measured on 5.2 (16^2 plane): exit 2 after the bake. Now refused
   before Blender bakes, exit 2, the link left as it was, naming the link's target (merged
   with rt57c, which refuses a link to nothing even with --overwrite: that replaced the link
   with the map, and the file the link names was never written).

2. The same for compare's --json (and its heat map, NAME_error.png): check_output_path asked
   Path.exists(), so a report path that is a link to a file not there yet passed; the whole
   compare ran (6.1 s for a 16^2 rock on 5.2), then the report's open(..., "x") met the link
   and compare said "'.../c.json' appeared while this compare ran (another compare writing the
   same report?)", exit 1: wrong (it was there from the start) and late. With --overwrite and
   the link's folder missing: the compare ran, then "could not write ... (the disk may be
   full)", exit 1. Now both are refused before the compare (0.07 s), exit 2: "exists; pass
   --overwrite", and "it is a symbolic link to '...', in a folder that does not exist; make
   that folder, or give another path"; the link left as it was.

3. Round 56d's renamed groups (group_updates.renamed_away) took any name that starts as one of
   surfgrad's per-UV-map names do for surfgrad's: an older "SG Normal Map [UVMap]" the artist
   renamed "SG Normal Map [UVMap] mine" (a suffix: the usual rename) was still promised by the
   sidebar ("Update surfgrad Groups rebuilds them", with the button), and Update said "No
   surface-gradient group was updated": "its rebuild did not reach it (add the group again
   from the menu)", the fix that does not help. A current one edited inside and renamed so,
   as the sidebar asks ("rename each to keep your version"), was still named edited. Measured
   on 5.2. Now a per-UV-map or filter-width name counts as surfgrad's only when it is the name
   surfgrad gives from the group's own UV Map / Normal Map node (or its filter width): the
   renamed one is named apart with "rename it back", no button, left by Update with that
   reason, and no longer named edited; "SG Normal Map [UVMap]", its ".001" copy, a UV map
   name too long for a name (the hashed name) and "SG Height Map Forward (filter 0.5)" still
   update.

4. `python -m surfgrad_addon bake-normal-map` (bake-batch, compare, ...) on a Python without
   the bpy wheel (a TD's system Python, a venv made for another line): a raw
   ModuleNotFoundError traceback, exit 1 (from inside interrupts._load_blender since 56c;
   before, from open_mainfile's `import bpy`; measured on the system Python 3.11). Now
   exit 2 before anything runs: "bake-normal-map needs Blender's Python module bpy, which
   this Python (3.11, ...) does not have: install the bpy wheel ... or bake inside Blender".

Probed and fine (not pinned here): image_headers.cut_short on OpenImageIO-written EXRs
(scanline and 16^2-tiled, every compression it writes: none, rle, zips, zip, piz, pxr24, b44,
b44a, dwaa, dwab; decreasingY; randomY tiled; a data window at (-5, -17); maketx's tiled
mipmapped textures of 9 levels, also randomY, dwaa, piz), Blender's own EXR writer (every
codec on 5.2, HTJ2K included, and 4.2; half and float) and WebP writer (lossy VP8, VP8X with
alpha, lossless VP8L): each whole file read whole, each one byte short refused. Cost: an
8192^2 tiled EXR of 16^2 tiles (262144 chunks) 0.24 s; 8192 ZIPS scanlines 0.004 s.
material_inputs.group_outputs: Blender keeps one Group Output active always (setting the
last one's is_active_output False flags the first again, 4.2 and 5.2), so "none flagged" does
not arise. render_mesh's handlers come out on an ExitStack and go back on an exception.
interrupts._load_blender unblocks the signals in a finally (an ImportError leaves none held);
threads that inherit the held mask (the watcher, Blender's) are not the ones that start
bake-batch's workers. bake-batch with such a link as an asset's output resolves it (writes
through it) and refuses a missing target folder before baking ("output folder ... does not
exist"), exit 1: no wasted bake (left as is; bake-normal-map replaces the link instead).

Noticed and left alone: the render-mode pass still runs depsgraph_update_pre/_post handlers
twice (5.2 and 4.2; from the settings it sets and restores, as any property change does);
compare's stack names (STACK_GRID 256) only shorten a warning's list of pairs.
"""

import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from test_faults_pipeline_leftovers import _normal_texels, _scene, _write_image  # noqa: E402

pytestmark = pytest.mark.tier("bake")

RES = 16


def test_an_output_linked_to_a_file_not_there_yet_is_refused_before_the_bake(tmp_path, capsys):
    """Exit 2 before Blender bakes, the link as it was, nothing written (before: the bake ran
    in full, then placing the map refused it)."""
    _write_image(tmp_path / "n.png", _normal_texels(RES))
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    (tmp_path / "publish").mkdir()
    target = tmp_path / "publish" / "n_v004.png"
    out = tmp_path / "out.png"
    out.symlink_to(target)
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out), "--resolution", str(RES), "--samples", "1"])
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert rc == exit_codes.BAD_REQUEST, text
    assert "baking with Cycles" not in text, text          # refused before the bake
    assert (f"output {str(out)!r} is a symbolic link to {str(target)!r}, which does not exist"
            in captured.err), text
    assert "Traceback" not in text
    assert out.is_symlink() and os.readlink(out) == str(target) and not target.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend", "n.png", "out.png",
                                                          "publish"]
    assert list((tmp_path / "publish").iterdir()) == []


def test_a_dangling_link_with_overwrite_is_refused_too(tmp_path, capsys):
    """--overwrite does not replace a link to nothing with the map (rt57c): exit 2, the link as
    it was."""
    _write_image(tmp_path / "n.png", _normal_texels(RES))
    blend = _scene(tmp_path / "a.blend", tmp_path / "n.png")
    out = tmp_path / "out.png"
    out.symlink_to(tmp_path / "missing.png")
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Plane",
                           "--output", str(out), "--resolution", str(RES), "--samples", "1",
                           "--overwrite"])
    err = capsys.readouterr().err
    assert rc == exit_codes.BAD_REQUEST, err
    assert "which does not exist" in err and "Traceback" not in err
    assert out.is_symlink() and not (tmp_path / "missing.png").exists()


def _rock(tmp_path):
    from surfgrad_addon.harness import batch_assets as BA
    return BA.write_asset(tmp_path / "rock.blend", ("Rock",), tiles=(1001,), image_size=16)


@pytest.mark.parametrize("name", ["c.json", "c_error.png"])
def test_a_compare_report_linked_to_a_file_not_there_yet_is_refused_before_the_compare(
        name, tmp_path, capsys):
    """Exit 2 before the compare bakes, 'exists; pass --overwrite', the link as it was
    (before: exit 1 after the compare, 'appeared while this compare ran')."""
    from surfgrad_addon.harness import cli
    rock = _rock(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    link = out / name
    link.symlink_to(tmp_path / "publish" / name)
    capsys.readouterr()
    rc = cli.main(["compare", "--blend", str(rock), "--object", "Rock", "--method",
                   "normal-map", "--resolution", "16", "--json", str(out / "c.json")])
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert rc == exit_codes.BAD_REQUEST, text
    assert f"{link} exists; pass --overwrite to replace it" in captured.err, text
    assert "appeared while" not in text and "Traceback" not in text
    assert "Read blend" not in text                 # refused before the file was opened
    assert sorted(p.name for p in out.iterdir()) == [name] and link.is_symlink()
    assert not (tmp_path / "publish").exists()


def test_a_compare_report_linked_into_a_missing_folder_is_refused_with_overwrite(tmp_path,
                                                                                capsys):
    """--overwrite, the link's folder not there: exit 2 before the compare, naming the link's
    target (before: exit 1 after it, 'the disk may be full')."""
    from surfgrad_addon.harness import cli
    rock = _rock(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    link = out / "c.json"
    target = tmp_path / "publish" / "c.json"
    link.symlink_to(target)
    capsys.readouterr()
    rc = cli.main(["compare", "--blend", str(rock), "--object", "Rock", "--method",
                   "normal-map", "--resolution", "16", "--json", str(link), "--overwrite"])
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert rc == exit_codes.BAD_REQUEST, text
    assert (f"it is a symbolic link to {str(target)!r}, in a folder that does not exist; "
            f"make that folder, or give another path") in captured.err, text
    assert "disk may be full" not in text and "Traceback" not in text
    assert sorted(p.name for p in out.iterdir()) == ["c.json"] and link.is_symlink()
    assert not (tmp_path / "publish").exists()


def test_a_compare_report_linked_into_a_folder_there_is_written_through_the_link(tmp_path,
                                                                                capsys):
    """The control: --overwrite, the link's folder there: exit 0, the report at the target."""
    from surfgrad_addon.harness import cli
    rock = _rock(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "publish").mkdir()
    target = tmp_path / "publish" / "c.json"
    (out / "c.json").symlink_to(target)
    rc = cli.main(["compare", "--blend", str(rock), "--object", "Rock", "--method",
                   "normal-map", "--resolution", "16", "--json", str(out / "c.json"),
                   "--overwrite"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert target.read_text().lstrip().startswith("{")


# Finding 3: renamed per-UV-map groups ---------------------------------------------------------

def _older(group, name=None):
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.addon.group_names import VERSION_KEY
    group[VERSION_KEY] = G.VERSION - 1
    if name is not None:
        group.name = name
    return group


def _material_using(group):
    import bpy
    from surfgrad_addon.addon.compat import new_material
    mat = new_material("Rock")
    mat.node_tree.nodes.new("ShaderNodeGroup").node_tree = group
    return mat


@pytest.mark.tier("blender")
@pytest.mark.parametrize("suffix", [" mine", " (edited)", " [v2]"])
def test_a_per_uv_map_group_renamed_with_a_suffix_is_named_apart_and_left(suffix, fresh):
    from surfgrad_addon.addon import group_updates as U
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.addon.group_names import VERSION_KEY
    name = "SG Normal Map [UVMap]" + suffix
    group = _older(G.normal_map_group("UVMap"), name)
    _material_using(group)
    nodes = len(group.nodes)
    text = U.stale_text(U.stale_groups())
    assert f"1 older surface-gradient group(s) were renamed ({name!r})" in text, text
    assert "Update surfgrad Groups rebuilds them" not in text, text
    updated, left = U.update_stale_groups()
    assert updated == [] and [n for n, _ in left] == [name], left
    assert "rename it back to its name in the Add menu" in left[0][1], left
    assert "did not reach it" not in left[0][1], left
    assert group[VERSION_KEY] == G.VERSION - 1 and len(group.nodes) == nodes
    import bpy
    assert sorted(g.name for g in bpy.data.node_groups) == [name]     # nothing added


@pytest.mark.tier("blender")
def test_an_edited_per_uv_map_group_renamed_with_a_suffix_is_no_longer_named_edited(fresh):
    from surfgrad_addon.addon import group_updates as U
    from surfgrad_addon.addon import groups as G
    group = G.normal_map_group("UVMap")
    next(n for n in group.nodes if n.bl_idname == "ShaderNodeNormalMap").mute = True
    _material_using(group)
    assert "('SG Normal Map [UVMap]')" in (U.edited_text() or ""), U.edited_text()
    group.name = "SG Normal Map [UVMap] mine"      # what the sidebar asks
    assert U.edited_text() is None, U.edited_text()


@pytest.mark.tier("blender")
@pytest.mark.parametrize("kind", ["normal map", "copy", "long uv map", "filter width"])
def test_per_uv_map_and_filter_groups_under_surfgrads_names_still_update(kind, fresh):
    """The controls: each is named surfgrad's, and Update rebuilds it."""
    import bpy
    from surfgrad_addon.addon import group_updates as U
    from surfgrad_addon.addon import groups as G
    from surfgrad_addon.addon.group_names import VERSION_KEY
    if kind == "filter width":
        group = _older(G.height_map_forward_group(0.5))
        assert group.name == "SG Height Map Forward (filter 0.5)"
    elif kind == "long uv map":
        uv = "UV_" + "x" * 60                     # the longest UV map name (63 bytes)
        group = _older(G.normal_map_group(uv))
        # 4.2 and 4.5 name a data-block in 63 bytes: the hashed name of fitting_name
        short = bpy.types.ID.bl_rna.properties["name"].length_max <= 64
        assert ("~" in group.name) == short, group.name
    else:
        group = _older(G.normal_map_group("UVMap"))
        if kind == "copy":
            group.name = "SG Normal Map [UVMap].001"
    _material_using(group)
    assert not U.renamed_away(group)
    text = U.stale_text(U.stale_groups())
    assert "Update surfgrad Groups rebuilds them" in text and "renamed" not in text, text
    updated, left = U.update_stale_groups()
    assert left == [] and len(updated) == 1, (updated, left)
    assert all(g.get(VERSION_KEY) == G.VERSION for g in bpy.data.node_groups
               if g.users), [(g.name, g.get(VERSION_KEY)) for g in bpy.data.node_groups]


# Finding 4: no bpy --------------------------------------------------------------------------

_NO_BPY = """
import runpy, sys
class NoBpy:                                  # this Python has no bpy wheel
    def find_spec(self, name, path=None, target=None):
        if name == "bpy" or name.startswith("bpy."):
            raise ModuleNotFoundError("No module named 'bpy'", name="bpy")
        return None
sys.meta_path.insert(0, NoBpy())
sys.argv = ["surfgrad_addon", *sys.argv[1:]]
runpy.run_module("surfgrad_addon", run_name="__main__")
"""


@pytest.mark.tier("child")
@pytest.mark.parametrize("command", ["bake-normal-map", "compare"])
def test_a_python_without_bpy_is_told_so_not_a_traceback(command, tmp_path):
    import subprocess
    root = Path(__file__).resolve().parents[1]
    args = {"bake-normal-map": ["--blend", str(tmp_path / "a.blend"), "--object", "Plane",
                                "--output", str(tmp_path / "n.png")],
            "compare": ["--blend", str(tmp_path / "a.blend"), "--object", "Plane", "--method",
                        "normal-map", "--json", str(tmp_path / "r.json")]}[command]
    (tmp_path / "a.blend").write_bytes(b"BLENDER")
    env = {**os.environ, "PYTHONPATH": str(root)}
    run = subprocess.run([sys.executable, "-c", _NO_BPY, command, *args], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == exit_codes.BAD_REQUEST, run.stderr
    assert "Traceback" not in run.stderr + run.stdout, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert line.startswith(f"surfgrad: error: {command} needs Blender's Python module bpy, "
                           f"which this Python ("), line
    assert "pip install bpy==" in line and "blender -c surfgrad" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend"]
