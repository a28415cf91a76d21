"""Number options of the command lines (`python -m surfgrad_addon`, `blender -c surfgrad`): one
argparse type per kind of value, so every command that takes a count, a size or a number of
seconds refuses the same typos the same way, while parsing (exit 2, before any work, nothing
written; argparse names the option, the message the allowed range).

Without these, `--repeats 0` wrote a JSON of NaN medians with exit 0, `--workers 0` ran one
worker, `--count 1000000000` built a billion paths before any check."""

import argparse
import math

from .bake_request import whole_number_problem
from .normal_bake import RESOLUTION_RANGE as BAKE_RESOLUTION_RANGE

# Ranges shared by the commands that take the value (and the API's checks of the same value).
COMPARE_RESOLUTION_RANGE = (8, 8192)   # a compare's bake (harness/compare.py takes it)
COMPARE_WORKERS_RANGE = (1, 64)    # compare-all's processes (each a bpy); 0 ran one
REPEATS_RANGE = (1, 100)           # timed runs of one figure (their median)
WORKERS_RANGE = (0, 256)           # bake-batch: Blender processes at once (0: this one)
ASSETS_RANGE = (1, 1000)           # procedural assets asset_000 .. asset_999
WORKER_TIMEOUT_MAX = 7 * 24 * 3600.0   # seconds; past this a worker is hung, not slow


def whole(lo, hi):
    """The argparse type of a whole number from lo to hi ('2.5', '1e9', '-1' refused)."""
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            value = text
        problem = whole_number_problem("", value, lo, hi)
        if problem:
            raise argparse.ArgumentTypeError(problem.strip())
        return value
    parse.__name__ = f"whole number from {lo} to {hi}"
    return parse


def seconds(hi):
    """The argparse type of a number of seconds, more than 0 and at most hi (nan, inf, 0 and
    negatives refused)."""
    def parse(text):
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not 0 < value <= hi:
            raise argparse.ArgumentTypeError(f"{text!r}: give seconds, more than 0 and at "
                                             f"most {hi:.0f}")
        return value
    parse.__name__ = "seconds"
    return parse


class Distinct(argparse.Action):
    """A list option whose values must differ: `--sizes 64 64` measured one size twice under
    one key of the JSON (the second overwrote the first)."""

    def __call__(self, parser, namespace, values, option_string=None):
        seen = set()
        twice = [v for v in values if v in seen or seen.add(v)]
        if twice:
            parser.error(f"argument {option_string}: {twice[0]} is given twice: give each "
                         f"value once")
        setattr(namespace, self.dest, values)
