"""Object names a Flamenco job carries: the `objects` setting is one comma-separated string, so
a name holding a comma must survive the trip (the add-on's eval escapes it, the job type
splits on unescaped commas only), and a name that is a path to the file system ('..', 'a/b')
must not move a task's manifest out of the manifest folder or onto another task's."""

import json
from pathlib import Path

import pytest

from support.flamenco import compile_job, run_task_as_worker

pytestmark = pytest.mark.tier("child")


class _Obj:
    def __init__(self, name, kind="MESH"):
        self.name, self.type = name, kind


class _Context:
    def __init__(self, objects):
        self.selected_objects = objects


def _as_addon_evaluates(names):
    """The `objects` value the Flamenco add-on computes: the job type's own eval expression,
    run in Python on selected objects with these names (and one non-mesh, left out)."""
    base = {"objects": "A", "blendfile": "/p/a.blend", "output_pattern": "/p/{object}.png",
            "manifest_dir": "/p/m"}
    spec = next(s for s in compile_job(base)["job_type"]["settings"] if s["key"] == "objects")
    selected = [_Obj(n) for n in names] + [_Obj("Camera, main", "CAMERA")]
    return eval(spec["eval"], {"C": _Context(selected)})


NAMES = ["Rock, big", "Tree", "back\\slash", "trailing\\", "a,b,,c", ",lead"]


def _tasks(objects, tiles="1001", pattern="/p/maps/{object}.png"):
    job = compile_job({"objects": objects, "tiles": tiles, "blendfile": "/p/a.blend",
                    "output_pattern": pattern, "manifest_dir": "/p/m"})
    assert "error" not in job, job
    out = []
    for task in job["tasks"]:
        args = task["commands"][0]["parameters"]["args"]
        (obj,) = [a[len("--objects="):] for a in args if a.startswith("--objects=")]
        out.append((obj, args[args.index("--tiles") + 1], args[args.index("--manifest") + 1]))
    return out


def test_selected_names_with_commas_and_backslashes_each_become_one_task():
    value = _as_addon_evaluates(NAMES)
    assert [obj for obj, _, _ in _tasks(value)] == NAMES
    # What an artist types: commas between names, spaces around them ignored, a repeat once.
    assert [obj for obj, _, _ in _tasks(" Tree , Bush,Tree, Rock\\, big")] == \
        ["Tree", "Bush", "Rock, big"]


def test_manifest_names_stay_in_the_folder_and_apart():
    names = ["..", ".", "a/b", "a_b", "A_B", "../../etc/x", "C:\\x", "Tree"]
    # ({uv} in the pattern: their maps may be apart by UV map; with {object} alone 'a/b' and
    # 'a_b' are one file, and the job is refused: tests/test_faults_farm53c.py)
    tasks = _tasks(",".join(n.replace("\\", "\\\\").replace(",", "\\,") for n in names),
                   "1001-1002", "/p/maps/{object}_{uv}.png")
    assert [obj for obj, _, _ in tasks[::2]] == names
    manifests = [Path(m) for _, _, m in tasks]
    assert all(m.parent == Path("/p/m") for m in manifests), manifests
    assert all(not m.name.startswith(".") for m in manifests), manifests
    # One manifest per task, also where the folder ignores case.
    assert len({m.name.lower() for m in manifests}) == len(tasks)
    # A name that is safe keeps its manifest name (resubmitted jobs find their manifests).
    assert ("Tree", "1002", "/p/m/Tree-1002.json") in tasks


def test_a_task_for_an_object_named_with_a_comma_and_a_slash_bakes_it(tmp_path):
    """The compiled command, run as a worker's Blender would, bakes exactly that object and
    writes its manifest inside the manifest folder."""
    from surfgrad_addon.harness import batch_assets as BA
    blend = tmp_path / "a.blend"
    BA.write_asset(blend, ("Rock, big/1", "Rock"), tiles=(1001,), image_size=16)
    job = compile_job({"objects": _as_addon_evaluates(["Rock, big/1"]), "tiles": "1001",
                    "blendfile": str(blend), "resolution": 16, "samples": 1, "margin": 2,
                    "output_pattern": str(tmp_path / "maps" / "{object}.png"),
                    "manifest_dir": str(tmp_path / "m")})
    (task,) = job["tasks"]
    res = run_task_as_worker(task)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    made = sorted(str(f.relative_to(tmp_path)) for f in tmp_path.rglob("*") if f.is_file())
    assert [m for m in made if m != "a.blend"] == ["m/Rock, big_1-1001.json",
                                                   "maps/Rock, big_1.png"], made
    manifest = json.loads((tmp_path / "m" / "Rock, big_1-1001.json").read_text())
    assert "Rock, big/1" in json.dumps(manifest)
