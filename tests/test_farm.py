"""The farm files (tools/farm): the Open Job Description template runs with openjd-cli on a few
small assets (one task per asset x tile), and the Flamenco job type compiles with node against
a stand-in for Flamenco's compiler globals into the tasks and commands expected, whose command
line bakes when run."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.harness import batch_assets as BA  # noqa: E402
from support.child import ROOT, run_python  # noqa: E402
from support.flamenco import compile_job, run_task_as_worker  # noqa: E402

pytestmark = pytest.mark.tier("child")


TEMPLATE = ROOT / "tools" / "farm" / "openjd" / "surfgrad-bake.yaml"


def _openjd():
    for cand in (os.environ.get("SURFGRAD_OPENJD"), Path(sys.executable).parent / "openjd",
                 shutil.which("openjd")):
        if cand and Path(cand).is_file():
            return str(cand)
    pytest.skip("openjd-cli is not installed here (requirements.txt pins it for the 5.2 line; "
                "or set SURFGRAD_OPENJD)")


def _pixels(path):
    img = bpy.data.images.load(str(path))
    img.colorspace_settings.name = "Non-Color"
    px = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px


@pytest.fixture
def farm_assets(tmp_path):
    BA.write_asset(tmp_path / "in" / "a.blend", ("Rock",), tiles=(1001, 1002), image_size=16)
    BA.write_asset(tmp_path / "in" / "b.blend", ("Tree", "Bush"), tiles=(1001,), image_size=16,
                   seed=5)
    (tmp_path / "in" / "c.blend").write_text("not a blend")
    lst = tmp_path / "assets.txt"
    lst.write_text("# asset list\nin/a.blend\nin/b.blend:Tree\nin/c.blend\n")
    return lst


def _openjd_run(openjd, tmp_path, lst, indices, out):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    params = {"AssetList": str(lst), "AssetIndices": indices, "Tiles": "1001-1002",
              "OutputPattern": str(out / "{file}_{object}.<UDIM>.png"),
              "ManifestDir": str(out / "manifests"), "Resolution": 16, "Samples": 2,
              "Launcher": f"{sys.executable} -m surfgrad_addon"}
    args = [openjd, "run", str(TEMPLATE)]
    for k, v in params.items():
        args += ["-p", f"{k}={v}"]
    return subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)


def test_openjd_template_runs_one_task_per_asset_and_tile(farm_assets, tmp_path):
    openjd = _openjd()
    check = subprocess.run([openjd, "check", str(TEMPLATE)], capture_output=True, text=True)
    assert check.returncode == 0 and "passes validation" in check.stdout, check.stdout
    out = tmp_path / "out"
    res = _openjd_run(openjd, tmp_path, farm_assets, "0-1", out)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert sorted(p.name for p in out.glob("*.png")) == ["a_Rock.1001.png", "a_Rock.1002.png",
                                                         "b_Tree.1001.png"]
    assert sorted(p.name for p in (out / "manifests").glob("*.json")) == [
        f"asset-{a}-tile-{t}.json" for a in (0, 1) for t in (1001, 1002)]
    m = json.loads((out / "manifests" / "asset-1-tile-1002.json").read_text())
    (entry,) = m["assets"].values()
    assert entry["object"] == "Tree" and entry["status"] == "baked" and entry["files"] == {}
    # The farm's tiles are the local batch's tiles.
    local = tmp_path / "local"
    r = run_python(["-m", "surfgrad_addon", "bake-batch", str(tmp_path / "in" / "a.blend"),
                    "--output", str(local / "{file}_{object}.<UDIM>.png"), "--resolution",
                    "16", "--samples", "2", "--workers", "0"])
    assert r.returncode == 0, r.stderr[-2000:]
    for t in (1001, 1002):
        assert np.abs(_pixels(out / f"a_Rock.{t}.png")
                      - _pixels(local / f"a_Rock.{t}.png")).max() < 1e-6
    # A rerun skips unchanged tasks; a bad asset fails its own tasks with the reason.
    res = _openjd_run(openjd, tmp_path, farm_assets, "0", out)
    assert res.returncode == 0, res.stdout[-3000:]
    assert res.stdout.count("[batch] 0 baked, 1 skipped, 0 failed") == 2, res.stdout[-3000:]
    res = _openjd_run(openjd, tmp_path, farm_assets, "2", out)
    assert res.returncode != 0
    assert "c.blend is named .blend but is not a Blender file" in res.stdout + res.stderr


def test_openjd_outputs_resolve_to_absolute_paths_on_submission(farm_assets, tmp_path):
    """A task runs in a temporary session folder: a relative output would vanish with it.
    OutputPattern and ManifestDir are PATH parameters, made absolute against the submitter's
    folder; the task script refuses any that still is not (another runner)."""
    openjd = _openjd()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(ROOT)
    args = [openjd, "run", str(TEMPLATE), "-p", f"AssetList={farm_assets}",
            "-p", "AssetIndices=1", "-p", "Tiles=1001", "-p", "OutputPattern=maps/{object}.png",
            "-p", "ManifestDir=maps/manifests", "-p", "Resolution=16",
            "-p", f"Launcher={sys.executable} -m surfgrad_addon"]
    res = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stdout[-3000:]
    assert sorted(str(p.relative_to(tmp_path)) for p in (tmp_path / "maps").rglob("*.*")) == [
        "maps/Tree.png", "maps/manifests/asset-1-tile-1001.json"]
    # The task script itself, given a relative path as-is.
    text = TEMPLATE.read_text()
    script = text[text.index("data: |") + len("data: |"):text.index("actions:")]
    script = "\n".join(line[12:] for line in script.splitlines())
    for output, manifests in (("maps/x.png", "/m"), ("/o/x.png", "m")):
        # The script's arguments, in the order of the template's args (Launcher first).
        argv = ["false", "list.txt", "0", "1001", output, manifests, "16", "1", "0",
                "tangent", "auto", "no"]
        res = subprocess.run(["bash", "-c", script, "bash", *argv], cwd=tmp_path,
                             capture_output=True, text=True, timeout=60)
        assert res.returncode == 2, res.stderr
        assert "is relative: a farm task runs in a temporary folder" in res.stderr


def _job_type():
    """The job type's settings, as the Manager lists them to the add-on."""
    job = compile_job({"objects": "A", "blendfile": "/p/a.blend", "output_pattern": "/p/{object}.png",
                    "manifest_dir": "/p/m"})
    return job["job_type"]["settings"]


