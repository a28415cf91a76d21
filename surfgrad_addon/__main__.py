"""Command line: python -m surfgrad_addon <command> ...

  demo             the main job: evaluate the reference on procedural scenes, write maps and
                   a summary (later stages add Cycles bakes and their comparison)
  bench-reference  throughput of the reference evaluator at 256^2 .. 2048^2 (JSON)
"""

import argparse
import sys


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m surfgrad_addon", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the main job (reference stage)")
    demo.add_argument("--out", default="out/demo", help="output folder (default out/demo)")
    demo.add_argument("--resolution", type=int, default=256, help="bake size in texels")
    demo.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    bench = sub.add_parser("bench-reference", help="benchmark the reference evaluator")
    bench.add_argument("--out", default="out/bench_reference.json", help="JSON output path")
    bench.add_argument("--sizes", type=int, nargs="+", default=None,
                       help="bake sizes (default 256 512 1024 2048)")
    bench.add_argument("--overwrite", action="store_true", help="replace an existing JSON")
    args = parser.parse_args(argv)
    try:
        if args.command == "demo":
            from . import main_job
            main_job.run(args.out, args.resolution, args.overwrite)
        elif args.command == "bench-reference":
            from . import bench_reference
            bench_reference.run(args.out, args.sizes or bench_reference.SIZES,
                                overwrite=args.overwrite)
    except (FileExistsError, ValueError, KeyError) as err:
        print(f"surfgrad: error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
