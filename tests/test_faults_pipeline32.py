"""Fault injection, red team 32b: what a pipeline TD meets that earlier rounds left.

Geometry Nodes instances left unrealized (and vertex instancing) render with the object, but
Blender's bake renders only its realized mesh: a part instanced with the object's material on
its own UVs came out as the flat background with exit 0, and compare said nothing."""

import json

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.tier("bake")


# Scenes ------------------------------------------------------------------------------------------

def _grid(name, u0=0.0, u1=1.0, n=4):
    """An n x n grid on [-1, 1]^2, gently waved, its UVs on u0..u1 x 0..1."""
    me = bpy.data.meshes.new(name)
    verts = [(x / n * 2 - 1, y / n * 2 - 1, 0.1 * np.sin(3 * x + y))
             for y in range(n + 1) for x in range(n + 1)]
    faces = [(y * (n + 1) + x, y * (n + 1) + x + 1, (y + 1) * (n + 1) + x + 1,
              (y + 1) * (n + 1) + x) for y in range(n) for x in range(n)]
    me.from_pydata(verts, [], faces)
    uv = me.uv_layers.new(name="UVMap")
    for loop in me.loops:
        x, y, _ = verts[loop.vertex_index]
        uv.data[loop.index].uv = (u0 + (x + 1) / 2 * (u1 - u0), (y + 1) / 2)
    return me


