"""The installable extension: Blender's validator and builder, a headless install into an
isolated user folder, the Add menu and its operator, a clean disable, and a .blend that renders
the same without the extension.

Every Blender session that installs or opens something runs in a subprocess (this file run as a
script, `python tests/test_extension.py MODE ...`) with its own BLENDER_USER_RESOURCES, set
before `import bpy`, so nothing touches the real user folder or this process.
"""

import json
import os
import sys
import time
import zipfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from support.blender import new_material  # noqa: E402 (a sibling: this file also runs as a script)

pytestmark = pytest.mark.tier("child")


ROOT = Path(__file__).resolve().parents[1]

EXT_MODULE = "bl_ext.user_default.surfgrad"
MENU_LABEL = "Surface Gradient"
BAKE_SIZE = 48
RENDER_SIZE = 24


# ---------------------------------------------------------------------------------------------
# Blender-side code (runs in the subprocesses)
# ---------------------------------------------------------------------------------------------

class Recorder:
    """A stand-in for UILayout: records menu(), operator() (with the properties the draw
    function sets) and separator() calls."""

    def __init__(self):
        self.calls = []
        self.operator_context = 'INVOKE_DEFAULT'

    def menu(self, idname, **kw):
        self.calls.append(("menu", idname, kw))

    def operator(self, idname, **kw):
        props = SimpleNamespace()
        self.calls.append(("operator", idname, dict(kw, props=props)))
        return props

    def separator(self, **kw):
        self.calls.append(("separator", None, kw))

    def __getattr__(self, name):          # anything else a draw function might call
        def call(*args, **kw):
            self.calls.append((name, args, kw))
            return SimpleNamespace()
        return call


def _draw(draw_fn, tree_type):
    layout = Recorder()
    space = SimpleNamespace(type='NODE_EDITOR', tree_type=tree_type)
    draw_fn(SimpleNamespace(layout=layout), SimpleNamespace(space_data=space))
    return layout.calls


def _shader_editor(bpy, tree):
    """Turn the first area of the (background) window into a Shader Editor showing `tree`;
    returns the keywords for context.temp_override."""
    win = bpy.context.window_manager.windows[0]
    area = win.screen.areas[0]
    area.type = 'NODE_EDITOR'
    area.ui_type = 'ShaderNodeTree'
    space = area.spaces.active
    space.pin = True
    space.node_tree = tree
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return dict(window=win, area=area, region=region), space


def _poll_message(bpy, **override):
    with bpy.context.temp_override(**override):
        if bpy.ops.surfgrad.add_group.poll():
            return None
        try:
            bpy.ops.surfgrad.add_group(group="SG Resolve")
        except RuntimeError as ex:
            return str(ex)
    return "no error raised"


def _group_descriptions(bpy, names):
    """Missing descriptions of the named groups and of every group nested in them."""
    missing, seen, todo = [], set(), list(names)
    while todo:
        tree = bpy.data.node_groups[todo.pop()]
        if tree.name in seen:
            continue
        seen.add(tree.name)
        if not tree.description.strip():
            missing.append(f"{tree.name}: group description")
        for item in tree.interface.items_tree:
            if item.item_type == 'SOCKET' and not item.description.strip():
                missing.append(f"{tree.name}: {item.in_out.lower()} {item.name!r}")
        todo += [n.node_tree.name for n in tree.nodes
                 if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None]
    return sorted(seen), missing


def _registration_state(bpy):
    add_menu = bpy.types.NODE_MT_shader_node_add_all
    return {
        "enabled": bpy.context.preferences.addons.find(EXT_MODULE) >= 0,
        "hooks": [f"{f.__module__}.{f.__qualname__}" for f in add_menu._dyn_ui_initialize()
                  if f.__module__.startswith(EXT_MODULE)],
        "menu_class": hasattr(bpy.types, "NODE_MT_surfgrad_add"),
        "operator_class": hasattr(bpy.types, "SURFGRAD_OT_add_group"),
        "operator_in_ops": "add_group" in dir(bpy.ops.surfgrad),
    }


