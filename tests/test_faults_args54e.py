"""Red team 54e: the number and list options of every command (`python -m surfgrad_addon ...`,
`blender -c surfgrad ...`, the API's bake_batch) given what a typo or a script gives: 0,
negatives, 1e9, 2.5 for a count, nan/inf for seconds, a value twice in a list, empty lists.
Each is now refused while parsing by one shared type per kind of value
(addon/number_options.py): exit 2, nothing written, the option and its range named.

1. bench-reference --repeats 0 (or -2): exit 0 and a JSON with 26 NaN medians ("median of
   nothing", numpy's empty-slice warning); bench-compare --repeats 0 (and docs/proof.md's
   `python -m surfgrad_addon.harness.bench.compare`, its own parser) logged "compare / bake
   alone nanx ... (median of 0)" and wrote its JSON, exit 0. Now
   "argument --repeats: 0: use a whole number from 1 to 100", exit 2, no JSON.
2. bench-reference with every table emptied (--sizes --method-sizes --compare-sizes
   --memory-sizes, each "none: skip"): exit 0 and a JSON of four empty tables. Now refused,
   naming the four options.
3. bench-reference --sizes 0 / -4: the listing bench ran first, then "bake resolution must be
   positive, got 0 x 0" (no option named); --sizes 64 64 measured one size twice under one
   JSON key; 1e9 unbounded. Sizes of bench-reference, bench-compare, bench --resolution,
   compare(-all) and demo now share the compare's range, 8 to 8192, each given once.
4. compare-all --workers 0 or -1 ran as 1 worker, silently (max(1, workers)); 1e9 had no
   bound (a child per worker). Now 1 to 64.
5. bench --resolution 1e9 / --repeats 1e9: only "at least 1" was checked. Now 8..8192, 1..100.
6. batch-assets --count 1e9 / bench-batch --assets 1e9: a list of a billion paths before any
   check (under `ulimit -v 4000000`: 58 s, then "ran out of memory ... a lower --resolution",
   exit 1, --count unnamed; without a limit, the machine's memory). bench-batch --workers 1 1: one JSON run key written twice; --workers 0 or -1 reached
   the batch after the assets were written. Now 1 to 1000 assets, workers 1 to 256, distinct.
7. bake-batch --workers 1e9 (and api.bake_batch(workers=10**9)): Pool([None] * workers), 8 GB,
   after every asset was scanned. --worker-timeout inf (or 1e10) passed the "> 0" check and
   reached queue.get(timeout=inf): bake-batch on a batch-assets file printed a raw
   OverflowError traceback ("timestamp out of range for platform time_t", workers.py:92) and
   "surfgrad: error: 'scan'", exit 2, after the scan had started. Now workers 0 to 256 and 0 < timeout <= 604800 s, on the command line and the API.
8. --tiles 1001-1000000000 (bake-normal-map, bake-batch, compare): parse_tiles built the
   billion-tile set first (14 s, then MemoryError under a 3 GB limit) before the range check.
   Now "tile 1000000000: UDIM tiles are numbered 1001 to 2000" at once.
"""

import math
import time

import pytest

pytest.importorskip("bpy")

from surfgrad_addon.addon import command_line as CL  # noqa: E402
from surfgrad_addon.addon.batch import plan as P  # noqa: E402
from surfgrad_addon.harness import cli  # noqa: E402
from surfgrad_addon.reference import tiles as T  # noqa: E402

pytestmark = pytest.mark.tier("blender")


def _parse(argv):
    return CL.parser(cli.SUBCOMMANDS, cli.PROG, cli.DESCRIPTION).parse_args(argv)


def _refused(argv, capsys):
    """The parser's exit code and its error line."""
    with pytest.raises(SystemExit) as stop:
        _parse(argv)
    return stop.value.code, capsys.readouterr().err.strip().splitlines()[-1]


NO_TABLES = ["--method-sizes", "--compare-sizes", "--memory-sizes"]


