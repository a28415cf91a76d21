"""The harness's command line, `python -m surfgrad_addon <command> ...` (DESCRIPTION lists the
commands). Each subcommand is one row of SUBCOMMANDS: its options and what runs it, a thin
adapter over the module that does the job; bake-normal-map and bake-batch are the extension's
own rows (addon/commands.py SHIPPED, also `blender -c surfgrad`), and addon/command_line.py
builds both command lines from their tables.
"""

import os
import sys
from pathlib import Path

from ..addon import command_line as CL
from ..addon import number_options as NO
from ..addon.commands import SHIPPED
from ..reference.decals import DECAL_SHAPES

# The shared number types (addon/number_options.py): checked while parsing, before any work.
_SIZE = NO.whole(*NO.COMPARE_RESOLUTION_RANGE)       # a compare's or bench's bake size
_REPEATS = NO.whole(*NO.REPEATS_RANGE)

PROG = "python -m surfgrad_addon"
DESCRIPTION = f"""Command line: {PROG} <command> ...

  demo             the main job: evaluate the reference on procedural scenes (maps and a
                   summary), bake every method with Cycles and compare (compare-all),
                   chart speed against accuracy (bench --quick), build demo.blend and render
                   its exhibits
  bench-reference  throughput of the reference evaluator (listings, whole methods), its time
                   against Cycles' bake and its peak memory per size (JSON)
  bench-compare    a whole compare's wall time against the bake alone (2048^2, 4096^2; JSON)
  compare-all      every method on every procedural test object: table, JSON, heat maps
  bake-normal-map  bake an object's material into a tangent- or object-space normal map file
  bake-batch       bake many objects / collections / .blend files: UDIM tiles, per-asset
                   settings, skip unchanged, several worker processes, a JSON manifest
  batch-assets     small procedural assets to try bake-batch on
  bench-batch      scale figures of bake-batch (assets per second with 1 and 2 workers)
  demo-blend       build demo.blend from code (exhibits, packed textures), render pictures
  bench            speed against accuracy of every method (charts, table, JSON, heat maps)
                   and the stability suite
  bench-render     render cost of the surface-gradient groups against Blender's own nodes
  bench-far        every method 0, 1 km and 10 km from the origin against the reference,
                   beside Blender's built-in node for the same job (JSON and Markdown)
  compare          bake a method's node groups with Cycles and compare with the reference
                   (needs bpy; also: blender -b --disable-autoexec FILE
                   --python-exit-code 1 --python surfgrad_addon/blender_cli.py -- compare ...)
"""


def _method_names():
    """The registry's method names (harness/methods.py; it needs bpy, which compare does)."""
    try:
        from .methods import METHODS
    except ImportError:
        return None
    return sorted(METHODS)


def _sizes(given, default):
    """A size list option: the module's default when not given (an empty list is none)."""
    return default if given is None else tuple(given)


def _out(p, default, what="output folder", is_file=False):
    p.add_argument("--out", default=default, help=what)
    p.set_defaults(out_is_file=is_file, out_example=Path(default).name)


def _out_problem(args):
    """Why --out cannot take this command's files (None when it can), before any work: a
    place no file can be made in (read-only, another user's, /proc), a dangling symbolic
    link, a name too long. Without this, a traceback once the command wrote (bench-reference
    and bench-compare after minutes of work). A folder output is written into its parent
    first too (staged_folder.py), so both are tried."""
    from ..addon.bake_request import folder_problem, name_problem
    out = getattr(args, "out", None)
    if out is None:
        return None
    if args.out_is_file and str(out).endswith(("/", os.sep)):
        # Path() drops the slash: `--out reports/` wrote a JSON file named `reports`.
        return (f"{str(out)!r} ends in '/', a folder, and this command writes one file: give "
                f"a file name in it (e.g. {os.path.join(out, args.out_example)!r})")
    out = Path(os.path.abspath(out))
    folders = [out.parent] if args.out_is_file else [out.parent, out]
    return next((p for p in map(folder_problem, folders) if p), None) or \
        name_problem(out, "output file")


def _overwrite(p, what="replace existing outputs"):
    p.add_argument("--overwrite", action="store_true", help=what)