def _as_addon_submits(project_blend, farm_blend, **given):
    """The settings Flamenco's add-on sends: every setting (its property holds the default
    unless set), the hidden ones evaluated in the artist's Blender (abspath: '//' is the
    folder of the file being submitted), blendfile the farm's copy (Shaman's checkout)."""
    def abspath(p):
        return str(Path(project_blend).parent / p[2:]) if p.startswith("//") else p
    settings = {s["key"]: s["default"] for s in _job_type() if "default" in s}
    settings.update(given)
    settings["output_path"] = abspath(settings["output_pattern"])
    settings["manifest_path"] = abspath(settings["manifest_dir"])
    settings["blendfile"] = str(farm_blend)
    return settings


def test_flamenco_job_type_compiles_to_one_blender_task_per_object_and_tile(farm_assets,
                                                                           tmp_path):
    project = tmp_path / "in" / "b.blend"
    farm = tmp_path / "shaman" / "job-0001" / "b.blend"       # the farm's copy of the file
    farm.parent.mkdir(parents=True)
    shutil.copy(project, farm)
    job = compile_job(_as_addon_submits(project, farm, objects="Tree, Bush", tiles="1001-1002",
                                     resolution=16, samples=2))
    keys = [s["key"] for s in job["job_type"]["settings"]]
    assert {"objects", "tiles", "output_pattern", "resolution", "samples", "blendfile"} <= \
        set(keys)
    assert [t["name"] for t in job["tasks"]] == ["bake Tree 1001", "bake Tree 1002",
                                                 "bake Bush 1001", "bake Bush 1002"]
    for task in job["tasks"]:
        assert task["type"] == "blender" and len(task["commands"]) == 1
        cmd = task["commands"][0]
        assert cmd["name"] == "blender-render"
        p = cmd["parameters"]
        assert p["exe"] == "{blender}" and p["exeArgs"] == "{blenderArgs}"
        # An uncaught Python error must fail the task: the exit code flag comes first.
        assert p["blendfile"] == str(farm)
        assert p["argsBefore"] == ["--disable-autoexec"]     # the file's scripts stay off
        assert p["args"][:3] == ["--python-exit-code", "1", "--python-expr"]
        args = p["args"][p["args"].index("--") + 1:]
        assert args[:3] == ["bake-batch", "--open-file", f"--objects={task['name'].split()[1]}"]
        assert args[args.index("--tiles") + 1] == task["name"].split()[2]
        # '//' resolved on submission against the project's file, not the farm's copy.
        assert args[args.index("--output") + 1] == \
            str(tmp_path / "in" / "maps" / "{file}_{object}.<UDIM>.png")
        assert args[args.index("--manifest") + 1].startswith(str(tmp_path / "in" / "maps"))
        assert args[args.index("--resolution") + 1] == "16"
    blend = str(project)
    bad = compile_job({"objects": "Tree", "tiles": "1001-99", "blendfile": blend,
                    "output_pattern": "/o/{object}.png", "manifest_dir": "/o"})
    assert "tiles '1001-99'" in bad["error"]
    assert "objects" in compile_job({"objects": " , ", "blendfile": blend})["error"]

    # Run two of the commands as a worker's Blender would.
    for task in job["tasks"][:2]:
        res = run_task_as_worker(task)
        assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    maps = tmp_path / "in" / "maps"
    assert sorted(p.name for p in maps.glob("*.png")) == ["b_Tree.1001.png"]
    assert sorted(p.name for p in (maps / "manifests").glob("*.json")) == ["Tree-1001.json",
                                                                            "Tree-1002.json"]
    assert sorted(p.name for p in farm.parent.rglob("*")) == ["b.blend"]   # nothing there


