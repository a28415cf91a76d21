"""Red team 42b: what a render farm's tasks do to each other and to a bake's files.

- Farm tasks in containers (Docker, Kubernetes, Singularity with its own process-id space)
  run Blender under the same small process id in each, and a bake's temporary file beside
  the map was named by the process id alone (`.Rock.part1.png`). Two tasks baking one map
  into a shared folder (two list lines landing on one file, a job submitted twice) therefore
  wrote one temporary file: Blender's save of the second truncated the first's, the first
  published it as its map (a hard link) and removed it, and the second then found no file.
  Measured with two real `bake-batch --workers 0` runs of two different assets under
  `unshare --pid` (each Python is process 1), 2048^2 16-bit PNGs, seven rounds: the task
  that exited 0 (its manifest: baked) had published the other asset's map in 3 (all 2048
  rows), a file equal to neither asset's map in 4 (one a PNG no reader opens), its own in
  none; the other failed 'Rock.png exists'. A stop (SIGTERM)
  of one task removed the other's temporary files too (remove_partials matched by id). Now
  the name also holds a random token of the process (interrupts.partial_path), and a batch's
  worker gets its token from the batch, which removes a dead worker's files by both.
- A tile token spelled another way in the output ('rock.<udim>.png', Mari's
  'rock.$UDIM.png'; Blender fills in '<UDIM>' alone, case and all): bake-normal-map
  and bake-batch wrote one file named with the token, exit 0 (as '<UVTILE>' did before round
  36). Now refused before anything runs, exit 2, naming the token and the fix.
- An asset list's '~/a.blend' where the process has no home folder (HOME unset and no
  password entry for its user id: a container run under an arbitrary uid, measured in a user
  namespace as uid 4242): the batch printed Python's bare "Could not determine home
  directory.", exit 2, naming neither the list nor the fix. Now it names both.
- compare-all with a relative --out, run from a folder other than the checkout (a farm
  task's working folder) with --workers 2: its worker process runs in the checkout and took
  the relative path from there, so the run failed, exit 1, "compare-all worker 1 failed
  (exit 1): FileNotFoundError: ... 'ca/heat/blend-pd_Torus.png'" (a checkout holding such a
  folder would have had the worker's heat maps written into it). Now the worker gets the
  folder absolute.
- The main job's and the benches' --out is written in a sibling `.NAME.partial-PID`, and a
  run removed one of its own id as "left by a killed process": a second run under the same
  id (another container) removed the first's files under way, and the two then wrote one
  folder. Now the sibling carries the process's token too, and nothing is removed.
"""