# demo ---------------------------------------------------------------------------------------

def demo_arguments(p):
    _out(p, "out/demo", "output folder (default out/demo)")
    # --resolution is stage 1's reference maps (numpy, no bake); the bakes are stage 2's
    # --compare-resolution. The help said "bake size" for both.
    p.add_argument("--resolution", type=_SIZE, default=256,
                   help="texels per side of stage 1's reference maps, numpy only (default 256; "
                        "the bakes' size is --compare-resolution)")
    _overwrite(p)
    p.add_argument("--compare-resolution", type=_SIZE, default=64,
                   help="bake size in texels of the bake-vs-reference stage (compare-all; "
                        "default 64)")
    p.add_argument("--no-bake", action="store_true",
                   help="skip every Cycles stage: the reference maps (numpy only) and the "
                        "report page")
    p.add_argument("--pictures", action="store_true",
                   help="also render the exhibits (minutes; the page otherwise shows the "
                        "committed ones in docs/exhibits)")


def demo_run(args):
    """The main job in stages, each announced with its number and time, ending with the
    report page (out/demo/index.html) that shows what the run proved. Written whole or not
    at all: into a hidden sibling folder, moved into --out at the end (staged_folder.py)."""
    import time
    from ..addon.normal_bake import resolution_problem
    from . import main_job
    from .compare import RESOLUTION_RANGE
    from .report_page import write_report_page
    if args.no_bake and args.pictures:
        # The pictures are Cycles renders, a stage --no-bake skips: both ran no picture, exit 0.
        raise ValueError("--pictures renders the exhibits with Cycles, and --no-bake skips "
                         "every Cycles stage: give one of them")
    sizes = [("--resolution", args.resolution)] + \
        ([] if args.no_bake else [("--compare-resolution", args.compare_resolution)])
    for option, value in sizes:                # before any stage runs
        problem = resolution_problem(value, *RESOLUTION_RANGE)
        if problem:
            raise ValueError(f"{option}: {problem}")
    start = time.perf_counter()
    stages = ["reference maps and summary"]
    if not args.no_bake:
        stages += ["bake every method and compare (compare-all)", "quick bench",
                   "demo.blend"] + (["exhibit pictures"] if args.pictures else [])
    stages.append("report page")
    done = iter(range(1, len(stages) + 1))

    def stage(name):
        print(f"surfgrad: [{next(done)}/{len(stages)}] {name} "
              f"({time.perf_counter() - start:.0f} s so far)", flush=True)

    def stages_in(work, log):
        stage(stages[0])
        main_job.run(work, args.resolution, log=log)
        if not args.no_bake:
            from . import compare_all, demo, demo_pictures
            from .bench import run as bench_run
            stage(stages[1])
            compare_all.run_all(work / "compare", args.compare_resolution, log=log)
            stage(stages[2])
            bench_run.run(work / "bench", quick=True, log=log)
            stage(stages[3])
            cams = demo.save_demo(work / "demo.blend", log=log)
            if args.pictures:
                stage(stages[4])
                demo_pictures.render_pictures(cams, work / "pictures", log=log)
        stage(stages[-1])
        write_report_page(work, job_seconds=time.perf_counter() - start, log=log,
                          shown_as=args.out)

    _whole(args, stages_in)
    print(f"surfgrad: done in {time.perf_counter() - start:.0f} s; open "
          f"{Path(args.out) / 'index.html'}", flush=True)


# bench-reference ----------------------------------------------------------------------------

def bench_reference_arguments(p):
    _out(p, "out/bench_reference.json", "JSON output path", is_file=True)
    p.add_argument("--sizes", type=_SIZE, nargs="*", default=None, action=NO.Distinct,
                   help="sizes of the listing table (default 256 512 1024 2048; none: skip)")
    p.add_argument("--method-sizes", type=_SIZE, nargs="*", default=None, action=NO.Distinct,
                   help="sizes of the whole-method table (default 256 1024 2048 4096; none: "
                        "skip)")
    p.add_argument("--compare-sizes", type=_SIZE, nargs="*", default=None, action=NO.Distinct,
                   help="sizes of the compare runs against Cycles (default 1024 2048; none: "
                        "skip)")
    p.add_argument("--memory-sizes", type=_SIZE, nargs="*", default=None, action=NO.Distinct,
                   help="sizes of the peak-memory compare runs (default 1024 2048 4096; 8192 "
                        "needs about 8 GB)")
    p.add_argument("--methods", nargs="+", default=None,
                   help="compare methods to run (default: all)")
    p.add_argument("--repeats", type=_REPEATS, default=3, help="runs per figure (median)")
    _overwrite(p, "replace an existing JSON")


