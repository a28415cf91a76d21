"""Command line: python -m surfgrad_addon <command> ...

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
  bench-far        every method 0, 1 km and 10 km from the origin against the reference,
                   beside Blender's built-in node for the same job (JSON and Markdown)
  compare          bake a method's node groups with Cycles and compare with the reference
                   (needs bpy; also: blender -b FILE --python-exit-code 1 --python
                   surfgrad_addon/blender_cli.py -- compare ...)
"""

import argparse
import sys




def _method_names():
    """The registry's method names (harness/methods.py; it needs bpy, which compare does)."""
    try:
        from .methods import METHODS
    except ImportError:
        return None
    return sorted(METHODS)


def main(argv=None, in_blender=False):
    parser = argparse.ArgumentParser(prog="python -m surfgrad_addon", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the main job (reference stage)")
    demo.add_argument("--out", default="out/demo", help="output folder (default out/demo)")
    demo.add_argument("--resolution", type=int, default=256, help="bake size in texels")
    demo.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    bench = sub.add_parser("bench-reference", help="benchmark the reference evaluator")
    bench.add_argument("--out", default="out/bench_reference.json", help="JSON output path")
    bench.add_argument("--sizes", type=int, nargs="*", default=None,
                       help="sizes of the listing table (default 256 512 1024 2048; none: "
                            "skip)")
    bench.add_argument("--method-sizes", type=int, nargs="*", default=None,
                       help="sizes of the whole-method table (default 256 1024 2048 4096; "
                            "none: skip)")
    bench.add_argument("--compare-sizes", type=int, nargs="*", default=None,
                       help="sizes of the compare runs against Cycles (default 1024 2048; "
                            "none: skip)")
    bench.add_argument("--memory-sizes", type=int, nargs="*", default=None,
                       help="sizes of the peak-memory compare runs (default 1024 2048 4096; "
                            "8192 needs about 8 GB)")
    bench.add_argument("--methods", nargs="+", default=None,
                       help="compare methods to run (default: all)")
    bench.add_argument("--repeats", type=int, default=3, help="runs per figure (median)")
    bench.add_argument("--overwrite", action="store_true", help="replace an existing JSON")
    bcmp = sub.add_parser("bench-compare", help="a whole compare's wall time against the bake "
                                                "alone, interleaved child processes (JSON)")
    bcmp.add_argument("--out", default="out/bench_compare.json", help="JSON output path")
    bcmp.add_argument("--sizes", type=int, nargs="+", default=None,
                      help="bake sizes (default 2048 4096)")
    bcmp.add_argument("--method", default=None, help="method (default normal-map)")
    bcmp.add_argument("--repeats", type=int, default=3, help="pairs per size (median)")
    bcmp.add_argument("--compare-root", default=None,
                      help="checkout whose compare command to time (default this one; e.g. "
                           "an earlier commit's, for before/after figures)")
    bcmp.add_argument("--overwrite", action="store_true", help="replace an existing JSON")
    cmp = sub.add_parser("compare", help="bake a method and compare it with the reference")
    cmp.add_argument("--blend", default=None,
                     help=".blend file to open (default: the procedural test scene; inside "
                          "Blender: the open file)")
    cmp.add_argument("--object", required=True, help="name of the mesh object to bake")
    cmp.add_argument("--method", required=True, choices=_method_names(),
                     help="the method (harness/methods.py)")
    cmp.add_argument("--resolution", type=int, default=128, help="bake size in texels")
    cmp.add_argument("--json", required=True, help="report path (an _error.png heat map is "
                                                   "written beside it)")
    cmp.add_argument("--uv-map", default=None, help="UV map to bake into (default: the active "
                                                    "render UV map)")
    cmp.add_argument("--image", default=None, help="normal map image to use instead of the "
                                                   "procedural test image")
    cmp.add_argument("--variant", default=None,
                     choices=("forward", "one-texel", "hq", "box", "sphere", "cylinder", "cone"),
                     help="height-map derivative variant (default hq) or decal shape "
                          "(default box)")
    cmp.add_argument("--tiles", type=int, nargs="+", default=None,
                     help="UDIM tiles to bake and compare (default: the 0-1 square, or every "
                          "tile with faces when all faces lie on UDIM tiles)")
    cmp.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    call = sub.add_parser("compare-all", help="every method on every test object (needs bpy)")
    call.add_argument("--out", default="out/compare", help="output folder")
    call.add_argument("--resolution", type=int, default=64, help="bake size in texels")
    call.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    call.add_argument("--workers", type=int, default=None,
                      help="processes sharing the cases (default: one per core, at most 2)")
    demo.add_argument("--compare-resolution", type=int, default=64,
                      help="bake size of the bake-vs-reference stage")
    demo.add_argument("--no-bake", action="store_true",
                      help="skip the Cycles bake stage (reference only)")
    bch = sub.add_parser("bench", help="speed against accuracy for every method, and the "
                                       "stability suite (needs bpy)")
    bch.add_argument("--out", default="out/bench", help="output folder")
    bch.add_argument("--quick", action="store_true", help="small bakes, 2 repeats (minutes "
                                                          "become seconds)")
    bch.add_argument("--resolution", type=int, default=None, help="bake size (default 256, "
                                                                  "quick 64)")
    bch.add_argument("--repeats", type=int, default=None, help="timed repeats (default 5)")
    bch.add_argument("--only", nargs="+", default=None, help="scenario names to run")
    bch.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    rc = sub.add_parser("bench-render", help="render cost of the surface-gradient groups "
                                             "against Blender's own nodes (needs bpy)")
    rc.add_argument("--out", default="out/bench_render", help="output folder")
    rc.add_argument("--quick", action="store_true", help="small, few samples, no EEVEE")
    rc.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    far = sub.add_parser("bench-far", help="every method far from the origin, beside "
                                           "Blender's built-in node (needs bpy)")
    far.add_argument("--out", default="out/far", help="output folder (far.json, far.md)")
    far.add_argument("--resolution", type=int, default=64, help="bake size in texels")
    far.add_argument("--distances", type=float, nargs="+", default=None,
                     help="distances from the origin in metres (default 0 1000 10000)")
    far.add_argument("--objects", nargs="+", default=None,
                     help="test objects (default Sphere Transformed)")
    far.add_argument("--methods", nargs="+", default=None, help="methods (default: all)")
    far.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    from ..addon.commands import add_bake_batch, add_bake_normal_map
    add_bake_normal_map(sub)
    add_bake_batch(sub)
    ba = sub.add_parser("batch-assets", help="write small procedural assets (.blend files, "
                                             "UVs in 2 UDIM tiles, an SG material) to try "
                                             "bake-batch on")
    ba.add_argument("--out", default="out/batch_assets", help="folder for the .blend files")
    ba.add_argument("--count", type=int, default=4, help="number of assets (default 4)")
    ba.add_argument("--overwrite", action="store_true", help="replace existing files")
    bb = sub.add_parser("bench-batch", help="scale figures of bake-batch: procedural assets "
                                            "baked with 1 and 2 worker processes (JSON)")
    bb.add_argument("--out", default="out/bench_batch", help="output folder")
    bb.add_argument("--assets", type=int, default=50, help="number of assets (default 50)")
    bb.add_argument("--resolution", type=int, default=512, help="texels per side (512)")
    bb.add_argument("--workers", type=int, nargs="+", default=[1, 2],
                    help="worker counts to measure (default 1 2)")
    bb.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    db = sub.add_parser("demo-blend", help="build demo.blend (exhibits, packed textures) and "
                                           "optionally render its pictures")
    db.add_argument("--out", default="demo.blend", help="the .blend to write")
    db.add_argument("--pictures", default=None, help="folder for a Cycles render of each "
                                                     "exhibit")
    db.add_argument("--overwrite", action="store_true", help="replace an existing file")
    db.add_argument("--closures", action="store_true", help="the Sampler exhibit alone "
                    "(Blender 5.0+; the repository's demo_closures.blend)")
    args = parser.parse_args(argv)
    # Ctrl-C / SIGTERM stop every command at once, exit 130 / 143, nothing written
    # (addon/interrupts.py); bake-normal-map and bake-batch install their own.
    from ..addon import interrupts
    if args.command in ("bake-normal-map", "bake-batch"):
        return _dispatch(args, in_blender)
    with interrupts.stoppable(f"{args.command}"):
        return _dispatch(args, in_blender)


def _dispatch(args, in_blender):
    try:
        if args.command == "demo":
            from . import main_job
            main_job.run(args.out, args.resolution, args.overwrite)
            if not args.no_bake:
                from . import compare_all
                compare_all.run_all(f"{args.out}/compare", args.compare_resolution,
                                    args.overwrite)
                from .bench import run as bench_run
                bench_run.run(f"{args.out}/bench", quick=True, overwrite=args.overwrite)
                from . import demo
                cams = demo.save_demo(f"{args.out}/demo.blend", overwrite=args.overwrite)
                demo.render_pictures(cams, f"{args.out}/pictures")
        elif args.command == "bench":
            from .bench import run as bench_run
            bench_run.run(args.out, args.quick, args.resolution, args.repeats, args.only,
                          args.overwrite)
        elif args.command == "bake-normal-map":
            from ..addon.commands import run_bake_normal_map
            run_bake_normal_map(args)      # --blend opens that file, inside Blender too
        elif args.command == "bake-batch":
            from ..addon.commands import run_bake_batch
            if in_blender and not args.blends and not args.asset_list:
                args.open_file = True
            return run_bake_batch(args)
        elif args.command == "batch-assets":
            from . import batch_assets
            for path in batch_assets.write_assets(args.out, args.count, args.overwrite):
                print(path)
        elif args.command == "bench-batch":
            from . import bench_batch
            bench_batch.run(args.out, args.assets, args.resolution, args.workers,
                            overwrite=args.overwrite)
        elif args.command == "demo-blend":
            from . import demo
            cams = demo.save_demo(args.out, args.overwrite, closures=args.closures)
            if args.pictures:
                demo.render_pictures(cams, args.pictures)
        elif args.command == "compare-all":
            from . import compare_all
            compare_all.run_all(args.out, args.resolution, args.overwrite,
                                workers=args.workers)
        elif args.command == "bench-render":
            from .bench import render_cost
            render_cost.run(args.out, args.quick, args.overwrite)
        elif args.command == "bench-far":
            from . import far
            far.run(args.out, args.resolution, tuple(args.distances or far.DISTANCES),
                    tuple(args.objects or far.FAR_OBJECTS), args.methods, args.overwrite)
        elif args.command == "bench-reference":
            from . import bench_reference
            br = bench_reference
            pick = lambda given, default: default if given is None else tuple(given)
            br.run(args.out, pick(args.sizes, br.SIZES), overwrite=args.overwrite,
                   method_sizes=pick(args.method_sizes, br.METHOD_SIZES),
                   compare_sizes=pick(args.compare_sizes, br.COMPARE_SIZES),
                   memory_sizes=pick(args.memory_sizes, br.MEMORY_SIZES),
                   methods=args.methods, repeats=args.repeats)
        elif args.command == "bench-compare":
            from . import bench_compare as bc
            bc.run(args.out, tuple(args.sizes or bc.SIZES), args.method or bc.METHOD,
                   args.repeats, args.overwrite, compare_root=args.compare_root)
        elif args.command == "compare":
            from . import compare
            compare.run(args.blend, args.object, args.method, args.resolution, args.json,
                        args.uv_map, args.image, args.variant, args.overwrite,
                        from_open_file=in_blender, tiles=args.tiles)
    except (FileExistsError, ValueError, KeyError, RuntimeError) as err:
        print(f"surfgrad: error: {err}", file=sys.stderr)
        from ..addon.exit_codes import code_for
        return code_for(err)
    return 0


if __name__ == "__main__":
    sys.exit(main())