def test_bench_reference_repeats_zero_writes_no_json_of_nan(tmp_path, capsys):
    """Finding 1: exit 0 with NaN medians before; now exit 2 and no file."""
    out = tmp_path / "b.json"
    with pytest.raises(SystemExit) as stop:
        cli.main(["bench-reference", "--out", str(out), "--sizes", "16", *NO_TABLES,
                  "--repeats", "0"])
    assert stop.value.code == 2
    assert "--repeats" in capsys.readouterr().err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_bench_reference_with_every_table_empty_is_refused(tmp_path, capsys):
    """Finding 2: a JSON of nothing, exit 0, before."""
    out = tmp_path / "b.json"
    assert cli.main(["bench-reference", "--out", str(out), "--sizes", *NO_TABLES]) == 2
    err = capsys.readouterr().err
    assert all(o in err for o in ["--sizes", *NO_TABLES]), err
    assert list(tmp_path.iterdir()) == []


OUT = ["--out", "/tmp/never-written-54e"]
BATCH = ["bake-batch", "a.blend", "--output", "/tmp/never-written-54e/{object}.png"]
REFUSED = [  # (argv, the option, what the message must say)
    (["bench-reference", *OUT, "--repeats", "-2"], "--repeats", "from 1 to 100"),
    (["bench-compare", *OUT, "--repeats", "0"], "--repeats", "from 1 to 100"),
    (["bench-reference", *OUT, "--sizes", "0"], "--sizes", "from 8 to 8192"),
    (["bench-reference", *OUT, "--method-sizes", "-4"], "--method-sizes", "from 8 to 8192"),
    (["bench-reference", *OUT, "--sizes", "64", "64"], "--sizes", "64 is given twice"),
    (["bench-compare", *OUT, "--sizes", "1000000000"], "--sizes", "from 8 to 8192"),
    (["bench-compare", *OUT, "--sizes", "64", "128", "64"], "--sizes", "given twice"),
    (["compare-all", *OUT, "--workers", "0"], "--workers", "from 1 to 64"),
    (["compare-all", *OUT, "--workers", "-1"], "--workers", "from 1 to 64"),
    (["compare-all", *OUT, "--workers", "1000000000"], "--workers", "from 1 to 64"),
    (["bench", *OUT, "--quick", "--resolution", "1000000000"], "--resolution", "8 to 8192"),
    (["bench", *OUT, "--quick", "--repeats", "1000000000"], "--repeats", "from 1 to 100"),
    (["bench", *OUT, "--repeats", "2.5"], "--repeats", "'2.5'"),
    (["batch-assets", *OUT, "--count", "1000000000"], "--count", "from 1 to 1000"),
    (["batch-assets", *OUT, "--count", "0"], "--count", "from 1 to 1000"),
    (["bench-batch", *OUT, "--assets", "1000000000"], "--assets", "from 1 to 1000"),
    (["bench-batch", *OUT, "--workers", "0"], "--workers", "from 1 to 256"),
    (["bench-batch", *OUT, "--workers", "1", "1"], "--workers", "1 is given twice"),
    (["bench-batch", *OUT, "--resolution", "100000"], "--resolution", "from 4 to 16384"),
    ([*BATCH, "--workers", "-1"], "--workers", "from 0 to 256"),
    ([*BATCH, "--workers", "1000000000"], "--workers", "from 0 to 256"),
    ([*BATCH, "--worker-timeout", "inf"], "--worker-timeout", "at most 604800"),
    ([*BATCH, "--worker-timeout", "nan"], "--worker-timeout", "more than 0"),
    ([*BATCH, "--worker-timeout", "0"], "--worker-timeout", "more than 0"),
    (["demo", *OUT, "--compare-resolution", "1e9"], "--compare-resolution", "8 to 8192"),
]


@pytest.mark.parametrize("argv, option, said", REFUSED, ids=[" ".join(a[0:1] + a[3:])
                                                             for a, _, _ in REFUSED])
def test_a_bad_number_is_refused_while_parsing_naming_option_and_range(argv, option, said,
                                                                        capsys):
    """Findings 1 and 3 to 7: exit 2 before anything runs, the option and the range named."""
    code, line = _refused(argv, capsys)
    assert code == 2
    assert f"argument {option}:" in line and said in line, line


