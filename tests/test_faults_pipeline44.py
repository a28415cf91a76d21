"""Red team 44c: a TD's headless runs and a farm's tasks, killed, re-queued, squeezed.

1. A batch killed (SIGKILL: a farm's hard kill, the out-of-memory killer; or a worker dying)
   after a bake put its map in place and before the manifest recorded it: the rerun failed
   that asset, exit 1, "Rock.png exists; pass --overwrite to replace it" (the map was the
   killed run's own), and a worker's retry in the same run did too (measured with a real
   SIGKILL of `bake-batch --workers 0` sent as soon as the second or third of three maps
   appeared: both reruns exit 1; the manifest's temporary file was left once). Now the batch records
   the files a bake is about to put in place, with the hash of their complete temporary
   files, before they are put there (`pending` in the manifest; a worker waits for that
   record), and a rerun (or the retry) takes a file still holding that content as its own
   and bakes it again; a file that holds anything else is still refused.
2. A run that bakes an asset again (--force, a repainted texture, new settings) and does not
   finish it (killed, stopped with SIGTERM: a farm's cancel, or failed) wrote the manifest
   without the maps the earlier run had recorded for that asset: the next run took them for
   someone's files and failed the asset, "Rock.png exists", exit 1. Now such an entry keeps
   them on record (`earlier_files`) until a bake records its own.
3. A '{...}' in the output of `api.bake_normal_map` and of Freeze's Save As (Blender 5's path
   template '{blend_name}', the batch's '{object}'): a file named '{blend_name}_nrm.png' was
   written, where `bake-normal-map` refuses it (round 43a). Now both refuse it with the same
   words (normal_bake.brace_token_problem), nothing written, the material unchanged. So is
   '<UDIM>' in Freeze's Save As (one image, of the 0-1 square): a file named 'n.<UDIM>.png'
   was written and the frozen material read it.
4. The hidden working folder of a main job or bench (`.NAME.partial-PID-TOKEN`, beside its
   --out) killed with SIGKILL stayed for good, one more per killed run on a farm's share.
   Now a run records who it is in it (machine, boot, process-id space, process start:
   harness/run_owner.py), and the next run into that --out removes those whose run provably
   ended, one line each; it leaves, and names once with the command, those it cannot tell
   (another machine's, another container's, one without a record): they may be live.
   A bake's temporary files beside its maps and manifest (`.Rock.part<pid>-<token>.png`),
   which carry no such record, are named by the batch's next run into that folder (a
   warning with the command), not removed.
5. A manifest the file-size limit (`ulimit -f`, SIGXFSZ, which Python ignores: EFBIG) would not
   take whole: the run failed, exit 1, telling the TD to "free space ... (the disk may be
   full)" on a disk with room. Now it names the limit and how to raise it.
6. Two assets whose outputs are one file through a symbolic link (`out/{file}/...` where
   `out/b` links to `out/a`, a versioned store's layout) or through '..' (`out/{file}/../
   {object}.png`): the batch baked the first and, with --overwrite, replaced its map with
   the second's, exit 0, both recorded as baked (one recorded map was gone); without it,
   failed the second after baking the first, exit 1.
   Now refused before anything bakes, exit 2, naming both and the file, as two assets on one
   name are.
7. compare-all --overwrite stopped (SIGTERM, Ctrl-C) or failed midway wrote each case's heat
   map over the earlier run's as it went, and the stop took back only the new names: measured
   with a rerun at 16^2 over a run at 8^2, stopped by SIGTERM once ten heat maps were
   rewritten, 12 of its 124 heat maps were the stopped run's (16 px) under the earlier run's
   tables (8 px), exit 143. Now the cases
   write into a hidden sibling of heat/ and everything is moved in at the end, in one commit
   (a stop waits for it); a stopped or failed run leaves the folder as it was.
"""