def bench_reference_run(args):
    from .bench import reference as br
    tables = {"--sizes": _sizes(args.sizes, br.SIZES),
              "--method-sizes": _sizes(args.method_sizes, br.METHOD_SIZES),
              "--compare-sizes": _sizes(args.compare_sizes, br.COMPARE_SIZES),
              "--memory-sizes": _sizes(args.memory_sizes, br.MEMORY_SIZES)}
    if not any(tables.values()):
        # Every table skipped wrote a JSON of empty tables, exit 0.
        raise ValueError(f"{', '.join(tables)} are all empty: nothing to measure; give sizes "
                         f"to at least one of them (or leave one out for its defaults)")
    br.run(args.out, tables["--sizes"], overwrite=args.overwrite,
           method_sizes=tables["--method-sizes"], compare_sizes=tables["--compare-sizes"],
           memory_sizes=tables["--memory-sizes"], methods=args.methods, repeats=args.repeats)


# bench-compare ------------------------------------------------------------------------------

def bench_compare_arguments(p):
    _out(p, "out/bench_compare.json", "JSON output path", is_file=True)
    p.add_argument("--sizes", type=_SIZE, nargs="+", default=None, action=NO.Distinct,
                   help="bake sizes (default 2048 4096)")
    p.add_argument("--method", default=None, help="method (default normal-map)")
    p.add_argument("--repeats", type=_REPEATS, default=3, help="pairs per size (median)")
    p.add_argument("--compare-root", default=None,
                   help="checkout whose compare command to time (default this one; e.g. an "
                        "earlier commit's, for before/after figures)")
    p.add_argument("--before-root", default=None,
                   help="a second checkout whose compare is timed in the same rounds, against "
                        "the same bake-alone child (the 'before' figures)")
    _overwrite(p, "replace an existing JSON")


def bench_compare_run(args):
    from .bench import compare as bc
    bc.run(args.out, tuple(args.sizes or bc.SIZES), args.method or bc.METHOD, args.repeats,
           args.overwrite, compare_root=args.compare_root, before_root=args.before_root)


# compare, compare-all -----------------------------------------------------------------------

def _cycles_device(p):
    from .cycles_device import KINDS
    p.add_argument("--cycles-device", default="CPU", choices=KINDS,
                   help="Cycles device of the bakes/renders: CPU (default), or every CUDA or "
                        "OptiX GPU (refused when Cycles finds none)")


def compare_arguments(p):
    p.add_argument("--blend", default=None,
                   help=".blend file to open (default: the procedural test scene; inside "
                        "Blender: the open file)")
    p.add_argument("--object", required=True, help="name of the mesh object to bake")
    p.add_argument("--method", required=True, choices=_method_names(),
                   help="the method (harness/methods.py)")
    p.add_argument("--resolution", type=_SIZE, default=128, help="bake size in texels")
    p.add_argument("--json", required=True, help="report path (an _error.png heat map is "
                                                 "written beside it)")
    p.add_argument("--uv-map", default=None, help="UV map to bake into (default: the active "
                                                  "render UV map)")
    p.add_argument("--image", default=None, help="normal map image to use instead of the "
                                                 "procedural test image (methods that read "
                                                 "a normal map)")
    p.add_argument("--variant", default=None,
                   choices=("forward", "one-texel", "hq", *DECAL_SHAPES),
                   help="height-map / height-map-sampler derivative variant (default hq) or "
                        "decal shape (default box); the other methods have none")
    p.add_argument("--tiles", nargs="+", default=None,
                   help="UDIM tiles to bake and compare, e.g. 1001 1002, 1001,1002 or "
                        "1001-1010 (default: the 0-1 square, or every tile with faces when "
                        "all faces lie on UDIM tiles)")
    _cycles_device(p)
    _overwrite(p)