def _material(name):
    """Noise -> Bump -> Principled: a normal that varies over the surface."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0):       # 5.0+: every material has its node tree
        mat.use_nodes = True
    nt = mat.node_tree
    noise = nt.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 8.0
    bump = nt.nodes.new("ShaderNodeBump")
    nt.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    nt.links.new(bump.outputs["Normal"], nt.nodes["Principled BSDF"].inputs["Normal"])
    return mat


def _object(me, name):
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _instancing_modifier(obj, instance_of, realize=False, count=1, keep_own=True):
    """Geometry Nodes: `count` instances of `instance_of` (an object, or None: the object's
    own geometry) on points along x, joined with the object's own mesh (keep_own)."""
    tree = bpy.data.node_groups.new("Inst", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    geo = nodes.new("NodeGroupInput").outputs[0]
    if instance_of is None:
        source = geo
    else:
        info = nodes.new("GeometryNodeObjectInfo")
        info.inputs["Object"].default_value = instance_of
        source = info.outputs["Geometry"]
    line = nodes.new("GeometryNodeMeshLine")
    line.inputs["Count"].default_value = count
    line.inputs["Start Location"].default_value = (2.5, 0.0, 0.0)
    line.inputs["Offset"].default_value = (2.5, 0.0, 0.0)
    points = nodes.new("GeometryNodeMeshToPoints")
    links.new(line.outputs[0], points.inputs[0])
    inst = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(points.outputs[0], inst.inputs["Points"])
    links.new(source, inst.inputs["Instance"])
    out = inst.outputs[0]
    if realize:
        real = nodes.new("GeometryNodeRealizeInstances")
        links.new(out, real.inputs[0])
        out = real.outputs[0]
    if keep_own:
        join = nodes.new("GeometryNodeJoinGeometry")
        links.new(out, join.inputs[0])
        links.new(geo, join.inputs[0])
        out = join.outputs[0]
    links.new(out, nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("Instances", "NODES").node_group = tree


def _save(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def _half_instanced(path, realize=False):
    """Obj: a grid on the left half of the UV square; a second grid 'Part' with the same
    material on the right half, instanced by Obj's Geometry Nodes (Part itself not rendered)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat = _material("Mat")
    own = _grid("Obj", 0.0, 0.5)
    own.materials.append(mat)
    obj = _object(own, "Obj")
    part_mesh = _grid("Part", 0.5, 1.0)
    part_mesh.materials.append(mat)
    part = _object(part_mesh, "Part")
    part.hide_render = True
    _instancing_modifier(obj, part, realize=realize)
    return _save(path)


def _copies_and_scatter(path):
    """Obj: a grid over the whole UV square with two instances of its own geometry (the same
    UVs) and three of 'Grass', which has a material of its own."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    own = _grid("Obj")
    own.materials.append(_material("Mat"))
    obj = _object(own, "Obj")
    grass_mesh = _grid("Grass")
    grass_mesh.materials.append(_material("GrassMat"))
    grass = _object(grass_mesh, "Grass")
    grass.hide_render = True
    _instancing_modifier(obj, None, count=2)
    _instancing_modifier(obj, grass, count=3)       # a second modifier, on top
    return _save(path)


def _only_instances(path):
    """Obj's Geometry Nodes turn its whole mesh into one instance (nothing realized)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    own = _grid("Obj")
    own.materials.append(_material("Mat"))
    obj = _object(own, "Obj")
    tree = bpy.data.node_groups.new("ToInstance", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    to_instance = tree.nodes.new("GeometryNodeGeometryToInstance")
    tree.links.new(tree.nodes.new("NodeGroupInput").outputs[0], to_instance.inputs[0])
    tree.links.new(to_instance.outputs[0], tree.nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("GN", "NODES").node_group = tree
    return _save(path)


# Running the commands ----------------------------------------------------------------------------

def _bake(capsys, blend, output, *extra):
    """bake-normal-map of Obj in this process at 32^2, margin 0: (exit code, stderr)."""
    from surfgrad_addon.addon import commands
    output.parent.mkdir(exist_ok=True)
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Obj",
                           "--output", str(output), "--resolution", "32", "--margin", "0",
                           *extra])
    return rc, capsys.readouterr().err


def _flat_texels(path):
    """Per half (left, right) of the map: texels that hold exactly the flat normal (0.5, 0.5,
    1), the colour a bake leaves where no face is."""
    img = bpy.data.images.load(str(path))
    try:
        w, h = img.size
        px = np.array(img.pixels[:], dtype=np.float64).reshape(h, w, 4)[..., :3]
    finally:
        bpy.data.images.remove(img)
    flat = np.all(np.abs(px - (0.5, 0.5, 1.0)) < 1e-6, axis=2)
    return int(flat[:, :w // 2].sum()), int(flat[:, w // 2:].sum())


# Unrealized instances ---------------------------------------------------------------------------

def test_instances_of_the_material_where_the_mesh_leaves_texels_empty_are_refused(tmp_path,
                                                                                     capsys):
    """Before: exit 0, and the instanced half of the map was the flat background (512 of 512
    texels at 32^2), nothing said. Now refused (exit 2) naming the part and the fix, no file
    written, the .blend unchanged; --allow-partial bakes the rest with the warning; realized,
    the same part is baked (the evidence that the refusal's map would be partial)."""
    blend = _half_instanced(tmp_path / "half.blend")
    before = blend.read_bytes()
    out = tmp_path / "out"
    rc, err = _bake(capsys, blend, out / "n.exr")
    assert rc == 2, err
    line = [x for x in err.splitlines() if x.startswith("surfgrad: error:")]
    assert len(line) == 1 and "1 unrealized instance(s) of mesh 'Part' (16 faces)" in line[0]
    assert "512 texel(s) (counted at 32^2 a tile) that the realized mesh leaves empty" in line[0]
    assert "Realize Instances" in line[0] and "--allow-partial" in line[0]
    assert "Traceback" not in err and not (out / "n.exr").exists()
    assert list(out.iterdir()) == []
    assert blend.read_bytes() == before

    rc, err = _bake(capsys, blend, out / "partial.exr", "--allow-partial")
    assert rc == 0, err
    assert "surfgrad: warning: object 'Obj' renders 1 unrealized instance(s)" in err
    assert "baked without them (--allow-partial)" in err
    assert _flat_texels(out / "partial.exr") == (0, 512)       # the part is missing: flat

    realized = _half_instanced(tmp_path / "realized.blend", realize=True)
    rc, err = _bake(capsys, realized, out / "realized.exr")
    assert rc == 0, err
    assert "instance" not in err
    assert _flat_texels(out / "realized.exr") == (0, 0)         # realized, it is baked


def test_instanced_copies_and_a_scatter_of_other_materials_bake_with_a_warning(tmp_path,
                                                                                capsys):
    """Copies of the object's own mesh (its UVs: no texel left empty) and instances of another
    material do not make this map partial: baked, exit 0, and (before: nothing) a warning on
    stderr and in bake-batch's manifest naming them and the fix; compare warns too."""
    from surfgrad_addon.addon import commands
    from surfgrad_addon.harness.cli import main
    blend = _copies_and_scatter(tmp_path / "copies.blend")
    out = tmp_path / "out"
    rc, err = _bake(capsys, blend, out / "n.png")
    assert rc == 0, err
    warning = [x for x in err.splitlines() if "unrealized" in x]
    assert len(warning) == 1, err
    assert "renders 5 unrealized instance(s) of mesh 'Obj', mesh 'Grass' (80 faces)" in warning[0]
    assert "the map is complete without them" in warning[0] and "Realize Instances" in warning[0]
    assert _flat_texels(out / "n.png") == (0, 0)

    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(blend), "--objects", "Obj", "--output",
                           str(out / "batch" / "{object}.png"), "--resolution", "32",
                           "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == 0, err
    asset = json.loads((out / "batch" / "surfgrad-bake-manifest.json").read_text())["assets"]
    (entry,) = asset.values()
    assert entry["status"] == "baked"
    assert any("5 unrealized instance(s)" in w for w in entry["warnings"]), entry

    code = main(["compare", "--blend", str(blend), "--object", "Obj", "--method", "normal-map",
                 "--resolution", "32", "--json", str(out / "c.json")])
    assert code == 0, capsys.readouterr().err
    warnings = json.loads((out / "c.json").read_text())["warnings"]
    assert any("5 unrealized instance(s)" in w and "they are not compared" in w
               for w in warnings), warnings


def test_a_partial_instance_fails_its_batch_asset_with_the_line(tmp_path, capsys):
    """bake-batch: the asset fails with the refusal's line (exit 1), in the manifest too."""
    from surfgrad_addon.addon import commands
    blend = _half_instanced(tmp_path / "half.blend")
    out = tmp_path / "out"
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(blend), "--objects", "Obj", "--output",
                           str(out / "{object}.png"), "--resolution", "32", "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert "half.blend:Obj: object 'Obj' renders 1 unrealized instance(s)" in err
    assert not (out / "Obj.png").exists()
    (entry,) = json.loads((out / "surfgrad-bake-manifest.json").read_text())["assets"].values()
    assert entry["status"] == "failed" and "Realize Instances" in entry["error"]


def test_a_mesh_made_all_of_instances_is_named_as_such(tmp_path, capsys):
    """Before: exit 2 with 'UV map 'UVMap' ... is not on the mesh as it renders (a modifier
    removes it ...)', which blamed the UV map. Now the line says the faces are instances."""
    blend = _only_instances(tmp_path / "all.blend")
    rc, err = _bake(capsys, blend, tmp_path / "out" / "n.png")
    assert rc == 2, err
    assert ("surfgrad: error: object 'Obj' renders all its faces as 1 unrealized instance(s) "
            "and Blender's bake renders only the realized mesh, which has none: add a Realize "
            "Instances node") in err
    assert not (tmp_path / "out" / "n.png").exists()


# A farm's limits and closed streams (child processes) ---------------------------------------

def _command(args, cwd, preexec=None, **streams):
    """`python -m surfgrad_addon ARGS` from this checkout: the finished CompletedProcess."""
    import os
    import subprocess
    import sys
    from support.child import ROOT
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=str(ROOT), TMPDIR=str(cwd / "tmp"))
    (cwd / "tmp").mkdir(exist_ok=True)
    return subprocess.run([sys.executable, "-m", "surfgrad_addon", *map(str, args)], cwd=str(cwd),
                          env=env, preexec_fn=preexec, timeout=300, **streams)


def _cpu_limit(seconds):
    """A soft CPU time limit (`ulimit -S -t`, SGE's s_cpu) for a child: SIGXCPU when reached."""
    import resource

    def limit():
        hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
        resource.setrlimit(resource.RLIMIT_CPU, (seconds, hard))
    return limit


@pytest.fixture
def rock(tmp_path):
    from surfgrad_addon.harness import batch_assets as BA
    return BA.write_asset(tmp_path / "rock.blend", ("Rock",), tiles=(1001,), image_size=16)


@pytest.mark.tier("child")
def test_a_cpu_time_limit_stops_the_bake_cleanly_with_the_fix(rock, tmp_path):
    """`ulimit -S -t 4` (SGE's s_cpu): SIGXCPU while Cycles bakes. Before: the process died
    of it (-24; 152 in a shell), no line, Blender's session folder left in $TMPDIR. Now: exit
    152, one line naming the limit and its fix, no map, no temporary file, no session folder.
    (Starting takes about 1.2 s of CPU; the 512^2, 256-sample bake far more than 4 s.)"""
    import subprocess
    out = tmp_path / "out"
    out.mkdir()
    done = _command(["bake-normal-map", "--blend", rock, "--object", "Rock", "--output",
                     out / "n.png", "--resolution", "512", "--samples", "256"], tmp_path,
                    preexec=_cpu_limit(4), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                    text=True)
    assert done.returncode == 152, done.stderr[-2000:]
    assert done.stderr.strip().splitlines()[-1] == (
        "surfgrad: interrupted by SIGXCPU (its CPU time limit was reached: raise `ulimit -t` "
        "or the job's CPU time limit): stopped the bake; exit code 152")
    assert "Traceback" not in done.stderr
    assert list(out.iterdir()) == [] and list((tmp_path / "tmp").iterdir()) == []


@pytest.mark.tier("child")
def test_a_cpu_time_limit_in_a_batch_worker_fails_its_asset_once_with_the_fix(rock, tmp_path):
    """The batch's worker reaches the limit. Before: it died of SIGXCPU, which read as a crash
    (`died (exit code -24)`), and the asset was baked again in a fresh process (the same
    limit: twice the time). Now the worker stops cleanly, the asset fails at once, naming
    the limit."""
    import subprocess
    out = tmp_path / "maps"
    done = _command(["bake-batch", rock, "--output", out / "{object}.png", "--resolution",
                     "512", "--samples", "256", "--workers", "1"], tmp_path,
                    preexec=_cpu_limit(6), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                    text=True)
    assert done.returncode == 1, done.stderr[-2000:]
    (entry,) = json.loads((out / "surfgrad-bake-manifest.json").read_text())["assets"].values()
    assert entry["error"] == ("its worker process was stopped by SIGXCPU (its CPU time limit "
                              "was reached: raise `ulimit -t` or the job's CPU time limit) "
                              "(not retried)"), entry
    assert len(entry["attempts"]) == 1 and "retrying" not in done.stdout
    assert not (out / "Rock.png").exists() and list((tmp_path / "tmp").iterdir()) == []


def _closed(fds):
    """preexec: close these descriptors in the child (a shell's `>&-`, `2>&-`, `<&-`)."""
    import os

    def close():
        for fd in fds:
            os.close(fd)
    return close


@pytest.mark.tier("child")
@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch-0", "bake-batch-1",
                                     "compare"])
def test_a_command_started_with_its_output_closed_runs_to_the_end(rock, tmp_path, command):
    """`... >&-` (stdout closed at the start, as some daemons and schedulers start jobs).
    Before: bake-normal-map ended with an AttributeError traceback ('NoneType' object has no
    attribute 'flush'), exit 1, no map. Now every command runs and writes its files, and
    says nothing on stderr."""
    import subprocess
    out = tmp_path / "out"
    if command == "bake-normal-map":
        args = ["bake-normal-map", "--blend", rock, "--object", "Rock", "--output",
                out / "Rock.png", "--resolution", "32"]
        out.mkdir()
    elif command == "compare":
        args = ["compare", "--blend", rock, "--object", "Rock", "--method", "normal-map",
                "--resolution", "16", "--json", out / "c.json"]
        out.mkdir()
    else:
        args = ["bake-batch", rock, "--output", out / "{object}.png", "--resolution", "32",
                "--workers", command[-1]]
    done = _command(args, tmp_path, preexec=_closed([1]), stderr=subprocess.PIPE, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr and "surfgrad" not in done.stderr
    made = out / ("c.json" if command == "compare" else "Rock.png")
    assert made.stat().st_size > 100
    if command != "compare":
        assert made.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert made.read_bytes()[-8:-4] == b"IEND"      # whole: nothing else written into it


@pytest.mark.tier("child")
def test_a_bake_started_with_every_stream_closed_still_bakes_and_says_nothing(rock, tmp_path):
    """`>&- 2>&- <&-`: exit 0 and the map, the same bytes as with the streams open."""
    import subprocess
    out = tmp_path / "out"
    out.mkdir()
    base = ["bake-normal-map", "--blend", rock, "--object", "Rock", "--resolution", "32"]
    done = _command(base + ["--output", out / "closed.png"], tmp_path, preexec=_closed([0, 1, 2]))
    assert done.returncode == 0
    done = _command(base + ["--output", out / "open.png"], tmp_path, stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL)
    assert done.returncode == 0
    assert (out / "closed.png").read_bytes() == (out / "open.png").read_bytes()


# Paths that are not UTF-8 ------------------------------------------------------------------------

@pytest.fixture
def latin1_folder(tmp_path, rock):
    """A folder whose name holds the Latin-1 byte of 'o-umlaut' (not UTF-8: an old share, an
    unzipped archive), holding a copy of the rock asset."""
    import os
    import shutil
    folder = os.path.join(os.fsencode(tmp_path), b"l\xf6n")
    os.mkdir(folder)
    shutil.copy(rock, os.path.join(folder, b"r.blend"))
    return os.fsdecode(folder)          # '...l\udcf6n', as Python names it


@pytest.mark.tier("child")
def test_a_batch_worker_that_prints_a_non_utf8_path_is_not_taken_for_dead(latin1_folder,
                                                                         tmp_path):
    """bake-batch --workers 1 of a .blend in that folder. Before: Blender's `Read blend:` line
    carries the path's raw byte, the batch's strict decode of the worker's output ended its
    reader, the worker was taken as dead, killed (-9) after 10 s, retried, and the asset
    failed after 22 s: `the worker process died (exit code -9)`. Now baked."""
    import subprocess
    done = _command(["bake-batch", f"{latin1_folder}/r.blend", "--output",
                     f"{latin1_folder}/maps/{{file}}_{{object}}.png", "--resolution", "16",
                     "--workers", "1"], tmp_path, stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE, errors="replace")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "1 baked, 0 skipped, 0 failed" in done.stdout
    assert open(f"{latin1_folder}/maps/r_Rock.png", "rb").read(8) == b"\x89PNG\r\n\x1a\n"


@pytest.mark.tier("child")
@pytest.mark.parametrize("command", ["bake-normal-map", "bake-batch"])
def test_a_non_utf8_output_path_under_a_strict_utf8_stdout_is_named_not_an_error(
        latin1_folder, tmp_path, command):
    """A UTF-8 locale (en_US.UTF-8) makes Python's stdout strict; stood in for here by
    PYTHONIOENCODING=utf-8:strict (this machine has only C locales). Before: bake-normal-map
    wrote the map, then its `[3/3] wrote` line raised, so it said `surfgrad: error: 'utf-8'
    codec can't encode character '\\udcf6'...` and exited 2 with the map in place;
    bake-batch --workers 1 failed the asset the same way in its worker. Now exit 0, the
    path's byte written as an escape."""
    import os
    import subprocess
    if command == "bake-normal-map":
        args = ["bake-normal-map", "--blend", f"{latin1_folder}/r.blend", "--object", "Rock",
                "--output", f"{latin1_folder}/n.png", "--resolution", "16"]
        made = f"{latin1_folder}/n.png"
    else:
        args = ["bake-batch", f"{latin1_folder}/r.blend", "--output",
                f"{latin1_folder}/maps/{{object}}.png", "--resolution", "16", "--workers", "1"]
        made = f"{latin1_folder}/maps/Rock.png"
    env_before = os.environ.get("PYTHONIOENCODING")
    os.environ["PYTHONIOENCODING"] = "utf-8:strict"
    try:
        done = _command(args, tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                        errors="replace")
    finally:
        if env_before is None:
            del os.environ["PYTHONIOENCODING"]
        else:
            os.environ["PYTHONIOENCODING"] = env_before
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "surfgrad: error" not in done.stderr and "Traceback" not in done.stderr
    assert "l\\udcf6n" in done.stdout              # named, as an escape
    assert open(made, "rb").read(8) == b"\x89PNG\r\n\x1a\n"


# An address-space limit (`ulimit -v`) ----------------------------------------------------------

@pytest.mark.tier("child")
def test_a_bake_that_cannot_fit_the_address_space_limit_is_refused_before_it_starts(rock,
                                                                                     tmp_path):
    """`ulimit -v 3900000` (3.7 GB; SGE's h_vmem sets the same limit) and a 4096^2 bake, which
    adds at least 183 bytes a texel (2.8 GB) to the 1.5 GB a started command uses. Before:
    Blender's allocation failed inside the bake (std::bad_alloc: exit 134, or a segmentation
    fault: 139), no line of ours, its session folder left in $TMPDIR. Now refused, exit 2,
    one line naming the limit and the fix, nothing written."""
    import resource
    import subprocess

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (3900000 * 1024, resource.RLIM_INFINITY))
    out = tmp_path / "out"
    out.mkdir()
    done = _command(["bake-normal-map", "--blend", rock, "--object", "Rock", "--output",
                     out / "n.exr", "--resolution", "4096"], tmp_path, preexec=limit,
                    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    assert done.returncode == 2, done.stderr[-2000:]
    (line,) = done.stderr.strip().splitlines()
    # The asset's own 16^2 float texture counts too (its packed data, read from the header).
    assert line.startswith("surfgrad: error: a 4096x4096 bake of 1 tile(s) reading 1 image(s) "
                           "(the largest 'Rock_src', 16x16 float) needs at least 2.9 GB of "
                           "memory beyond the ")
    assert line.endswith("more than its address-space limit of 3.7 GB (`ulimit -v`, or the "
                         "job's memory limit such as SGE's h_vmem), where Blender's bake "
                         "would crash: raise the limit or bake at a lower --resolution")
    assert list(out.iterdir()) == [] and list((tmp_path / "tmp").iterdir()) == []


@pytest.mark.tier("numpy")
def test_the_memory_check_leaves_an_unlimited_process_and_small_bakes_alone(monkeypatch):
    """No limit: nothing to check. Under a limit, a bake within it passes; the bound is the
    measured 180 bytes a texel for the first tile, 50 for each further one."""
    import resource
    from surfgrad_addon.addon import memory_limit as ML
    monkeypatch.setattr(resource, "getrlimit", lambda _: (resource.RLIM_INFINITY,) * 2)
    monkeypatch.setattr(ML, "machine_memory", lambda: None)
    assert ML.bake_memory_problem(16384, 10) is None
    gb = 1024 ** 3
    monkeypatch.setattr(resource, "getrlimit", lambda _: (4 * gb, resource.RLIM_INFINITY))
    monkeypatch.setattr(ML, "address_space_in_use", lambda: 1 * gb)
    # 3 GB of room: 4096^2 x 180 B = 2.81 GB fits one tile, not two (+ 50 B a texel: 3.6 GB)
    assert ML.bake_memory_problem(4096, 1) is None
    assert "a 4096x4096 bake of 2 tile(s) needs at least 3.7 GB" in ML.bake_memory_problem(4096, 2)
    # A 16 GB machine: ten 4096^2 tiles (at least 9.8 GB; 28 GB counted at 180 B a tile) fit.
    monkeypatch.setattr(resource, "getrlimit", lambda _: (resource.RLIM_INFINITY,) * 2)
    monkeypatch.setattr(ML, "machine_memory", lambda: (16 * gb, "16 GB"))
    monkeypatch.setattr(ML, "resident_in_use", lambda: gb // 2)
    assert ML.bake_memory_problem(4096, 10) is None
    assert "needs at least 16.9 GB" in ML.bake_memory_problem(4096, 19)


# A texture changed between the check and the bake ------------------------------------------------

def _rock_with_texture_on_disk(tmp_path):
    """The rock asset with its normal map unpacked beside it (//textures/Rock_src.exr);
    (blend, the texture's path)."""
    from surfgrad_addon.harness import batch_assets as BA
    blend = BA.write_asset(tmp_path / "rock.blend", ("Rock",), tiles=(1001,), image_size=16)
    bpy.ops.wm.open_mainfile(filepath=str(blend), use_scripts=False)
    bpy.ops.file.unpack_all(method="WRITE_LOCAL")
    (image,) = [i for i in bpy.data.images if i.filepath]
    png = tmp_path / bpy.path.abspath(image.filepath).split(str(tmp_path) + "/")[-1]
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert png.is_file() and png.stat().st_size > 100
    return blend, png


def test_a_texture_changed_between_the_check_and_the_bake_fails_the_bake(tmp_path, capsys,
                                                                         monkeypatch):
    """The texture is cut in half after the request's checks read it and before Cycles loads
    it (an artist saving it on the share while the farm bakes). Before: exit 0, a map of
    Cycles' magenta 'missing' colour (every texel (0.54, -0.54, 0.65) decoded). Now exit 1,
    one line naming the file and the fix, no map."""
    from surfgrad_addon.addon import bake_request, commands
    blend, png = _rock_with_texture_on_disk(tmp_path)
    whole = png.read_bytes()
    real = bake_request.NB.bake_normal_tiles

    def cut_then_bake(*args, **kwargs):
        png.write_bytes(whole[:len(whole) // 2])
        return real(*args, **kwargs)
    monkeypatch.setattr(bake_request.NB, "bake_normal_tiles", cut_then_bake)
    out = tmp_path / "out"
    out.mkdir()
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(out / "n.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == 1, err
    (line,) = [x for x in err.splitlines() if x.startswith("surfgrad: error:")]
    assert f"{str(png)!r}" in line and "changed while it was baked" in line, line
    assert list(out.iterdir()) == []


@pytest.mark.tier("numpy")
def test_a_bake_larger_than_the_machine_is_refused_naming_its_memory(monkeypatch):
    """No address-space limit, but a 16384^2 bake (at least 45 GB) on a machine of 24 GB and
    no swap (this one): the OOM killer would end it (SIGKILL, no line; not run here, it would
    take the shared machine's memory). Refused naming the machine's memory; a container's
    lower cgroup limit is named instead where it has one."""
    from surfgrad_addon.addon import memory_limit as ML
    from support.machine_memory import machine_without_swap
    gb = 1024 ** 3
    machine_without_swap(monkeypatch, 24 * gb, gb // 2)
    problem = ML.bake_memory_problem(16384, 1)
    assert problem == ("a 16384x16384 bake of 1 tile(s) needs at least 45.0 GB of memory beyond "
                       "the 0.5 GB this process holds, more than this machine's 24.0 GB of "
                       "memory and 0.0 GB of swap, where the system would kill the bake: bake "
                       "at a lower --resolution, or on a machine with more memory")
    assert ML.bake_memory_problem(8192, 1) is None          # 11.3 GB: fits
    assert ML.machine_memory()[0] == 24 * gb


@pytest.mark.tier("numpy")
def test_a_container_memory_limit_is_the_machine_for_the_check(monkeypatch, tmp_path):
    import resource
    from surfgrad_addon.addon import memory_limit as ML
    gb = 1024 ** 3
    (tmp_path / "memory.max").write_text(f"{4 * gb}\n")
    (tmp_path / "v1").write_text("9223372036854771712\n")       # v1's "no limit"
    monkeypatch.setattr(ML, "CGROUP_LIMITS", (str(tmp_path / "v1"), str(tmp_path / "memory.max")))
    monkeypatch.setattr(resource, "getrlimit", lambda _: (resource.RLIM_INFINITY,) * 2)
    monkeypatch.setattr(ML, "resident_in_use", lambda: 2 * gb)
    assert ML.machine_memory()[0] == 4 * gb
    assert "the memory limit of its control group (4.0 GB, " in ML.bake_memory_problem(4096, 1)
    assert ML.bake_memory_problem(2048, 1) is None          # 0.7 GB: fits


# An output folder behind a dangling link -------------------------------------------------------

@pytest.mark.parametrize("below", ["", "sub/"])
def test_a_batch_output_folder_behind_a_dangling_link_is_named_with_the_fix(rock, tmp_path,
                                                                            capsys, below):
    """`maps` is a symbolic link to a share that is not mounted. Before: exit 2 with
    `surfgrad: error: [Errno 17] File exists: '.../maps'` (the checks walked past the link to
    its writable parent; the folder's mkdir then stopped at it). Now the line names the link,
    its target and the fix; nothing is made."""
    from surfgrad_addon.addon import commands
    link = tmp_path / "maps"
    link.symlink_to(tmp_path / "share" / "maps")
    capsys.readouterr()
    rc = commands.execute(["bake-batch", str(rock), "--output", f"{link}/{below}{{object}}.png",
                           "--resolution", "16", "--workers", "0"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert (f"output folder {str(link) + ('/sub' if below else '')!r}: {str(link)!r} is a "
            f"symbolic link to {str(tmp_path / 'share' / 'maps')!r}, which does not exist (an "
            f"unmounted share or a moved folder?): mount or create it, or give another "
            f"folder") in err
    assert "Errno" not in err and not (tmp_path / "share").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["maps", "rock.blend"]


def test_a_bake_output_folder_that_is_a_dangling_link_says_so(rock, tmp_path, capsys):
    """bake-normal-map into such a link. Before: `output folder '.../maps' does not exist:
    create it first`, where creating it fails (`File exists`). Now the link and its missing
    target are named."""
    from surfgrad_addon.addon import commands
    link = tmp_path / "maps"
    link.symlink_to(tmp_path / "share" / "maps")
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(rock), "--object", "Rock",
                           "--output", str(link / "n.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert (f"surfgrad: error: output folder {str(link)!r} does not exist (it is a symbolic "
            f"link to {str(tmp_path / 'share' / 'maps')!r}, which does not exist: an unmounted "
            f"share or a moved folder?): create it first") in err