import json
import os
import resource

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon import api  # noqa: E402
from surfgrad_addon.addon import commands, exit_codes, freeze  # noqa: E402
from surfgrad_addon.addon.compat import new_material  # noqa: E402
from surfgrad_addon.addon import normal_bake as NB  # noqa: E402
from surfgrad_addon.addon.batch import bake_batch, manifest, session  # noqa: E402
from surfgrad_addon.addon.exit_codes import BakeFailed  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from surfgrad_addon.harness import compare_all as CA  # noqa: E402
from surfgrad_addon.harness import run_owner, scenes  # noqa: E402
from surfgrad_addon.harness.staged_folder import staged  # noqa: E402

pytestmark = pytest.mark.tier("bake")

SMALL = ["--workers", "0", "--resolution", "16", "--margin", "0"]


class _Killed(BaseException):
    """Stands for a SIGKILL: nothing after it runs."""


def test_a_batch_killed_after_publishing_a_map_is_finished_by_its_rerun(tmp_path, capsys,
                                                                       monkeypatch):
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock", "Stone"), tiles=(1001,),
                           image_size=16)
    maps = tmp_path / "maps"
    maps.mkdir()
    command = ["bake-batch", str(blend), "--output", str(maps / "{object}.png"), *SMALL]
    publish_all = NB._publish_all

    def killed_after_publishing(temps, finals, *args):
        publish_all(temps, finals, *args)
        if finals[1001].name == "Stone.png":
            raise _Killed                 # the second map is in place, not yet recorded
    monkeypatch.setattr(NB, "_publish_all", killed_after_publishing)
    with pytest.raises(_Killed):
        commands.execute(command)
    monkeypatch.undo()
    stone = maps / "Stone.png"
    killed_map = stone.read_bytes()
    assert killed_map.endswith(NB.PNG_END)
    recorded = json.loads((maps / "surfgrad-bake-manifest.json").read_text())["assets"]
    assert [k.rsplit(":", 1)[1] for k, a in recorded.items() if a.get("status")] == ["Rock"]
    # what a killed bake leaves too (its file under check), and one of a live run elsewhere
    leftovers = [maps / ".Stone.part4242-0123abcd.png", maps / ".Rock.part77-89abcdef.png"]
    for p in leftovers:
        p.write_bytes(b"a map under way")
    capsys.readouterr()
    assert commands.execute(command) == 0, capsys.readouterr().err       # before: 1, exists
    err = capsys.readouterr().err
    assert "exists" not in err, err
    assert (f"warning: 2 temporary file(s) of other runs in {str(maps)!r} "
            f"({leftovers[1].name}, {leftovers[0].name}): left by killed runs") in err, err
    assert all(p.read_bytes() == b"a map under way" for p in leftovers)
    for p in leftovers:
        p.unlink()
    assert stone.read_bytes().endswith(NB.PNG_END)
    records = json.loads((maps / "surfgrad-bake-manifest.json").read_text())["assets"]
    assert {a["object"]: a["status"] for a in records.values()} == {"Rock": "skipped",
                                                                     "Stone": "baked"}
    assert all("pending" not in a for a in records.values())

    # A file of the user's at that name after such a kill: refused, left as it was.
    stone_record = next(a for a in records.values() if a["object"] == "Stone")
    stone_record.pop("files")
    stone_record["status"] = None
    stone_record["pending"] = {"1001": {"path": str(stone), "sha256": "0" * 64}}
    manifest = json.loads((maps / "surfgrad-bake-manifest.json").read_text())
    manifest["assets"] = records
    (maps / "surfgrad-bake-manifest.json").write_text(json.dumps(manifest))
    stone.write_bytes(killed_map[:-12])                 # (a file no bake of ours wrote)
    assert commands.execute(command) == exit_codes.BAKE_FAILED
    assert f"{stone} exists; pass --overwrite" in capsys.readouterr().err
    assert stone.read_bytes() == killed_map[:-12]