def compare_run(args):
    from . import compare
    compare.run(args.blend, args.object, args.method, args.resolution, args.json, args.uv_map,
                args.image, args.variant, args.overwrite, from_open_file=args.in_blender,
                tiles=args.tiles, cycles_device=args.cycles_device)


def compare_all_arguments(p):
    _out(p, "out/compare")
    p.add_argument("--resolution", type=_SIZE, default=64, help="bake size in texels")
    _overwrite(p)
    p.add_argument("--workers", type=NO.whole(*NO.COMPARE_WORKERS_RANGE), default=None,
                   help="processes sharing the cases (default: one per core, at most 2)")
    _cycles_device(p)


def compare_all_run(args):
    from . import compare_all
    compare_all.run_all(args.out, args.resolution, args.overwrite, workers=args.workers,
                        cycles_device=args.cycles_device)


# bench, bench-render, bench-far -------------------------------------------------------------

def bench_arguments(p):
    _out(p, "out/bench")
    p.add_argument("--quick", action="store_true", help="small bakes, 2 repeats (minutes "
                                                        "become seconds)")
    p.add_argument("--resolution", type=_SIZE, default=None, help="bake size (default 256, "
                                                                  "quick 64)")
    p.add_argument("--repeats", type=_REPEATS, default=None, help="timed repeats (default 5)")
    p.add_argument("--only", nargs="+", default=None, help="scenario names to run")
    _overwrite(p)


def _whole(args, run):
    """run(folder, log) with --out written whole or not at all (staged_folder.py): a failed
    or stopped run leaves --out as it was."""
    from .staged_folder import shown, staged
    with staged(args.out, args.overwrite) as work:
        run(work, shown(lambda text: print(text, flush=True), work, args.out))


def bench_run(args):
    from .bench import run
    _whole(args, lambda work, log: run.run(work, args.quick, args.resolution, args.repeats,
                                           args.only, log=log))


def bench_render_arguments(p):
    _out(p, "out/bench_render")
    p.add_argument("--quick", action="store_true", help="small, few samples, no EEVEE")
    p.add_argument("--size", type=int, default=None,
                   help="frame width and height in pixels (default 320, quick 96)")
    p.add_argument("--samples", type=int, default=None,
                   help="Cycles samples per pixel (default 64, quick 8)")
    p.add_argument("--no-eevee", action="store_true", help="skip the EEVEE timings")
    _cycles_device(p)
    _overwrite(p)


def bench_render_run(args):
    from .bench import render_cost
    _whole(args, lambda work, log: render_cost.run(
        work, args.quick, log=log, size=args.size, samples=args.samples,
        eevee=not args.no_eevee, cycles_device=args.cycles_device))


def bench_far_arguments(p):
    _out(p, "out/far", "output folder (far.json, far.md)")
    p.add_argument("--resolution", type=_SIZE, default=64, help="bake size in texels")
    p.add_argument("--distances", type=float, nargs="+", default=None,
                   help="distances from the origin in metres (default 0 1000 10000)")
    p.add_argument("--objects", nargs="+", default=None,
                   help="test objects (default Sphere Transformed)")
    p.add_argument("--methods", nargs="+", default=None, help="methods (default: all)")
    _overwrite(p)


def bench_far_run(args):
    from .bench import far
    far.run(args.out, args.resolution, tuple(args.distances or far.DISTANCES),
            tuple(args.objects or far.FAR_OBJECTS), args.methods, args.overwrite)


# batch-assets, bench-batch, demo-blend ------------------------------------------------------

def batch_assets_arguments(p):
    _out(p, "out/batch_assets", "folder for the .blend files")
    p.add_argument("--count", type=NO.whole(*NO.ASSETS_RANGE), default=4, help="number of assets (default 4)")
    _overwrite(p, "replace existing files")


def batch_assets_run(args):
    from . import batch_assets
    for path in batch_assets.write_assets(args.out, args.count, args.overwrite):
        print(path)


