"""Red team 49c: what a run killed (SIGKILL) while putting its files in place leaves.

1. publish_files keeps each old file aside as a hidden `.NAME.old-PID-TOKEN` until every new
   one is in place. A staged output folder's run (the main job, the bench) removed its owner
   record before moving its files in, so a run killed then left backups and a working folder
   that no later run could prove ended: both stayed for good, named once as maybe a live run's.
   Now the record stays until every file is in, and the next run into that folder removes a
   provably ended run's backups whose final file exists (one line each); a backup whose final
   name is gone is the only copy of that file: named with the command that puts it back, kept.
2. A batch's maps kept aside the same way (`.Rock.png.old-PID-TOKEN`, which carry no owner
   record) were not named by the batch's next run into that folder, as its temporary files
   are: now they are, in one warning, with those that are a map's only copy told apart.
"""

import json
import os

import pytest

from surfgrad_addon.harness import run_owner
from surfgrad_addon.harness import staged_folder as SF

pytestmark = pytest.mark.tier("numpy")


def _free_pid():
    free = int(open("/proc/sys/kernel/pid_max").read()) - 1
    while os.path.exists(f"/proc/{free}"):
        free -= 1                                 # an id no process of this machine has
    return free


def test_a_killed_runs_backups_go_only_where_it_ended_and_the_final_file_exists(tmp_path,
                                                                              capfd):
    here = run_owner.identity()
    final = tmp_path / "demo"
    final.mkdir()
    runs = {f"{_free_pid()}-0123abcd": dict(here, pid=_free_pid(), start="1"),   # killed
            f"{os.getpid()}-4567cdef": here}                                      # live
    for run, owner in runs.items():
        work = tmp_path / f".demo.partial-{run}"
        work.mkdir()
        (work / run_owner.RECORD_NAME).write_text(json.dumps(owner))
        for name in ("index.html", "gone.png"):
            (final / f".{name}.old-{run}").write_text(f"old {name}")
    (final / "index.html").write_text("the killed run's new page")
    with SF.staged(final, overwrite=True) as work:
        (work / "table.json").write_text("ours")
    err = capfd.readouterr().err
    killed, live = runs
    left = sorted(p.name for p in final.iterdir())
    assert left == sorted([f".gone.png.old-{killed}", f".gone.png.old-{live}",
                           f".index.html.old-{live}", "index.html", "table.json"]), left
    assert (final / f".gone.png.old-{killed}").read_text() == "old gone.png"
    assert err.count("surfgrad: removed ") == 2, err      # the backup and the working folder
    assert f"only copy of {final / 'gone.png'}" in err and "mv " in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == [f".demo.partial-{live}", "demo"]


def test_the_owner_record_stays_until_every_file_is_in_place(tmp_path, monkeypatch):
    final = tmp_path / "demo"
    final.mkdir()
    (final / "index.html").write_text("old")
    seen = []
    real = SF.publish

    def publish(pairs, *args, **kwargs):
        work = pairs[0][0].parent
        seen.append((run_owner.gone(work), (work / run_owner.RECORD_NAME).exists(),
                     sorted(final.name for _, final in pairs)))
        return real(pairs, *args, **kwargs)

    monkeypatch.setattr(SF, "publish", publish)
    with SF.staged(final, overwrite=True) as work:
        (work / "index.html").write_text("new")
    assert seen == [(False, True, ["index.html"])], seen
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]
    assert sorted(p.name for p in final.iterdir()) == ["index.html"]
    assert (final / "index.html").read_text() == "new"


def test_a_batch_names_old_maps_other_runs_kept_aside_and_the_sole_copies(tmp_path):
    from surfgrad_addon.addon import interrupts
    from surfgrad_addon.addon.batch import run
    (tmp_path / "Rock.png").write_text("new")
    for name in ("Rock.png", "Moss.1001.png"):
        (tmp_path / f".{name}.old-77-0123abcd").write_text("old")
    (tmp_path / f".Mine.png.old-{os.getpid()}-{interrupts.PART_TOKEN}").write_text("ours")
    said = []
    run._note_leftovers(tmp_path, said.append)
    assert said == [
        f"2 old file(s) kept aside by other runs in {str(tmp_path)!r} (.Moss.1001.png.old-77-"
        f"0123abcd, .Rock.png.old-77-0123abcd): left by runs killed while putting their maps "
        f"in place, or runs under way elsewhere; once no run writes there, remove them, "
        f"except .Moss.1001.png.old-77-0123abcd: the only copy of a map whose name is gone, "
        f"rename it back to that name (without the leading '.' and the '.old-...' end)"], said
    assert len(list(tmp_path.iterdir())) == 4                      # nothing removed