def test_a_run_that_did_not_finish_a_rebake_keeps_the_earlier_maps_on_record(tmp_path, capsys,
                                                                            monkeypatch):
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    maps = tmp_path / "maps"
    command = ["bake-batch", str(blend), "--output", str(maps / "{object}.png"), *SMALL]
    assert commands.execute(command) == 0
    first = (maps / "Rock.png").read_bytes()

    def killed(*_):
        raise _Killed                      # while the map is being written, none published
    monkeypatch.setattr(NB, "_check_written", killed)
    with pytest.raises(_Killed):
        commands.execute(command + ["--force"])
    monkeypatch.undo()
    assert (maps / "Rock.png").read_bytes() == first
    capsys.readouterr()
    assert commands.execute(command) == 0, capsys.readouterr().err       # before: 1, exists
    records = json.loads((maps / "surfgrad-bake-manifest.json").read_text())["assets"]
    assert [a["status"] for a in records.values()] == ["baked"]
    (maps / "Rock.png").write_bytes(first[:-12])          # edited since: the user's now
    assert commands.execute(command + ["--force"]) == exit_codes.BAKE_FAILED
    assert "Rock.png exists; pass --overwrite" in capsys.readouterr().err
    assert (maps / "Rock.png").read_bytes() == first[:-12]


@pytest.mark.tier("blender")
def test_a_brace_token_in_the_api_and_freeze_output_is_refused_as_the_cli_does(fresh,
                                                                              tmp_path):
    obj = scenes.new_scene(["Plane"])["Plane"]
    mat = new_material("API")
    obj.data.materials.append(mat)
    api.add_layer_stack(mat)
    nodes = len(mat.node_tree.nodes)
    for name in ("{blend_name}_nrm.png", "{object}.png"):
        token = name[:name.index("}") + 1]
        with pytest.raises(ValueError) as err:
            api.bake_normal_map(obj, tmp_path / name, resolution=16, log=None)
        assert f"has {token}, which api.bake_normal_map does not fill in" in str(err.value)
        assert "api.bake_batch" in str(err.value)
        with pytest.raises(freeze.FreezeError) as err:
            freeze.check(obj, 16, filepath=str(tmp_path / name))
        assert f"has {token}, which Freeze's Save As does not fill in" in str(err.value)
    with pytest.raises(freeze.FreezeError, match=r"has <UDIM>, which Freeze does not fill in.*"
                                                 r"'[^']*/n\.1001\.png'"):
        freeze.freeze(obj, 16, filepath=str(tmp_path / "n.<UDIM>.png"), log=lambda *_: None)
    assert list(tmp_path.iterdir()) == [] and len(mat.node_tree.nodes) == nodes