def bench_batch_arguments(p):
    _out(p, "out/bench_batch")
    p.add_argument("--assets", type=NO.whole(*NO.ASSETS_RANGE), default=50,
                   help="number of assets (default 50)")
    p.add_argument("--resolution", type=NO.whole(*NO.BAKE_RESOLUTION_RANGE), default=512,
                   help="texels per side (512)")
    # Worker processes (0, this process, is bake-batch's, not a scale figure).
    p.add_argument("--workers", type=NO.whole(1, NO.WORKERS_RANGE[1]), nargs="+",
                   default=[1, 2], action=NO.Distinct,
                   help="worker counts to measure (default 1 2)")
    _overwrite(p)


def bench_batch_run(args):
    from .bench import batch
    batch.run(args.out, args.assets, args.resolution, args.workers, overwrite=args.overwrite)


def demo_blend_arguments(p):
    _out(p, "demo.blend", "the .blend to write", is_file=True)
    p.add_argument("--pictures", default=None, help="folder for a Cycles render of each "
                                                    "exhibit")
    _overwrite(p, "replace an existing file")
    p.add_argument("--closures", action="store_true", help="the Sampler exhibit alone "
                   "(Blender 5.0+; the repository's demo_closures.blend)")


def demo_blend_run(args):
    from . import demo, demo_pictures
    cams = demo.save_demo(args.out, args.overwrite, closures=args.closures)
    if args.pictures:
        demo_pictures.render_pictures(cams, args.pictures)


_BAKE_NORMAL_MAP, _BAKE_BATCH = SHIPPED
SUBCOMMANDS = (
    CL.Subcommand("demo", "the main job (reference stage)", demo_arguments, demo_run),
    CL.Subcommand("bench-reference", "benchmark the reference evaluator",
                  bench_reference_arguments, bench_reference_run, loads_blender=False),
    CL.Subcommand("bench-compare", "a whole compare's wall time against the bake alone, "
                  "interleaved child processes (JSON)", bench_compare_arguments,
                  bench_compare_run),
    CL.Subcommand("compare", "bake a method and compare it with the reference",
                  compare_arguments, compare_run),
    CL.Subcommand("compare-all", "every method on every test object (needs bpy)",
                  compare_all_arguments, compare_all_run),
    CL.Subcommand("bench", "speed against accuracy for every method, and the stability suite "
                  "(needs bpy)", bench_arguments, bench_run),
    CL.Subcommand("bench-render", "render cost of the surface-gradient groups against "
                  "Blender's own nodes (needs bpy)", bench_render_arguments, bench_render_run),
    CL.Subcommand("bench-far", "every method far from the origin, beside Blender's built-in "
                  "node (needs bpy)", bench_far_arguments, bench_far_run),
    _BAKE_NORMAL_MAP,
    _BAKE_BATCH,
    CL.Subcommand("batch-assets", "write small procedural assets (.blend files, UVs in 2 UDIM "
                  "tiles, an SG material) to try bake-batch on", batch_assets_arguments,
                  batch_assets_run),
    CL.Subcommand("bench-batch", "scale figures of bake-batch: procedural assets baked with 1 "
                  "and 2 worker processes (JSON)", bench_batch_arguments, bench_batch_run),
    CL.Subcommand("demo-blend", "build demo.blend (exhibits, packed textures) and optionally "
                  "render its pictures", demo_blend_arguments, demo_blend_run),
)


def main(argv=None, in_blender=False):
    """Parse and run; the exit code. in_blender: run inside Blender (blender_cli.py), where
    compare and bake-batch work on the open file when none is named."""
    args = CL.parser(SUBCOMMANDS, PROG, DESCRIPTION, raw_description=True).parse_args(argv)
    args.in_blender = in_blender
    problem = CL.working_folder_problem()        # before --out is made absolute
    if problem is None:
        out = _out_problem(args)
        problem = out and f"--out: {out}"
    if problem:
        print(f"surfgrad: error: {problem}", file=sys.stderr)
        return CL.BAD_REQUEST
    return CL.run(SUBCOMMANDS, args)


if __name__ == "__main__":
    sys.exit(CL.leave(main()))