def build_scene(bpy, add_group):
    """A tilted plane whose material runs a procedural tangent-space normal map through
    SG Normal Map into SG Resolve, and the resolved normal into a Principled BSDF's Normal
    (rendered) and an Emission (baked: EMIT). `add_group(tree, name)` adds a group node."""
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=2.0, rotation=(0.3, -0.2, 0.4))
    plane = bpy.context.active_object
    plane.name = "SG Plane"
    mat = new_material("SG Plane")
    if mat.node_tree is None:                 # before 5.0
        mat.use_nodes = True
    plane.data.materials.append(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = next(n for n in nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    out = next(n for n in nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = 'RGBA'
    mix.inputs[0].default_value = 0.45
    mix.inputs[6].default_value = (0.5, 0.5, 1.0, 1.0)
    links.new(noise.outputs["Color"], mix.inputs[7])
    normal_map = add_group(mat.node_tree, "SG Normal Map")
    resolve = add_group(mat.node_tree, "SG Resolve")
    links.new(mix.outputs[2], normal_map.inputs["Color"])
    links.new(normal_map.outputs["Surface Gradient"], resolve.inputs["Surface Gradient"])
    links.new(resolve.outputs["Normal"], bsdf.inputs["Normal"])
    emit = nodes.new("ShaderNodeEmission")
    links.new(resolve.outputs["Normal"], emit.inputs["Color"])
    both = nodes.new("ShaderNodeAddShader")
    links.new(bsdf.outputs[0], both.inputs[0])
    links.new(emit.outputs[0], both.inputs[1])
    links.new(both.outputs[0], out.inputs["Surface"])
    image = bpy.data.images.new("SG Bake Target", BAKE_SIZE, BAKE_SIZE, alpha=True,
                                float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    target = nodes.new("ShaderNodeTexImage")
    target.image = image
    nodes.active = target

    bpy.ops.object.camera_add(location=(0.0, 0.0, 4.0), rotation=(0.0, 0.0, 0.0))
    scene.camera = bpy.context.active_object
    bpy.ops.object.light_add(type='SUN', rotation=(0.6, 0.3, 0.0))
    bpy.context.active_object.data.energy = 3.0
    scene.render.engine = 'CYCLES'
    cy = scene.cycles
    cy.device, cy.samples, cy.seed = 'CPU', 4, 0
    cy.use_denoising = cy.use_adaptive_sampling = False
    scene.render.resolution_x = scene.render.resolution_y = RENDER_SIZE
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.bake.margin = 0
    return plane


def bake_and_render(bpy, work, tag):
    """EMIT bake (the resolved normal), NORMAL bake (the Principled BSDF's normal) and a
    Cycles render of the scene build_scene made; returns {name: float32 array}."""
    view_layer = bpy.context.view_layer
    plane = bpy.data.objects["SG Plane"]
    for o in view_layer.objects:
        o.select_set(False)
    plane.select_set(True)
    view_layer.objects.active = plane
    image = bpy.data.images["SG Bake Target"]
    arrays = {}
    for bake_type in ("EMIT", "NORMAL"):
        image.pixels.foreach_set(np.zeros(BAKE_SIZE * BAKE_SIZE * 4, np.float32))
        result = bpy.ops.object.bake(type=bake_type, normal_space='OBJECT', margin=0,
                                     use_clear=False)
        assert result == {'FINISHED'}, result
        px = np.empty(BAKE_SIZE * BAKE_SIZE * 4, np.float32)
        image.pixels.foreach_get(px)
        arrays[bake_type] = px.reshape(BAKE_SIZE, BAKE_SIZE, 4)
    path = Path(work) / f"{tag}_render.exr"
    bpy.context.scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    rendered = bpy.data.images.load(str(path))
    px = np.empty(len(rendered.pixels), np.float32)
    rendered.pixels.foreach_get(px)
    arrays["render"] = px.reshape(RENDER_SIZE, RENDER_SIZE, 4)
    return arrays


def session_installed(zip_path, work):
    """Install and enable the built zip, inspect the menu, run the operator for every entry,
    save the test scene, then disable (and re-enable, re-disable) the extension."""
    import bpy

    work = Path(work)
    report = {}
    bpy.ops.wm.read_factory_settings(use_empty=True)   # before installing: it resets add-ons
    t0 = time.perf_counter()
    report["install"] = sorted(bpy.ops.extensions.package_install_files(
        filepath=str(zip_path), repo='user_default', enable_on_install=True))
    report["install_seconds"] = time.perf_counter() - t0
    report["module_file"] = getattr(sys.modules.get(EXT_MODULE), "__file__", None)
    report["user_resources"] = os.environ["BLENDER_USER_RESOURCES"]
    report["state_enabled"] = _registration_state(bpy)
    groups = sys.modules[EXT_MODULE + ".addon.groups"]
    report["menu_groups"] = [name for name, _ in groups.MENU_GROUPS if groups.offered(name)]

    # The Add menu -> "Surface Gradient" submenu -> operator entries, drawn with a recorder.
    add_menu = bpy.types.NODE_MT_shader_node_add_all
    hooks = [f for f in add_menu._dyn_ui_initialize() if f.__module__.startswith(EXT_MODULE)]
    report["hook_calls_geometry"] = [c[0] for h in hooks for c in _draw(h, 'GeometryNodeTree')]
    submenus = [c[1] for h in hooks for c in _draw(h, 'ShaderNodeTree') if c[0] == "menu"]
    report["submenus"] = [(idname, getattr(bpy.types, idname).bl_label) for idname in submenus]
    menu_cls = next(getattr(bpy.types, i) for i in submenus
                    if getattr(bpy.types, i).bl_label == MENU_LABEL)
    drawn = [c for c in _draw(menu_cls.draw, 'ShaderNodeTree') if c[0] == "operator"]
    # After the group entries come the artist operators (layer stack, convert, decal).
    report["tool_entries"] = [c[1] for c in drawn if c[1] != "surfgrad.add_group"]
    entries = [(c[1], c[2]["text"], vars(c[2]["props"]))
               for c in drawn if c[1] == "surfgrad.add_group"]
    report["entries"] = [{"operator": op, "text": text, "props": props}
                         for op, text, props in entries]
    operators = {}
    for op_id in sorted({op for op, _, _ in entries}):
        mod, fn = op_id.split(".")
        op = getattr(getattr(bpy.ops, mod), fn)
        cls = getattr(bpy.types, op.idname())
        operators[op_id] = {
            "class": cls.__name__, "bl_options": sorted(cls.bl_options),
            "description": op.get_rna_type().description,
            "tooltips": {text: cls.description(None, SimpleNamespace(**props))
                         for o, text, props in entries if o == op_id},
        }
    report["operators"] = operators

    # Poll messages: no node editor, a node editor without a tree, a non-shader editor.
    win = bpy.context.window_manager.windows[0]
    view3d = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
    report["poll_view3d"] = _poll_message(
        bpy, window=win, area=view3d, region=view3d.regions[-1])
    override, space = _shader_editor(bpy, None)
    space.pin = False
    report["poll_no_tree"] = _poll_message(bpy, **override)
    override["area"].ui_type = 'GeometryNodeTree'
    report["poll_geometry_editor"] = _poll_message(bpy, **override)

    # Every entry through the operator, as the menu would run it (EXEC: no mouse event).
    mat = new_material("SG All Groups")
    if mat.node_tree is None:
        mat.use_nodes = True
    override, space = _shader_editor(bpy, mat.node_tree)
    added = []
    with bpy.context.temp_override(**override):
        for k, (op_id, text, props) in enumerate(entries):
            cursor = (300.0 * k, -100.0 * k)
            space.cursor_location = cursor
            mod, fn = op_id.split(".")
            result = getattr(getattr(bpy.ops, mod), fn)(**props)
            tree = mat.node_tree
            node = tree.nodes.active
            added.append({
                "text": text, "result": sorted(result), "node_type": node.bl_idname,
                "group": node.node_tree.name if node.node_tree else None,
                "selected": [n.name for n in tree.nodes if n.select] == [node.name],
                "location_ok": abs(node.location.x - cursor[0]) < 1e-3
                and abs(node.location.y - cursor[1]) < 1e-3})
        # Invoke (as from the menu) without starting the transform.
        result = bpy.ops.surfgrad.add_group('INVOKE_DEFAULT', group=entries[0][2]["group"],
                                           use_transform=False)
        report["invoke"] = sorted(result)
        try:
            bpy.ops.surfgrad.add_group(group="No Such Group")
            report["unknown_group"] = "no error"
        except RuntimeError as ex:
            report["unknown_group"] = str(ex)
    report["added"] = added
    # Once a group is in the file, its menu entry's tooltip starts with its description.
    cls = bpy.types.SURFGRAD_OT_add_group
    report["tooltips_after"] = {
        text: [cls.description(None, SimpleNamespace(**props)),
               bpy.data.node_groups[props["group"]].description]
        for _, text, props in entries}
    report["groups_checked"], report["missing_descriptions"] = _group_descriptions(
        bpy, [a["group"] for a in added if a["group"]])

    # Undo: operators called from Python push no undo step of their own (bpy.ops runs them
    # inside the caller's step), so push around the call like the UI would, then undo/redo.
    undo_mat = new_material("SG Undo")
    if undo_mat.node_tree is None:
        undo_mat.use_nodes = True
    override, space = _shader_editor(bpy, undo_mat.node_tree)
    before = len(undo_mat.node_tree.nodes)
    bpy.ops.ed.undo_push(message="before")
    with bpy.context.temp_override(**override):
        bpy.ops.surfgrad.add_group(group="SG Blend Normals")
    bpy.ops.ed.undo_push(message="Add Surface Gradient Group")
    after = len(bpy.data.materials["SG Undo"].node_tree.nodes)
    bpy.ops.ed.undo()
    undone = len(bpy.data.materials["SG Undo"].node_tree.nodes)
    bpy.ops.ed.redo()
    redone = len(bpy.data.materials["SG Undo"].node_tree.nodes)
    report["undo_counts"] = [before, after, undone, redone]

    # The scene of the reopen test, its groups added through the operator.
    def add_group(tree, name):
        override, space = _shader_editor(bpy, tree)
        with bpy.context.temp_override(**override):
            assert bpy.ops.surfgrad.add_group(group=name) == {'FINISHED'}
        return tree.nodes.active

    build_scene(bpy, add_group)
    blend = work / "surfgrad_scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    np.savez(work / "installed_arrays.npz", **bake_and_render(bpy, work, "installed"))
    report["blend"] = str(blend)

    # Disable, re-enable, disable.
    bpy.ops.preferences.addon_disable(module=EXT_MODULE)
    report["state_disabled"] = _registration_state(bpy)
    all_groups = bpy.data.materials["SG All Groups"].node_tree  # re-fetched: undo reloads IDs
    report["groups_after_disable"] = [n.node_tree.name for n in all_groups.nodes
                                      if n.bl_idname == "ShaderNodeGroup" and n.node_tree]
    bpy.ops.preferences.addon_enable(module=EXT_MODULE)
    report["state_reenabled"] = _registration_state(bpy)
    bpy.ops.preferences.addon_disable(module=EXT_MODULE)
    report["state_disabled_again"] = _registration_state(bpy)
    bpy.ops.preferences.addon_enable(module=EXT_MODULE)
    # (Re-enabled for it.) The TD command of the installed extension (`blender -c surfgrad bake-normal-map ...`):
    # registered with Blender's CLI machinery, run here through its handler (the bpy module
    # has no -c), with the installed module's own imports.
    commands = sys.modules[EXT_MODULE + ".addon.commands"]
    report["cli_registered"] = commands.is_registered()
    bake_obj = next(o.name for o in bpy.data.objects if o.type == "MESH" and o.active_material)
    nrm = work / "cli_normal.png"
    report["cli_ok"] = commands.execute(["bake-normal-map", "--blend", str(blend), "--object",
                                         bake_obj, "--output", str(nrm), "--resolution", "32"])
    report["cli_file"] = nrm.is_file() and nrm.stat().st_size > 100
    report["cli_bad"] = commands.execute(["bake-normal-map", "--blend", str(blend), "--object",
                                          "No Such Object", "--output", str(nrm)])
    report["cli_exists"] = commands.execute(["bake-normal-map", "--blend", str(blend),
                                             "--object", bake_obj, "--output", str(nrm)])
    # bake-batch with a worker process started from the installed extension's own folder.
    maps = work / "batch_maps"
    report["batch_rc"] = commands.execute(["bake-batch", str(blend), "--objects", bake_obj,
                                           "--output", str(maps / "{file}_{object}.<UDIM>.png"),
                                           "--resolution", "16", "--workers", "1"])
    report["batch_files"] = sorted(p.name for p in maps.glob("*.png"))
    report["batch_manifest"] = (maps / "surfgrad-bake-manifest.json").is_file()
    report["batch_object"] = bake_obj
    # The installed extension's api: what the extension does, and no harness behind it.
    import importlib
    api = importlib.import_module(EXT_MODULE + ".api")
    report["api_groups"] = api.group_names()
    report["api_group"] = api.node_group("SG Resolve").name
    api_map = work / "api_normal.png"
    report["api_bake"] = str(api.bake_normal_map(bpy.data.objects[bake_obj], api_map,
                                                 resolution=16, log=lambda *_: None))
    report["api_bake_file"] = api_map.is_file() and api_map.stat().st_size > 100
    try:
        api.compare
    except AttributeError as err:
        report["api_compare"] = str(err)
    report["harness_loaded"] = sorted(m for m in sys.modules if ".harness" in m
                                      or m.startswith("surfgrad_addon"))

    bpy.ops.preferences.addon_disable(module=EXT_MODULE)
    (work / "installed_report.json").write_text(json.dumps(report, indent=1))


def session_reopen(blend, work):
    """Open the saved file in a session that never saw the extension; bake and render."""
    import bpy

    work = Path(work)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    report = {
        "extension_modules": sorted(m for m in sys.modules if m.startswith(EXT_MODULE)),
        "installed_here": (Path(os.environ["BLENDER_USER_RESOURCES"]) / "extensions"
                           / "user_default" / "surfgrad").exists(),
        "addons": [a.module for a in bpy.context.preferences.addons],
        "menu_class": hasattr(bpy.types, "NODE_MT_surfgrad_add"),
        "node_groups": sorted(g.name for g in bpy.data.node_groups),
    }
    np.savez(work / "reopen_arrays.npz", **bake_and_render(bpy, work, "reopen"))
    (work / "reopen_report.json").write_text(json.dumps(report, indent=1))


# ---------------------------------------------------------------------------------------------
# pytest side
# ---------------------------------------------------------------------------------------------

def run_session(mode, user_dir, *args, timeout=180):
    # No checkout on the path: the session must use the installed extension alone.
    from support.child import run_python
    t0 = time.perf_counter()
    out = run_python([Path(__file__).resolve(), mode, *args], cwd=user_dir, timeout=timeout,
                     env={"BLENDER_USER_RESOURCES": str(user_dir)}, checkout=False)
    assert out.returncode == 0, \
        f"{mode} session failed:\n{out.stdout[-3000:]}\n{out.stderr[-5000:]}"
    return out, time.perf_counter() - t0


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("ext_build")
    from support.child import run_python
    out = run_python(["-m", "surfgrad_addon.harness.package", "--out", out_dir], timeout=120)
    assert out.returncode == 0, out.stderr
    zip_path = Path(out.stdout.strip().splitlines()[-1])
    return SimpleNamespace(zip=zip_path, log=out.stderr, out_dir=out_dir)


@pytest.fixture(scope="module")
def installed(built, tmp_path_factory):
    user = tmp_path_factory.mktemp("user_installed")
    work = tmp_path_factory.mktemp("work")
    run_session("installed", user, built.zip, work)
    report = json.loads((work / "installed_report.json").read_text())
    return SimpleNamespace(report=report, work=work, user=user)


def test_validator_and_builder_make_the_expected_zip(built):
    from surfgrad_addon.harness import package
    manifest = package.manifest()
    assert built.zip.name == package.zip_name() == f"surfgrad-{manifest['version']}.zip"
    assert manifest["id"] == "surfgrad"
    assert built.zip.parent == built.out_dir.resolve()
    # The validator ran on the staged source and on the zip, the builder made the zip.
    assert built.log.count("Success parsing TOML") == 2, built.log
    assert "created:" in built.log, built.log
    with zipfile.ZipFile(built.zip) as zf:
        names = set(zf.namelist())
        manifest_bytes = zf.read("blender_manifest.toml")
    assert names == package.expected_files()
    assert {"blender_manifest.toml", "__init__.py", "addon/ui.py", "addon/groups/__init__.py",
            "addon/normal_bake.py", "reference/__init__.py"} <= names
    for name in names:
        assert not name.startswith(("tests/", ".venv/", "out/", ".git/", ".ci/")), name
        # The proving harness stays out of the zip (README, "The extension").
        assert not name.startswith("harness/") and name not in (
            "__main__.py", "bake_normal_map.py", "blender_cli.py"), name
        assert "__pycache__" not in name and not name.endswith((".pyc", ".zip")), name
    assert manifest_bytes == (ROOT / "blender_manifest.toml").read_bytes()


def test_an_existing_zip_is_replaced_only_when_asked(built, tmp_path):
    """A second build into a folder holding the zip is refused (exit 2, the zip as it was);
    with --overwrite the new zip replaces it, built beside it first, nothing else left."""
    import shutil
    from support.child import run_python
    old = tmp_path / built.zip.name
    shutil.copy2(built.zip, old)
    old.write_bytes(old.read_bytes() + b"an older build")     # told apart from a new one
    before = old.read_bytes()
    out = run_python(["-m", "surfgrad_addon.harness.package", "--out", tmp_path], timeout=120)
    assert out.returncode == 2, out.stderr
    assert f"{old} exists: pass --overwrite to replace it" in out.stderr, out.stderr
    assert old.read_bytes() == before and sorted(tmp_path.iterdir()) == [old]
    out = run_python(["-m", "surfgrad_addon.harness.package", "--out", tmp_path,
                      "--overwrite"], timeout=120)
    assert out.returncode == 0, out.stderr
    assert sorted(tmp_path.iterdir()) == [old]
    with zipfile.ZipFile(old) as new, zipfile.ZipFile(built.zip) as first:
        assert sorted(new.namelist()) == sorted(first.namelist())


def test_the_zip_imports_nothing_it_does_not_hold(built, tmp_path):
    """Every module in the built zip, read with ast (lazy imports too), imports only modules
    the zip holds: nothing of the harness, no cycle (tests/test_imports.py does the checkout)."""
    from support import imports as I
    root = tmp_path / "surfgrad_addon"       # the zip's root is the package's own folder
    with zipfile.ZipFile(built.zip) as zf:
        py = [n for n in zf.namelist() if n.endswith(".py")]
        for name in py:
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            (root / name).write_bytes(zf.read(name))
    edges = I.graph(root=tmp_path)
    assert len(edges) == len(py) > 40
    assert not [m for m in edges if ".harness" in m]
    outside = {m: sorted(t for t in ts if t not in edges) for m, ts in edges.items()}
    assert not {m: t for m, t in outside.items() if t}
    assert I.cycles(edges) == []


def test_validator_rejects_a_bad_manifest(tmp_path):
    """The validator is Blender's, not a formality: a tagline ending in a full stop
    fails it."""
    code = (
        "from pathlib import Path\n"
        "from surfgrad_addon.harness import package as P\n"
        "src = P.stage(Path(r'%s') / 'src')\n"
        "m = src / 'blender_manifest.toml'\n"
        "m.write_text(m.read_text().replace('layered detail\"', 'layered detail.\"'))\n"
        "try:\n"
        "    P.validate(src)\n"
        "except P.ExtensionToolError as ex:\n"
        "    print('REJECTED', ex)\n" % tmp_path)
    from support.child import run_python
    out = run_python(["-c", code], timeout=120)
    assert out.returncode == 0, out.stderr
    assert "REJECTED" in out.stdout and "tagline" in out.stdout, out.stdout


def test_install_menu_operator_and_clean_disable(installed):
    r = installed.report
    assert r["install"] == ["FINISHED"]
    # Installed into the isolated user folder, enabled as bl_ext.user_default.surfgrad.
    assert r["module_file"].startswith(r["user_resources"]), r["module_file"]
    on = r["state_enabled"]
    assert on["enabled"] and on["menu_class"] and on["operator_class"] and on["operator_in_ops"]
    assert on["hooks"] == [EXT_MODULE + ".addon.ui.draw_add_menu"]
    # The Add menu hook draws only the submenu, and only in shader trees.
    assert r["hook_calls_geometry"] == []
    assert r["submenus"] == [["NODE_MT_surfgrad_add", MENU_LABEL]]
    # One entry per menu group, in order, each running surfgrad.add_group.
    assert r["menu_groups"] and len(r["menu_groups"]) >= 7
    assert [e["text"] for e in r["entries"]] == r["menu_groups"]
    assert [e["props"]["group"] for e in r["entries"]] == r["menu_groups"]
    assert {e["operator"] for e in r["entries"]} == {"surfgrad.add_group"}
    assert r["tool_entries"] == ["surfgrad.add_layer_stack", "surfgrad.convert_node",
                                 "surfgrad.add_decal_projector", "surfgrad.freeze_stack",
                                 "surfgrad.thaw_stack", "surfgrad.update_groups"]
    op = r["operators"]["surfgrad.add_group"]
    assert op["class"] == "SURFGRAD_OT_add_group"
    assert op["bl_options"] == ["REGISTER", "UNDO"]
    assert len(op["description"]) > 40
    assert set(op["tooltips"]) == set(r["menu_groups"])
    assert all(name in tip for name, tip in op["tooltips"].items())
    for name, (tip, description) in r["tooltips_after"].items():
        assert description and tip.startswith(description.rstrip(". ")) and name in tip, tip
    # Clear messages without a shader node tree.
    assert "Shader Editor" in r["poll_view3d"], r["poll_view3d"]
    assert "No active shader node tree" in r["poll_no_tree"], r["poll_no_tree"]
    # (A Geometry Nodes editor's own reason: SG Displace goes there; red team 53d.)
    assert "No active Geometry Nodes tree" in r["poll_geometry_editor"], \
        r["poll_geometry_editor"]
    assert "unknown surface-gradient group" in r["unknown_group"]
    # The installed extension's TD command works, refuses bad input with a code, and the
    # whole session loaded no module of the proving harness (nor the checkout's package).
    assert r["cli_registered"] and r["cli_ok"] == 0 and r["cli_file"]
    assert r["cli_bad"] == 2 and r["cli_exists"] == 2
    assert r["batch_rc"] == 0 and r["batch_manifest"]
    assert r["batch_files"] and all(n.startswith(f"surfgrad_scene_{r['batch_object']}.10")
                                    for n in r["batch_files"]), r["batch_files"]
    assert set(r["menu_groups"]) <= set(r["api_groups"]) and "SG Displace" in r["api_groups"]
    assert r["api_group"] == "SG Resolve"
    assert r["api_bake"] == str(installed.work / "api_normal.png") and r["api_bake_file"]
    assert "moved to surfgrad_addon.harness.api.compare" in r["api_compare"]
    assert r["harness_loaded"] == []
    # Every group added at the cursor, selected and active.
    assert [a["group"] for a in r["added"]] == r["menu_groups"]
    for a in r["added"]:
        assert a["result"] == ["FINISHED"] and a["node_type"] == "ShaderNodeGroup", a
        assert a["selected"] and a["location_ok"], a
    assert r["invoke"] == ["FINISHED"]
    # Every group (and every helper group inside) documents itself and each socket.
    assert set(r["menu_groups"]) <= set(r["groups_checked"])
    assert r["missing_descriptions"] == []
    # Undoable: undo removes the node, redo brings it back.
    before, after, undone, redone = r["undo_counts"]
    assert after == before + 1 and undone == before and redone == after
    # Disabled: menu hook, menu and operator gone; the groups stay in the file.
    for key in ("state_disabled", "state_disabled_again"):
        off = r[key]
        assert off == {"enabled": False, "hooks": [], "menu_class": False,
                       "operator_class": False, "operator_in_ops": False}, (key, off)
    assert r["state_reenabled"] == on
    assert r["groups_after_disable"][:len(r["menu_groups"])] == r["menu_groups"]


def test_saved_file_renders_the_same_without_the_extension(installed, tmp_path):
    user = tmp_path / "user_empty"
    user.mkdir()
    run_session("reopen", user, installed.report["blend"], tmp_path)
    r = json.loads((tmp_path / "reopen_report.json").read_text())
    assert r["extension_modules"] == [] and not r["installed_here"] and not r["menu_class"]
    assert not any(m.startswith("bl_ext.") for m in r["addons"]), r["addons"]
    assert {"SG Normal Map", "SG Resolve"} <= set(r["node_groups"])
    a = np.load(installed.work / "installed_arrays.npz")
    b = np.load(tmp_path / "reopen_arrays.npz")
    assert sorted(a.files) == sorted(b.files) == ["EMIT", "NORMAL", "render"]
    for key in a.files:
        assert a[key].shape == b[key].shape, key
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    # ... and the groups did something: covered texels hold varying unit normals.
    emit = a["EMIT"]
    covered = emit[..., 3] > 0.5
    assert covered.mean() > 0.2
    n = emit[covered][:, :3]
    np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1.0, atol=2e-3)
    assert n.std(axis=0).max() > 0.02
    assert np.isfinite(a["render"]).all() and a["render"][..., :3].max() > 0.0



if __name__ == "__main__":
    {"installed": session_installed, "reopen": session_reopen}[sys.argv[1]](*sys.argv[2:])
