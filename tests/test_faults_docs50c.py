"""Red team 50c: the README and docs/ (pipelines, farm, artists, versions) followed literally,
every command line, flag, exit code and api call they give, against what the product does.

1. `compare --tiles` took only numbers one by one (`type=int, nargs="+"`), while the bakes'
   `--tiles` (bake-normal-map's help: "e.g. 1001,1002 or 1001-1010") and the docs' "`--tiles`
   ranges low to high" take ranges: `compare --tiles 1001-1002` and `--tiles 1001,1002` ended in
   argparse's "argument --tiles: invalid int value: '1001-1002'", exit 2, a TD's copy of the
   bake's tiles refused. `harness_api.compare(obj, m, tiles="1001-1002")` (the bake functions
   take tiles "as text such as 1001-1005") raised a raw ValueError ("invalid literal for int()
   with base 10: '-'"), and tiles="1001" read each character as a tile: "tile 0: UDIM tiles
   are numbered 1001 to 2000". Now both take what the bakes take (reference/tiles.parse_tiles):
   "1001-1002", "1001,1002", 1001 1002, each giving tiles [1001, 1002]; a malformed or
   backwards range is refused before the file is opened, exit 2, naming the form.
2. `demo --help` said "bake size in texels" for `--resolution`, which sizes stage 1's numpy
   reference maps (README: "at 256 x 256 texels"), while the bakes are stage 2's
   `--compare-resolution` ("CPU, 1 sample, 64 x 64"): `bash run.sh main --resolution 512`, the
   README's example, left the bakes at 64. The help now says which is which with the
   defaults the README quotes, and the README says `--no-bake` writes the report page too
   (it said "stops after stage 1"; the run printed "[2/2] report page" and wrote index.html).
3. The Flamenco job type's Python expression, on a worker whose Blender lacks the enabled
   extension, printed its line on stdout and exited 3, a code docs/pipelines.md does not list
   (0, 1, 2, 130, 143, ...): a farm's log filter on stderr saw nothing. Now exit 2 (refused,
   nothing baked) with the line on stderr naming the fix.
4. Every `--flag` the docs give a command (`python -m surfgrad_addon CMD`, `blender -c surfgrad
   CMD`, `bash run.sh CMD`) is one that command's parser takes: checked here, so a renamed or
   removed flag fails the suite rather than a reader (all held at round 50).
5. `bake-normal-map --help` said `--output` is ".png (8-bit) or .exr (float)", where the docs
   give PNG at `--depth 8` or `16` and EXR at `half` or `float`, and `<UDIM>` for one file per
   tile, which the help did not name. It now says both.
6. `compare --variant` ("height-map derivative variant or decal shape") was ignored by every
   method of one variant: `compare --method decal-overwrite --variant sphere` compared the box
   decal and `--method triplanar-height --variant forward` the HQ one, exit 0, a JSON whose
   "variant" was null (a flag taken and dropped). Now refused, exit 2, nothing written, naming
   the methods that have variants; `--variant hq` (their one) is still taken.
7. `compare --image` ("normal map image to use instead of the procedural test image") was
   dropped by every method that reads no normal map (height-map, triplanar-height,
   height-blend, volume-noise, procedural-basis, displace-bump): `compare --method height-map
   --image rock_nrm.png` compared the procedural height image, exit 0, and said nothing of the
   map given. Now refused, exit 2, no report written, naming the fix.
8. `python -m surfgrad_addon bake-normal-map --object Cube --output rock.png` with `--blend`
   left out (the help: "default: the file Blender opened", and none is) baked the startup
   scene's Cube, exit 0: a TD's asset object named Cube got the default cube's map. Now
   refused, exit 2, nothing written, naming --blend (a bad setting is still named first).
9. `demo --no-bake --pictures` (README: `--pictures` also renders the exhibits; `--no-bake`
   runs no Cycles stage) ran the reference stage and the page, exit 0, and rendered no
   picture: the flag dropped. Now refused before anything runs, exit 2, no --out made.
10. docs/pipelines.md: "a name ending in `/` is a folder, not a file; ... and `compare --json`,
   alike". `compare --json reports/` wrote a JSON file named `reports` (1037 bytes) and
   `reports_error.png`, exit 0 (Path() drops the slash), and `bench-reference` / `bench-compare
   --out reports/` a JSON file `reports` (577 bytes, exit 0). Now refused before any work,
   exit 2, nothing written, naming a file in that folder as the fix. So is `bake-batch
   --manifest maps/manifests/` (the same line of the docs; it wrote a manifest file named
   `manifests`, exit 0) and `demo-blend --out demo/` (a .blend named `demo`).
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md"] + [ROOT / "docs" / f"{n}.md" for n in
                                ("pipelines", "farm", "artists", "versions", "performance",
                                 "proof")]

pytestmark = pytest.mark.tier("numpy")


def _subparsers(module):
    from surfgrad_addon.addon import command_line as CL
    p = CL.parser(getattr(module, "SUBCOMMANDS", None) or module.SHIPPED, "x", "x")
    return next(a for a in p._actions if a.__class__.__name__ == "_SubParsersAction").choices


def _doc_command_lines():
    """(file, command runner, subcommand, rest of the command) for every command the docs
    show: fenced blocks with their `\\` continuations joined, and prose code spans."""
    pattern = re.compile(r"(python -m surfgrad_addon|blender -c surfgrad|run\.sh) "
                         r"([a-z][a-z-]*)([^`#\n]*)")
    found = []
    for path in DOCS:
        text = path.read_text(encoding="utf-8").replace("\\\n", " ")
        for m in pattern.finditer(text):
            found.append((path.name, m.group(1), m.group(2), m.group(3)))
    return found


RUN_SH = {"main": "demo", "bench": "bench", "bench-render": "bench-render",
          "bench-reference": "bench-reference"}


def test_every_flag_the_docs_give_a_command_is_one_it_takes():
    from surfgrad_addon.addon import commands
    from surfgrad_addon.harness import cli
    harness, addon = _subparsers(cli), _subparsers(commands)
    lines = _doc_command_lines()
    assert len(lines) > 20, lines          # the docs do show commands (the pattern still finds)
    checked, wrong = 0, []
    for name, runner, command, rest in lines:
        parsers = addon if runner == "blender -c surfgrad" else harness
        if runner == "run.sh":
            if command not in RUN_SH:
                continue                   # test: pytest's arguments
            command = RUN_SH[command]
        if command not in parsers:
            wrong.append(f"{name}: {runner} {command}: no such command")
            continue
        takes = {s for a in parsers[command]._actions for s in a.option_strings}
        for flag in re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", rest):
            checked += 1
            if flag not in takes:
                wrong.append(f"{name}: {runner} {command} {flag}: not an option of it")
    assert checked > 30 and not wrong, wrong


def test_demo_help_says_which_resolution_is_the_bakes_as_the_readme_does():
    from surfgrad_addon.harness import cli
    demo = {a.dest: a for a in _subparsers(cli)["demo"]._actions}
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    reference = int(re.search(r"at (\d+) x \1 texels", readme).group(1))
    bakes = int(re.search(r"CPU, 1 sample, (\d+) x \1\)", readme).group(1))
    assert (reference, bakes) == (256, 64)            # the README's own numbers
    assert demo["resolution"].default == reference
    assert demo["compare_resolution"].default == bakes
    # The help tells the two apart (it said "bake size in texels" for the reference maps).
    assert "bake" not in demo["resolution"].help.split("(")[0], demo["resolution"].help
    assert "reference" in demo["resolution"].help and f"default {reference}" in \
        demo["resolution"].help
    assert "bake" in demo["compare_resolution"].help and f"default {bakes}" in \
        demo["compare_resolution"].help
    assert "report page" in demo["no_bake"].help
    assert "`--no-bake` runs stage 1 (numpy only) and the report page" in readme


@pytest.mark.tier("blender")         # harness.compare imports bpy
@pytest.mark.parametrize("given", [["1001-1002"], ["1001,1002"], ["1001", "1002"],
                                   "1001-1002", [1001, 1002]])
def test_compare_takes_tiles_in_the_forms_the_bakes_take(given):
    from surfgrad_addon.harness.compare import asked_tiles
    assert asked_tiles(given) == [1001, 1002]


@pytest.mark.tier("blender")         # harness.compare imports bpy
def test_compare_tiles_one_tile_as_text_is_that_tile():
    from surfgrad_addon.harness.compare import asked_tiles
    assert asked_tiles("1001") == [1001]           # before: tiles 0 and 1, "tile 0" refused
    assert asked_tiles(["1005"]) == [1005]
    assert asked_tiles(None) is None


@pytest.mark.tier("blender")         # harness.compare imports bpy
@pytest.mark.parametrize("given, words", [(["10x1"], "give UDIM numbers like 1001,1002"),
                                          (["1002-1001"], "write it low to high, like 1001-1002"),
                                          (",", "no tile given")])
def test_compare_refuses_a_malformed_tile_list_naming_the_form(given, words):
    from surfgrad_addon.harness.compare import CompareError, asked_tiles
    with pytest.raises(CompareError, match=re.escape(words)):
        asked_tiles(given)


def test_compare_command_line_parses_a_tile_range():
    from surfgrad_addon.harness import cli
    compare = _subparsers(cli)["compare"]
    args = compare.parse_args(["--object", "Plane", "--method", "normal-map", "--json", "x.json",
                               "--tiles", "1001-1002"])      # before: SystemExit(2)
    assert args.tiles == ["1001-1002"]


@pytest.mark.tier("child")
def test_flamenco_task_without_the_extension_is_refused_exit_2_on_stderr():
    from support.flamenco import compile_job
    job = compile_job({"objects": "Rock", "blendfile": "/p/a.blend",
                       "output_pattern": "/p/{object}.png", "manifest_dir": "/p/m"})
    args = job["tasks"][0]["commands"][0]["parameters"]["args"]
    expr = args[args.index("--python-expr") + 1]
    # A worker's Python with no surfgrad module loaded (the extension not enabled).
    res = subprocess.run([sys.executable, "-c", expr, "--", *args[args.index("--") + 1:]],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2, (res.returncode, res.stdout, res.stderr)    # before: 3
    assert res.stdout == ""                                                 # before: the line
    assert res.stderr.startswith("surfgrad: error: the surfgrad extension is not enabled")
    assert "enable it in Preferences" in res.stderr and "Traceback" not in res.stderr


@pytest.mark.tier("bake")
def test_harness_compare_takes_tiles_as_text():
    """The API as a script calls it: tiles="1001" (before: "tile 0: UDIM tiles are numbered
    1001 to 2000", each character read as a tile), "1001-1001" (before: a raw ValueError)."""
    pytest.importorskip("bpy")
    from surfgrad_addon.harness import api as harness_api
    from surfgrad_addon.harness import scenes
    scenes.new_scene()
    import bpy
    plane = bpy.data.objects["Plane"]
    for tiles in ("1001", "1001-1001"):
        report = harness_api.compare(plane, "normal-map", resolution=8, tiles=tiles)
        # One tile: the plain image's report (no per-tile rows), every texel compared.
        assert report["tiles"] is None and report["texels_compared"] == 64
        assert report["max_deg"] < 0.5


def test_bake_normal_map_output_help_gives_the_depths_and_tiles_the_docs_give():
    """docs/pipelines.md: `.png` (`--depth 8` or `16`) or `.exr` (`half` or `float`), and an
    output with `<UDIM>` writes one file per tile; the help said ".png (8-bit) or .exr
    (float)" and nothing of <UDIM>."""
    from surfgrad_addon.addon import commands
    parser = _subparsers(commands)["bake-normal-map"]
    actions = {a.dest: a for a in parser._actions}
    help_text = actions["output"].help
    assert "8-bit" not in help_text and "--depth" in help_text and "<UDIM>" in help_text
    assert set(actions["depth"].choices) >= {"8", "16", "half", "float"}
    pipelines = (ROOT / "docs" / "pipelines.md").read_text(encoding="utf-8")
    assert re.search(r"`\.png` \(`--depth 8` or `16`\s+bits\) or `\.exr` \(`half` or\s+`float`",
                     pipelines)


@pytest.mark.tier("bake")
@pytest.mark.parametrize("method, variant", [("decal-overwrite", "sphere"),
                                             ("triplanar-height", "forward"),
                                             ("normal-map", "box")])
def test_compare_refuses_a_variant_a_method_does_not_have(method, variant):
    pytest.importorskip("bpy")
    import bpy
    from surfgrad_addon.harness import compare, scenes
    scenes.new_scene()
    sphere = bpy.data.objects["Sphere"]
    with pytest.raises(compare.CompareError, match=rf"method '{method}' has no variants, so "
                       rf"--variant '{variant}' would change nothing: leave --variant out "
                       r"\(it is for decal, height-map, height-map-sampler\)"):
        compare.compare_object(sphere, method, 16, variant=variant, log=lambda *_: None)
    # Its one variant, named, is still taken (scripts that pass what compare-all passes).
    report, _ = compare.compare_object(sphere, method, 16, variant="hq", log=lambda *_: None)
    assert report["texels_compared"] > 0 and report["max_deg"] < 0.5


@pytest.mark.tier("bake")
def test_compare_refuses_an_image_its_method_does_not_read(tmp_path):
    pytest.importorskip("bpy")
    import bpy
    from surfgrad_addon.harness import compare, scenes
    scenes.new_scene()
    made = bpy.data.images.new("flat_nrm", 8, 8)
    made.pixels.foreach_set([0.5, 0.5, 1.0, 1.0] * 64)          # a flat tangent normal map
    made.filepath_raw, made.file_format = str(tmp_path / "flat_nrm.png"), "PNG"
    made.save()
    bpy.data.images.remove(made)
    sphere = bpy.data.objects["Sphere"]
    for method in ("height-map", "triplanar-height", "volume-noise"):
        with pytest.raises(compare.CompareError, match=rf"method '{method}' reads no normal "
                           r"map, so --image would change nothing: leave --image out"):
            compare.compare_object(sphere, method, 16, image=str(tmp_path / "flat_nrm.png"),
                                   log=lambda *_: None)
    # A method that reads it takes it: a flat map bakes the surface's own normal, no tilt.
    report, _ = compare.compare_object(sphere, "normal-map", 16,
                                       image=str(tmp_path / "flat_nrm.png"), log=lambda *_: None)
    assert report["max_deg"] < 0.5 and report["tilt_mean_deg"] < 0.5


@pytest.mark.tier("bake")
def test_bake_normal_map_without_blend_and_no_file_open_is_refused(tmp_path, capsys):
    pytest.importorskip("bpy")
    import bpy
    from surfgrad_addon.addon import commands
    bpy.ops.wm.read_factory_settings(use_empty=False)      # what python -m starts with
    assert bpy.data.filepath == "" and bpy.data.objects.get("Cube") is not None
    out = tmp_path / "rock.png"
    rc = commands.execute(["bake-normal-map", "--object", "Cube", "--output", str(out),
                           "--resolution", "8"])
    err = capsys.readouterr().err
    assert rc == 2, err                                       # before: 0, the cube's map
    assert "no --blend given and no saved .blend is open" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
    # A setting's problem is still the one named (the help's ranges first).
    assert commands.execute(["bake-normal-map", "--object", "Cube", "--output", str(out),
                             "--resolution", "3"]) == 2
    assert "resolution 3: use a whole number of texels from 4 to 16384" in \
        capsys.readouterr().err


@pytest.mark.tier("blender")
def test_demo_no_bake_with_pictures_is_refused_before_anything_runs(tmp_path, capsys):
    from surfgrad_addon.harness import cli
    out = tmp_path / "demo"
    rc = cli.main(["demo", "--no-bake", "--pictures", "--resolution", "8", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2, err                      # before: 0, index.html and no picture
    assert "--pictures renders the exhibits with Cycles, and --no-bake skips" in err
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.tier("bake")
@pytest.mark.parametrize("command", [
    ["compare", "--object", "Torus", "--method", "normal-map", "--resolution", "16", "--json"],
    ["bench-reference", "--sizes", "--method-sizes", "--compare-sizes", "--memory-sizes",
     "--repeats", "1", "--out"],
    ["bench-compare", "--sizes", "8", "--repeats", "1", "--out"]])
def test_a_json_output_ending_in_a_slash_is_a_folder_and_refused(command, tmp_path, capsys):
    from surfgrad_addon.harness import cli
    given = str(tmp_path / "reports") + "/"
    rc = cli.main([*command, given])
    err = capsys.readouterr().err
    assert rc == 2, err                      # before: 0, a file named 'reports'
    assert f"{given!r} ends in '/', a folder" in err and f"(e.g. '{given}" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.tier("bake")
def test_a_manifest_ending_in_a_slash_is_a_folder_and_refused(tmp_path, capsys):
    pytest.importorskip("bpy")
    from surfgrad_addon.harness import batch_assets as BA
    from surfgrad_addon.addon import commands
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    given = str(tmp_path / "maps" / "manifests") + "/"
    rc = commands.execute(["bake-batch", str(blend), "--workers", "0", "--resolution", "8",
                           "--output", str(tmp_path / "maps" / "{object}.png"),
                           "--manifest", given])
    err = capsys.readouterr().err
    assert rc == 2, err            # before: 0, the manifest written as a file 'manifests'
    assert f"manifest {given!r} ends in '/', a folder" in err
    assert "surfgrad-bake-manifest.json" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.blend"]
