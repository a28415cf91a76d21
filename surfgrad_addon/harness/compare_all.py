"""compare-all: every method on every object of the procedural test scene, on both cores.

    python -m surfgrad_addon compare-all --out DIR [--resolution N] [--workers N]
        [--cycles-device CPU|CUDA|OPTIX]

The cases (method, variant, object) are dealt round-robin to `workers` processes (default:
one per core, at most 2): this process runs share 0, child processes (this Python with the
bpy module, `python -m surfgrad_addon.harness.compare_all --shard ...`) the others, each in
its own fresh test scene, writing its heat maps and its reports (a JSON file, removed after)
into a hidden sibling of the heat/ folder, whose heat maps go into heat/ with the tables at
the end (a stopped or failed run leaves the folder as it was). The table and compare.json list the cases in the serial order, so
they are the same for any number of workers. Inside a Blender binary one process runs all.
Every process bakes on the Cycles device asked for (cycles_device.py; each report names it).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ..addon.batch.manifest import hold, release
from ..addon.batch.plan import BatchError
from ..addon.exit_codes import BakeFailed
from ..addon.process_ends import how_it_ended
from ..addon.publish_files import publish
from . import compare_settings as CS
from . import cycles_device as D
from . import run_owner
from .compare import CompareError, compare_object
from .heat_map import write_heat_map
from .methods import METHODS, cases, unavailable_reason
from .staged_folder import clear_leftovers

ROOT = Path(__file__).resolve().parents[2]
SHARD_FILE = ".compare_shard_{}.json"


def compare_cases(methods=None):
    """(method, variant) for every method this Blender can run (methods.cases()), or for
    those of `methods`."""
    return [(m, v) for m, v in cases() if not methods or m in methods]


# Cases at settings other than the defaults (compare_settings.py), each method's first
# variant: Strength 1 and DirectX off were the only values compared, where a group ignoring
# Strength, squaring it, or never flipping green equals the right one
# (tests/test_faults_mutants57d.py); likewise Sharpness 3 and Octaves 4
# (tests/test_faults_settings58c.py).
SETTINGS_CASES = {
    "normal-map": {"strength": 0.6, "directx": True},
    "triplanar": {"strength": 0.6, "directx": True, "sharpness": 8.0},
    "decal": {"strength": 0.6, "directx": True},
    "procedural-basis": {"strength": 0.6, "directx": True},
    # The default Octaves (4) is SG Noise's most: a group that ignored Octaves, summing all
    # four, passed every default case.
    "volume-noise": {"octaves": 2},
}


def all_cases(methods=None):
    """(method, variant, settings) of every case compare-all runs: compare_cases() at the
    defaults (settings None), then the SETTINGS_CASES of the methods among them."""
    plain = compare_cases(methods)
    firsts = {}
    for m, v in plain:
        firsts.setdefault(m, v)
    return ([(m, v, None) for m, v in plain]
            + [(m, firsts[m], SETTINGS_CASES[m]) for m in SETTINGS_CASES if m in firsts])


def default_workers():
    """One process per core (at most 2), when a child can import bpy as this process does."""
    if not _bpy_module():
        return 1
    return max(1, min(2, os.cpu_count() or 1))


def _bpy_module():
    """True when bpy is the pip module in this Python (not a Blender binary's)."""
    import bpy
    binary = getattr(bpy.app, "binary_path", "") or ""
    return not (binary and Path(binary).name.lower().startswith("blender")
                and Path(binary).is_file())


def _label(method, variant, settings=None):
    at = CS.label(settings)
    return (method + (f"-{variant}" if len(METHODS[method].variants) > 1 else "")
            + (f"-{at}" if at else ""))


def run_shard(out, resolution, shard, shards, log=print, methods=None, cycles_device="CPU"):
    """Cases shard, shard + shards, ... of the serial order: {index: report}."""
    import bpy
    from ..addon import interrupts
    from . import scenes
    objects = scenes.new_scene()        # factory settings: the device is chosen after it
    jobs = [(m, v, s, name) for m, v, s in all_cases(methods) for name in objects]
    reports = {}
    with D.selected(bpy.context.scene, cycles_device) as chosen:
        for index in range(shard, len(jobs), shards):
            method, variant, settings, name = jobs[index]
            report, heat = compare_object(objects[name], method, resolution, variant=variant,
                                          log=lambda *_: None, device=chosen.scene_device,
                                          settings=settings)
            report["cycles_device"] = chosen.description
            reports[index] = report
            label = _label(method, variant, settings)
            with interrupts.committing():     # a stop's clean-up sees this map, whole
                write_heat_map(Path(out) / "heat" / f"{label}_{name}.png", heat,
                               overwrite=True)
            log(f"[{index + 1}/{len(jobs)}] {label:22s} {name:12s} p99 "
                f"{report['p99_deg']:.4f} max {report['max_deg']:.4f} deg, bake "
                f"{report['bake_seconds']:.3f} s, reference {report['reference_seconds']:.3f} s")
    return reports


def _start_worker(out, resolution, shard, shards, methods, temp, cycles_device="CPU"):
    """A child running one shard; its errors go to a file (a pipe nobody reads while this
    process runs its own share could fill and stall it). Its temporary files go to `temp`,
    which this process removes: a child killed on a stop cannot clean up after itself. It
    runs in the checkout (cwd=ROOT), so `out` goes to it absolute: a relative --out given from
    another folder was the checkout's, and the run failed (red team 42b)."""
    cmd = [sys.executable, "-m", "surfgrad_addon.harness.compare_all", "--out",
           os.path.abspath(out),
           "--resolution", str(resolution), "--shard", str(shard), "--shards", str(shards),
           "--cycles-device", cycles_device]
    cmd += ["--methods", *methods] if methods else []
    errors = tempfile.TemporaryFile(mode="w+")
    env = dict(os.environ, TMPDIR=str(temp), TEMP=str(temp), TMP=str(temp))
    child = subprocess.Popen(cmd, cwd=ROOT, stderr=errors, text=True, env=env)
    child.errors = errors
    return child


def run_all(out_dir, resolution=64, overwrite=False, log=print, workers=None, methods=None,
            cycles_device="CPU"):
    """Every method (or those of `methods`) on every object of the procedural test scene:
    JSON, a Markdown table and an error heat map per case. A stop (Ctrl-C / SIGTERM) kills
    the workers and takes back what this run wrote (heat maps, the folders it made).
    cycles_device: CPU, CUDA or OPTIX; refused before anything is made when there is none."""
    from ..addon import interrupts
    from ..addon.normal_bake import resolution_problem
    from .compare import RESOLUTION_RANGE, check_output_path
    out = Path(out_dir)
    problem = resolution_problem(resolution, *RESOLUTION_RANGE)
    if problem:                                 # before any folder is made
        raise CompareError(problem)
    table_md, table_json = out / "compare.md", out / "compare.json"
    for p in (table_md, table_json):
        check_output_path(p, overwrite)
    if (out / "heat").exists() and not (out / "heat").is_dir():
        raise CompareError(f"{out / 'heat'} is a file; the heat maps need a folder there")
    unknown = sorted(set(methods or ()) - set(METHODS))
    if unknown:
        raise CompareError(f"no method {unknown[0]!r}; use some of {sorted(METHODS)}")
    devices = D.check(cycles_device)
    created = [d for d in (*reversed(out.parents), out, out / "heat") if not d.exists()]
    _hold(table_json)
    (out / "heat").mkdir(parents=True, exist_ok=True)
    # Every case writes into a hidden sibling of heat/, moved in at the end: a stopped or
    # failed rerun with --overwrite left its heat maps among the earlier run's, whose tables
    # they did not match (red team 44c). A killed run's goes as staged_folder's do.
    stage = out / f".heat.partial-{os.getpid()}-{interrupts.PART_TOKEN}"
    (stage / "heat").mkdir(parents=True)
    run_owner.record(stage)
    clear_leftovers(out / "heat", stage)
    temp = Path(tempfile.mkdtemp(prefix="surfgrad-compare-all-"))
    children = []
    committed = []

    def forget(_signal_name=None):
        """Kill the workers, remove their temporary files, this run's heat maps and the
        folders it made: on a stop, and on a failure (a run that fails writes nothing). Once
        its files are moved in (a stop waits for that), the run is whole: they stay."""
        for child in children:
            if child.poll() is None:
                child.kill()
                child.wait()
        shutil.rmtree(temp, ignore_errors=True)
        shutil.rmtree(stage, ignore_errors=True)
        release(table_json)                   # its lock file is in a folder removed next
        for d in reversed(created if not committed else ()):
            try:
                d.rmdir()
            except OSError:
                pass

    with interrupts.on_stop(forget):
        try:
            for method in METHODS:
                if unavailable_reason(method) is not None:
                    log(f"skipped {method}: {unavailable_reason(method)}")
            workers = default_workers() if workers is None else max(1, int(workers))
            if workers > 1 and not _bpy_module():
                log("compare-all: inside a Blender binary one process runs every case")
                workers = 1
            for k in range(1, workers):
                with interrupts.committing():     # a stop's clean-up sees every child
                    children.append(_start_worker(stage, resolution, k, workers, methods,
                                                  temp, cycles_device))
            reports = _collect(stage, resolution, workers, methods, children, log,
                               cycles_device)
        except BaseException as err:
            forget()
            if isinstance(err, OSError):        # a heat map the disk would not take
                raise _not_written(out, err) from None
            raise
        finally:
            for k, child in enumerate(children, start=1):
                if child.poll() is None:
                    child.kill()
                    child.wait()
                child.errors.close()
                (stage / SHARD_FILE.format(k)).unlink(missing_ok=True)
            shutil.rmtree(temp, ignore_errors=True)
        try:
            # A full disk or a file-size limit: before, a cut-off compare.json was left with
            # the heat maps and a raw OSError traceback. Now nothing is moved in.
            (stage / table_json.name).write_text(json.dumps(reports, indent=2))
            (stage / table_md.name).write_text(table_markdown(reports, resolution,
                                                              cycles_device, devices))
        except OSError as err:
            forget()
            raise _not_written(out, err) from None
        with interrupts.committing():             # every file or, on a stop before, none
            committed.append(True)
            try:
                publish([(f, out / "heat" / f.name) for f in sorted((stage / "heat").iterdir())]
                        + [(stage / p.name, p) for p in (table_json, table_md)], True,
                        FileExistsError)
            except BaseException:
                committed.clear()             # every file as it was: this run made nothing
                forget()
                raise
            shutil.rmtree(stage, ignore_errors=True)
    release(table_json)
    log(f"wrote {table_md}, {table_json} and {len(reports)} heat maps in {out / 'heat'}")
    return reports


def _hold(table_json):
    """This run's hold on its output folder (the manifest's lock, on compare.json), or a
    CompareError when another compare-all holds it. Two runs into one --out both passed the
    check, both exited 0, and the tables and heat maps left were a mix of the two (the first's
    replaced without --overwrite); one that failed removed the other's heat maps."""
    try:
        hold(table_json)
    except BatchError:
        raise CompareError(f"{str(table_json.parent)!r} is in use by another compare-all run "
                           f"(it holds {str(table_json.with_name('.compare.json.lock'))!r}): "
                           f"wait for that run to end, or give this one another --out") from None


def _not_written(out, err):
    return BakeFailed(f"could not write the tables and heat maps in {str(out)!r} ({err}): "
                      f"free space there (the disk may be full) or check the folder's "
                      f"permissions, and compare again")


def _collect(out, resolution, workers, methods, children, log, cycles_device="CPU"):
    """This process's shard, then each worker's: the reports in the serial order."""
    reports = run_shard(out, resolution, 0, workers, log, methods, cycles_device)
    for k, child in enumerate(children, start=1):
        child.wait()
        child.errors.seek(0)
        err = child.errors.read()
        shard_file = out / SHARD_FILE.format(k)
        if child.returncode != 0 or not shard_file.is_file():
            raise worker_failure(k, child.returncode, err)
        reports.update({int(i): r for i, r in json.loads(shard_file.read_text()).items()})
    return [reports[i] for i in sorted(reports)]


def worker_failure(k, returncode, err):
    """A failure after baking began (exit 1), not a refused request (2, as before). One
    killed by a signal names it: "exit -9: no output" did not say SIGKILL (red team 43a)."""
    lines = (err or "").strip().splitlines()
    return BakeFailed(f"compare-all worker {k} failed ({how_it_ended(returncode)})"
                      f"{': ' + lines[-1] if lines else ''}")


def table_markdown(reports, resolution, cycles_device="CPU", devices=()):
    on = "" if cycles_device == "CPU" else f", Cycles on {cycles_device} ({', '.join(devices)})"
    lines = [f"# Bakes against the reference at {resolution}^2{on}",
             "", "Angular error (degrees) between the Cycles bake of each method's node groups "
             "and the numpy reference, over every texel both cover (contested texels of "
             "overlapping UVs included: the reference follows the bake's rule); excluded "
             "texels counted by reason (edge: within float32 rounding of a triangle edge; "
             "outside: covered by one side only).", "",
             "| method | scene | texels | contested | excluded | edge | outside | mean | p99 | "
             "max | bake s | reference s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in reports:
        at = CS.label(r.get("settings"))
        label = r["method"] + "".join(f" ({x})" for x in (r["variant"], at) if x)
        lines.append(f"| {label} | {r['object']} | {r['texels_compared']} | "
                     f"{r['texels_contested']} | {100 * r['excluded_fraction']:.2f}% | "
                     f"{r['excluded']['edge']} | {r['excluded']['outside']} | "
                     f"{r['mean_deg']:.5f} | "
                     f"{r['p99_deg']:.4f} | {r['max_deg']:.4f} | {r['bake_seconds']:.3f} | "
                     f"{r['reference_seconds']:.3f} |")
    worst = max(reports, key=lambda r: r["max_deg"])
    lines += ["", f"Worst case: {worst['method']} on {worst['object']}, max "
                  f"{worst['max_deg']:.4f} deg (bar: p99 0.1, max 0.5)."]
    return "\n".join(lines) + "\n"


def _main():
    """A worker: one shard's heat maps, and its reports in the output folder."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", required=True)
    parser.add_argument("--resolution", type=int, required=True)
    parser.add_argument("--shard", type=int, required=True)
    parser.add_argument("--shards", type=int, required=True)
    parser.add_argument("--methods", nargs="*", default=None)
    parser.add_argument("--cycles-device", default="CPU", choices=D.KINDS)
    args = parser.parse_args()
    reports = run_shard(args.out, args.resolution, args.shard, args.shards,
                        log=lambda line: print(line, flush=True), methods=args.methods,
                        cycles_device=args.cycles_device)
    path = Path(args.out) / SHARD_FILE.format(args.shard)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(reports))
    tmp.replace(path)


if __name__ == "__main__":
    _main()
