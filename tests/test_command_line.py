"""The one command line: `python -m surfgrad_addon` (harness/cli.py SUBCOMMANDS) and
`blender -c surfgrad` (addon/commands.py SHIPPED) are built from tables of subcommands by
addon/command_line.py, the bake subcommands' rows shared; their bake options come from the bake
request's fields (defaults, ranges, help written once, addon/bake_request.py)."""

from dataclasses import fields

import pytest

from surfgrad_addon.addon import batch, commands
from surfgrad_addon.addon.bake_request import BakeRequest
from surfgrad_addon.harness import cli

pytestmark = pytest.mark.tier("blender")          # the harness's table reads the registry

BAKE = ["bake-normal-map", "--object", "Rock", "--output", "rock.png"]


def _harness_args(argv):
    return cli.CL.parser(cli.SUBCOMMANDS, cli.PROG, cli.DESCRIPTION).parse_args(argv)


def test_the_bake_rows_are_the_extensions_own_in_both_command_lines():
    names = [c.name for c in cli.SUBCOMMANDS]
    assert len(names) == len(set(names)) == 13
    assert [c for c in cli.SUBCOMMANDS if c.name.startswith("bake-")] == list(commands.SHIPPED)
    assert all(any(c is s for c in cli.SUBCOMMANDS) for s in commands.SHIPPED)
    for argv in (BAKE, ["bake-batch", "a.blend", "--output", "{file}.png", "--workers", "2"]):
        assert vars(_harness_args(argv)) == vars(commands.parser().parse_args(argv))


def test_bake_options_take_the_requests_defaults_and_ranges(capsys):
    args = commands.parser().parse_args(BAKE)
    defaults = {f.name: f.default for f in fields(BakeRequest)}
    for name in commands.NORMAL_MAP_OPTIONS:
        assert getattr(args, name) == defaults[name], name
    assert (args.resolution, args.margin, args.samples, args.space) == (1024, 16, 1, "tangent")
    assert commands.execute(["bake-normal-map", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "texels per side (default 1024; 4 to 16384)" in text
    assert "(default 16; 0 to 1024)" in text and "(default 1; 1 to 65536)" in text


def test_bake_batch_leaves_its_settings_to_the_settings_file_then_the_request():
    args = commands.parser().parse_args(["bake-batch", "--output", "{file}.png"])
    assert all(getattr(args, k) is None for k in batch.SETTING_KEYS)
    assert args.empty_tiles == "error" and args.workers == 1
    request = {f.name: f.default for f in fields(BakeRequest)}
    assert batch.DEFAULTS == {k: request[k] for k in batch.DEFAULTS}
    assert set(batch.SETTING_KEYS) <= set(request)


def test_blender_c_surfgrad_help_usage_and_request_errors(capsys, tmp_path):
    assert commands.execute(["--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: blender -c surfgrad [-h] {bake-normal-map,bake-batch}")
    assert commands.execute(["bake-normal-map"]) == 2
    assert "the following arguments are required: --object, --output" in capsys.readouterr().err
    assert commands.execute(["compare"]) == 2           # the harness's, not the extension's
    assert "invalid choice: 'compare'" in capsys.readouterr().err
    bad = ["bake-normal-map", "--object", "Rock", "--output", str(tmp_path / "r.png"),
           "--resolution", "3", "--samples", "0"]
    for run in (commands.execute, cli.main):
        assert run(bad) == 2
        err = capsys.readouterr().err
        assert err.startswith("surfgrad: error: 2 problems:")
        assert "resolution 3: use a whole number of texels from 4 to 16384" in err
        assert "samples 0: use a whole number from 1 to 65536" in err
        assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