def test_flamenco_job_type_takes_settings_as_the_manager_passes_them(tmp_path):
    """The Manager passes the submitted settings as they are (no defaults) to a script run in
    strict mode: a submission without the add-on (the API) gets the job type's own defaults,
    and an output relative to the blend file is refused with the fix, not baked into the
    farm's copy of the file."""
    blend = "/farm/jobs/0001/b.blend"
    job = compile_job({"objects": "Tree", "blendfile": blend,
                    "output_pattern": "/proj/maps/{file}_{object}.<UDIM>.png",
                    "manifest_dir": "/proj/maps/manifests/"})
    (task,) = job["tasks"]
    args = task["commands"][0]["parameters"]["args"]
    given = dict(zip(args, args[1:]))                 # each flag -> the value after it
    assert given["--tiles"] == "1001" and given["--resolution"] == "2048"
    assert given["--samples"] == "16" and given["--space"] == "tangent"
    assert given["--depth"] == "auto" and given["--margin"] == "16"
    assert given["--manifest"] == "/proj/maps/manifests/Tree-1001.json"
    for settings in ({"objects": "Tree", "blendfile": blend},
                     {"objects": "Tree", "blendfile": blend, "output_pattern": "maps/x.png",
                      "manifest_dir": "/m"},
                     {"objects": "Tree", "blendfile": blend, "output_pattern": "/o/x.png",
                      "manifest_dir": "//maps/manifests"}):
        err = compile_job(settings)["error"]
        assert "is relative: on the farm it would resolve inside the job's copy" in err, err
        assert "give an absolute path" in err
    assert "blendfile" in compile_job({"objects": "Tree", "output_pattern": "/o/x.png",
                                    "manifest_dir": "/m"})["error"]
    # The stand-in is as strict as the Manager: strict mode, settings exactly as submitted.
    sloppy = tmp_path / "sloppy.js"
    sloppy.write_text("const JOB_TYPE = {label: 'x', settings: [{key: 'n', type: 'int32', "
                      "default: 3}]};\n"
                      "function compileJob(job) { leaked = Object.keys(job.settings); }\n")
    assert "leaked is not defined" in compile_job({}, sloppy)["error"]
    echo = tmp_path / "echo.js"
    echo.write_text("const JOB_TYPE = {label: 'x', settings: [{key: 'n', type: 'int32', "
                    "default: 3}]};\n"
                    "function compileJob(job) { throw JSON.stringify(job.settings); }\n")
    assert json.loads(compile_job({"m": 1}, echo)["error"]) == {"m": 1}