@pytest.mark.tier("child")
def test_a_worker_dead_after_publishing_its_map_is_retried_to_the_end(tmp_path):
    """The worker process exits (70) once Stone's map is in place, before it replies. Before:
    the retry failed Stone, "Stone.png exists", exit 1."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock", "Stone"), tiles=(1001,),
                           image_size=16)
    maps = tmp_path / "maps"
    report = bake_batch([str(blend)], str(maps / "{object}.png"), workers=1,
                        defaults={"resolution": 16, "margin": 0}, log=lambda *_: None,
                        worker_env=dict(os.environ,
                                        **{session.FAULT_ENV: "die-published-once:Stone"}))
    stone = report["assets"][f"{blend.resolve()}:Stone"]
    assert [a["status"] for a in stone["attempts"]] == ["error", "ok"], stone
    assert "exit code 70" in stone["attempts"][0]["error"]
    assert report["counts"] == {"baked": 2, "skipped": 0, "failed": 0}
    assert (maps / "Stone.png").read_bytes().endswith(NB.PNG_END)
    assert sorted(p.name for p in maps.iterdir()) == ["Rock.png", "Stone.png",
                                                      "surfgrad-bake-manifest.json"]


@pytest.mark.tier("numpy")
def test_working_folders_of_killed_runs_go_only_when_their_run_provably_ended(tmp_path,
                                                                              capfd):
    free = int(open("/proc/sys/kernel/pid_max").read()) - 1
    while os.path.exists(f"/proc/{free}"):
        free -= 1                                 # an id no process of this machine has
    here = run_owner.identity()
    owners = {"killed": dict(here, pid=free, start="1"),
              "reused": dict(here, start=str(int(here["start"]) - 1)),   # our id, not us
              "elsewhere": dict(here, pid=free, boot="another machine"),
              "container": dict(here, pid=free, pid_space="pid:[1]"),
              "live": here}
    for name, owner in [*owners.items(), ("unrecorded", None)]:
        folder = tmp_path / f".demo.partial-{name}"
        folder.mkdir()
        (folder / "index.html").write_text(name)
        if owner:
            (folder / run_owner.RECORD_NAME).write_text(json.dumps(owner))
    with staged(tmp_path / "demo", overwrite=False) as work:
        (work / "index.html").write_text("ours")
    err = capfd.readouterr().err
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [f".demo.partial-{n}" for n in ("container", "elsewhere", "live",
                                                    "unrecorded")] + ["demo"], left
    assert err.count("surfgrad: removed ") == 2 and "partial-killed" in err, err
    assert "4 working folder(s) of other runs" in err and "rm -r " in err, err
    assert sorted(p.name for p in (tmp_path / "demo").iterdir()) == ["index.html"]


@pytest.mark.tier("numpy")
def test_a_manifest_over_the_file_size_limit_names_the_limit(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"surfgrad": "x", "assets": {}}))
    old = path.read_bytes()
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, hard))
    try:
        with pytest.raises(BakeFailed) as err:
            manifest.write_final(path, {"assets": {"a": {"note": "x" * 10000}}})
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert "(File too large)" in str(err.value) and "ulimit -f" in str(err.value), err.value
    assert "disk may be full" not in str(err.value)
    assert path.read_bytes() == old and os.listdir(tmp_path) == ["m.json"]


def test_two_outputs_on_one_file_through_a_symbolic_link_are_refused_before_baking(tmp_path,
                                                                                   capsys):
    for name in ("a", "b"):
        BA.write_asset(tmp_path / f"{name}.blend", ("Rock",), tiles=(1001,), image_size=16)
    out = tmp_path / "out"
    (out / "a").mkdir(parents=True)
    (out / "b").symlink_to("a")
    for pattern, one in ((out / "{file}" / "{object}.png", out / "a" / "Rock.png"),
                         (out / "{file}" / ".." / "{object}.png", out / "Rock.png")):
        for more in ([], ["--overwrite"]):
            rc = commands.execute(["bake-batch", str(tmp_path / "a.blend"),
                                   str(tmp_path / "b.blend"), "--output", str(pattern),
                                   *SMALL, *more])
            err = capsys.readouterr().err
            assert rc == exit_codes.BAD_REQUEST, err             # before: 1, or 0 replaced
            b, a = (str(pattern).format(file=f, object="Rock") for f in "ba")
            assert (f"b.blend:Rock and a.blend:Rock would write {b} and {a}, one file "
                    f"({one.resolve()}, through a symbolic link or '..' on the way)") in err, err
            assert os.listdir(out / "a") == [] and sorted(os.listdir(out)) == ["a", "b"]


def test_a_failed_compare_all_rerun_leaves_the_earlier_heat_maps_and_tables(tmp_path,
                                                                           monkeypatch):
    out = tmp_path / "o"
    CA.run_all(out, 8, methods=["normal-map"], workers=1, log=lambda *_: None)
    before = {p.name: p.read_bytes() for p in (out / "heat").iterdir()}
    tables = [(out / n).read_bytes() for n in ("compare.json", "compare.md")]
    assert len(before) == 4 * len(CA.all_cases(["normal-map"]))     # each case, four objects
    compare_object, calls = CA.compare_object, []

    def fails_on_the_third(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("stands for a stop or a failure midway")
        return compare_object(*args, **kwargs)
    monkeypatch.setattr(CA, "compare_object", fails_on_the_third)
    with pytest.raises(RuntimeError):
        CA.run_all(out, 16, overwrite=True, methods=["normal-map"], workers=1,
                   log=lambda *_: None)
    assert {p.name: p.read_bytes() for p in (out / "heat").iterdir()} == before
    assert [(out / n).read_bytes() for n in ("compare.json", "compare.md")] == tables
    assert sorted(p.name for p in out.iterdir()) == ["compare.json", "compare.md", "heat"]