def test_the_ranges_ends_are_still_taken():
    """The ends of each range parse to the numbers given (no check is stricter than its
    message), and a list without repeats is kept in its order."""
    a = _parse(["bench-reference", *OUT, "--sizes", "8192", "8", "--repeats", "100"])
    assert (a.sizes, a.repeats) == ([8192, 8], 100)
    assert _parse(["compare-all", *OUT, "--workers", "64"]).workers == 64
    b = _parse([*BATCH, "--workers", "0", "--worker-timeout", "0.5"])
    assert (b.workers, b.worker_timeout) == (0, 0.5)
    assert _parse([*BATCH, "--worker-timeout", "604800"]).worker_timeout == 604800.0
    assert _parse(["bench-batch", *OUT, "--workers", "2", "1"]).workers == [2, 1]
    assert _parse(["batch-assets", *OUT, "--count", "1000"]).count == 1000


def _checked(workers=1, worker_timeout=None):
    return P.checked_options("{object}.png", workers, worker_timeout, None, "error", None,
                             None, {})


@pytest.mark.parametrize("workers, timeout", [(10**9, None), (-1, None), (1, math.inf),
                                              (1, 1e10), (1, math.nan), (1, 0)])
def test_the_api_refuses_the_same_workers_and_timeouts(workers, timeout):
    """Finding 7, api.bake_batch's path (batch/plan.checked_options, before any file opens)."""
    with pytest.raises(P.BatchError) as err:
        _checked(workers, timeout)
    assert ("workers" if timeout is None else "timeout") in str(err.value)
    _checked(256, 604800)                       # the ends still taken


def test_a_tile_range_beyond_udim_is_refused_before_it_is_made():
    """Finding 8: 1001-3000000 made a 3-million-tile list (1001-1000000000: 14 s, then a
    MemoryError); now refused at once naming the tile and the range."""
    start = time.perf_counter()
    for text in ("1001-3000000", "1001-1000000000", "0-1002", "1001,2001"):
        with pytest.raises(ValueError, match=r"tile (3000000|1000000000|0|2001): UDIM tiles "
                                             r"are numbered 1001 to 2000"):
            T.parse_tiles(text)
    assert time.perf_counter() - start < 1.0
    assert T.parse_tiles("1998-2000,1001") == [1001, 1998, 1999, 2000]


@pytest.mark.parametrize("extra, said", [
    (["--workers", "-1"], "argument --workers: -1: use a whole number from 0 to 256"),
    (["--worker-timeout", "inf"], "argument --worker-timeout: 'inf': give seconds, more than 0"),
    (["--tiles", "1001-1000000000"], "tile 1000000000: UDIM tiles are numbered 1001 to 2000")])
def test_blender_c_surfgrad_refuses_the_same(tmp_path, capsys, extra, said):
    """`blender -c surfgrad bake-batch` (commands.execute, what Blender's -c calls): exit 2,
    nothing written, the same words as python -m (finding 7, and 8 through the request)."""
    from surfgrad_addon.addon import commands
    out = tmp_path / "maps"
    rc = commands.execute(["bake-batch", str(tmp_path / "a.blend"), "--output",
                           str(out / "{object}.<UDIM>.png"), "--workers", "0", *extra])
    err = capsys.readouterr().err
    assert rc == 2 and said in err and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


def test_bench_compare_module_run_as_docs_proof_says_refuses_repeats_zero(tmp_path, capsys,
                                                                          monkeypatch):
    """docs/proof.md runs `python -m surfgrad_addon.harness.bench.compare --repeats 7`: its
    own parser took --repeats 0 (a JSON of medians of nothing, exit 0) and --sizes 64 64."""
    from surfgrad_addon.harness.bench import compare as bc
    out = tmp_path / "bc.json"
    for extra, said in ((["--repeats", "0"], "argument --repeats: 0: use a whole number from "
                                             "1 to 100"),
                        (["--sizes", "64", "64"], "argument --sizes: 64 is given twice")):
        monkeypatch.setattr("sys.argv", ["compare.py", "--out", str(out), *extra])
        with pytest.raises(SystemExit) as stop:
            bc._main()
        assert stop.value.code == 2 and said in capsys.readouterr().err
        assert list(tmp_path.iterdir()) == []