import os
import pwd

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes, interrupts  # noqa: E402
from surfgrad_addon.addon.batch import BatchError, read_asset_list  # noqa: E402
from surfgrad_addon.addon.normal_bake import PNG_END  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from surfgrad_addon.harness import compare_all as CA  # noqa: E402
from surfgrad_addon.harness.staged_folder import staged  # noqa: E402
from support.child import ROOT  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def test_another_same_id_process_temporary_files_beside_the_map_are_left_alone(tmp_path,
                                                                                capsys):
    """Files of another task with this process's id beside the map, under the name the bake
    used before (`.Rock.part<pid>.png`) and under today's with another token. Before: the
    bake saved over the first, published it as Rock.png and removed it (another task's file
    under way, gone). Now both are left as they were, and Rock.png is this bake's map."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    maps = tmp_path / "maps"
    maps.mkdir()
    other = "0123abcd" if getattr(interrupts, "PART_TOKEN", "") != "0123abcd" else "89abcdef"
    theirs = {maps / f".Rock.part{os.getpid()}.png": b"another task's map, being written",
              maps / f".Rock.part{os.getpid()}-{other}.png": b"another task's map, too"}
    for path, data in theirs.items():
        path.write_bytes(data)
    rc = commands.execute(["bake-batch", str(blend), "--output", str(maps / "{object}.png"),
                           "--workers", "0", "--resolution", "16", "--margin", "0"])
    assert rc == 0, capsys.readouterr().err
    for path, data in theirs.items():
        assert path.is_file() and path.read_bytes() == data, path.name
    made = maps / "Rock.png"
    assert made.read_bytes().endswith(PNG_END)
    img = bpy.data.images.load(str(made), check_existing=False)
    try:
        assert tuple(img.size) == (16, 16)
        rgb = np.array(img.pixels[:]).reshape(16, 16, 4)[..., :3] * 2 - 1
    finally:
        bpy.data.images.remove(img)
    # A tangent-space map of the asset: unit normals facing out (8-bit steps), not grey.
    assert np.allclose(np.linalg.norm(rgb, axis=-1), 1, atol=0.02)
    assert (rgb[..., 2] > 0.3).all()


def test_tile_tokens_spelled_otherwise_are_refused_before_baking(tmp_path, capsys):
    """Before: 'rock.<udim>.png' and '{object}.$UDIM.png' each baked one file named with the
    token, exit 0."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    maps = tmp_path / "maps"
    maps.mkdir()
    small = ["--resolution", "16", "--margin", "0"]
    for command, token in ((["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                             "--output", str(maps / "rock.<udim>.png")], "<udim>"),
                           (["bake-batch", str(blend), "--output", str(maps / "{object}.$UDIM.png"),
                             "--workers", "0"], "$UDIM")):
        capsys.readouterr()
        rc = commands.execute(command + small)
        err = capsys.readouterr().err
        assert rc == exit_codes.BAD_REQUEST, err
        assert f"has {token!r}, a tile token this bake does not fill in" in err, err
        assert "write <UDIM>, in capitals" in err and "Traceback" not in err, err
    assert list(maps.iterdir()) == []


@pytest.mark.tier("numpy")
def test_a_tilde_in_an_asset_list_without_a_home_folder_names_the_list(tmp_path, monkeypatch):
    listing = tmp_path / "assets.txt"
    listing.write_text("~/a.blend\n")

    def no_entry(uid):
        raise KeyError(f"getpwuid(): uid not found: {uid}")

    monkeypatch.delenv("HOME", raising=False)
    monkeypatch.setattr(pwd, "getpwuid", no_entry)         # what a container's uid meets
    with pytest.raises(BatchError) as err:
        read_asset_list(listing)
    assert str(err.value) == (f"asset list {listing}: '~/a.blend' starts with '~', but this "
                              f"process has no home folder (HOME is not set, and the system "
                              f"knows none for this user): set HOME, or write the path in full "
                              f"or relative to the list's folder")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert read_asset_list(listing) == [str(tmp_path / "home" / "a.blend")]


@pytest.mark.tier("child")
def test_compare_all_workers_take_a_relative_out_from_the_callers_folder(tmp_path,
                                                                          monkeypatch):
    out = "rt42b-relative-compare"                   # relative to tmp_path, not the checkout
    monkeypatch.chdir(tmp_path)
    reports = CA.run_all(out, 8, workers=2, methods=["normal-map"], log=lambda *_: None)
    cases = 4 * len(CA.all_cases(["normal-map"]))    # the four test objects, each case
    assert len(reports) == cases
    heat = sorted(p.name for p in (tmp_path / out / "heat").iterdir())
    assert len(heat) == cases and all(n.startswith("normal-map") for n in heat), heat
    assert not (ROOT / out).exists()


@pytest.mark.tier("numpy")
def test_a_same_id_run_working_folder_beside_the_output_is_left_alone(tmp_path):
    theirs = tmp_path / f".demo.partial-{os.getpid()}"       # another container's run
    (theirs / "compare").mkdir(parents=True)
    (theirs / "compare" / "heat.png").write_text("their heat map, under way")
    final = tmp_path / "demo"
    with staged(final, overwrite=False) as work:
        assert work != theirs
        (work / "index.html").write_text("our page")
    assert (theirs / "compare" / "heat.png").read_text() == "their heat map, under way"
    assert sorted(p.name for p in final.iterdir()) == ["index.html"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [theirs.name, "demo"]
