"""The artist operators through bpy.ops, as the sidebar panel and the Add menu run them:
surfgrad.add_layer_stack, surfgrad.convert_node and surfgrad.add_decal_projector in a Shader
Editor, each undoable, each refusing misuse with a clear report and CANCELLED; and the
sidebar panel NODE_PT_surfgrad.

The session runs in a subprocess (this file run as a script, like tests/test_extension.py,
whose Shader Editor set-up it reuses), with the extension registered through its own entry
point (surfgrad_addon.register()) and its own BLENDER_USER_RESOURCES, so nothing is registered
in the pytest process or written to the real user folder. It writes a JSON report the tests
read.

How the session sees what an operator did:
- result: each operator class's execute is wrapped (in the session only) to record what it
  returned, so CANCELLED is checked as returned, not inferred; bpy.ops raises RuntimeError
  with the ERROR report's text, which is the message checked.
- undo: an operator called from Python pushes its own undo step only when called with
  undo=True (bpy.ops.x('EXEC_DEFAULT', True), as the UI does for operators with the UNDO
  option). Two calls, then undo: the second call's work is gone and the first's stays, so
  each call is its own step; undo again: back to the start; redo restores. IDs are fetched
  again by name after every undo/redo (memfile undo reloads them).
"""

import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from support.blender import new_material  # noqa: E402 (a sibling: this file also runs as a script)
from support.operator_session import run_session, write_report  # noqa: E402

pytestmark = pytest.mark.tier("child")


ROOT = Path(__file__).resolve().parents[1]

OPERATORS = ("surfgrad.add_layer_stack", "surfgrad.convert_node",
             "surfgrad.add_decal_projector")
MATERIAL = "SG Operators"


# ---------------------------------------------------------------------------------------------
# Blender-side code (runs in the subprocess)
# ---------------------------------------------------------------------------------------------

class Layout:
    """A stand-in for UILayout that records operator() calls; column()/row() return itself."""

    def __init__(self):
        self.operators = []

    def operator(self, idname, **kw):
        self.operators.append(idname)
        return SimpleNamespace()

    def column(self, **kw):
        return self

    row = box = column

    def __getattr__(self, name):
        return lambda *a, **kw: SimpleNamespace()


def _recording(original, log):
    # Exactly (self, context): Blender calls execute with the argument count it expects
    # (extra parameters with defaults crash it).
    def execute(self, context):
        result = original(self, context)
        log.append(sorted(result))
        return result
    return execute


def _wrap_executes(classes):
    """Record what each operator's execute returns: {bl_idname: [result, ...]}."""
    results = {}
    for cls in classes:
        results[cls.bl_idname] = []
        cls.execute = _recording(cls.execute, results[cls.bl_idname])
    return results


def _tree(bpy, name=MATERIAL):
    return bpy.data.materials[name].node_tree


def _snapshot(bpy, name=MATERIAL):
    """Nodes, links, objects, node groups and drivers: what an operator may add."""
    mat = bpy.data.materials.get(name)
    tree = mat.node_tree if mat else None
    anim = tree.animation_data if tree else None
    def group(node):
        return getattr(getattr(node, "node_tree", None), "name", "")
    return {
        "nodes": sorted(f"{n.name}:{n.bl_idname}:{group(n)}" for n in tree.nodes)
        if tree else [],
        "links": sorted(f"{lk.from_node.name}.{lk.from_socket.identifier}->"
                        f"{lk.to_node.name}.{lk.to_socket.identifier}"
                        for lk in tree.links) if tree else [],
        "objects": sorted(o.name for o in bpy.data.objects),
        "node_groups": sorted(g.name for g in bpy.data.node_groups),
        "drivers": sorted(f"{d.data_path}[{d.array_index}]" for d in anim.drivers)
        if anim else [],
    }


def _call(bpy, op_id, override, *args, **kw):
    """Run bpy.ops.<op_id> in `override`; returns {'error': text or None, 'returned': what
    bpy.ops returned (None when it raised)}."""
    mod, fn = op_id.split(".")
    op = getattr(getattr(bpy.ops, mod), fn)
    with bpy.context.temp_override(**override):
        try:
            return {"error": None, "returned": sorted(op(*args, **kw))}
        except RuntimeError as ex:
            return {"error": str(ex).strip(), "returned": None}


def _misuse(bpy, results, op_id, override, snapshot_of=MATERIAL, **kw):
    """Call op_id expecting a refusal: its error, what execute returned, and whether anything
    changed."""
    before = _snapshot(bpy, snapshot_of)
    n_results = len(results[op_id])
    out = _call(bpy, op_id, override, **kw)
    out["executed"] = results[op_id][n_results:]
    out["unchanged"] = _snapshot(bpy, snapshot_of) == before
    return out


def _principled_material(bpy, name, obj):
    mat = new_material(name)
    if mat.node_tree is None:                 # before 5.0
        mat.use_nodes = True
    obj.data.materials.append(mat)
    return mat


def _undoable(bpy, op_id, override, **kw):
    """A call of op_id that pushes its own undo step, as the UI makes it."""
    return lambda: _call(bpy, op_id, override, 'EXEC_DEFAULT', True, **kw)


def _undo_twice(bpy, check, first, second):
    """The calls first() and second() (each returns what _call does), then undo, undo, redo,
    redo; `check()` summarises the state after each. Returns the summaries and the calls."""
    states = {"start": check()}
    calls = [first()]
    states["first"] = check()
    calls.append(second())
    states["second"] = check()
    for step, op in (("undo_1", bpy.ops.ed.undo), ("undo_2", bpy.ops.ed.undo),
                     ("redo_1", bpy.ops.ed.redo), ("redo_2", bpy.ops.ed.redo)):
        op()
        states[step] = check()
    return {"states": states, "calls": calls}


def session(work):
    import bpy
    import numpy as np

    import surfgrad_addon
    from surfgrad_addon.addon import operators as O
    from test_extension import _shader_editor

    work = Path(work)
    report = {}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    surfgrad_addon.register()
    classes = (O.SURFGRAD_OT_add_layer_stack, O.SURFGRAD_OT_convert_node,
               O.SURFGRAD_OT_add_decal_projector)
    report["registered"] = {op: op.split(".")[1] in dir(bpy.ops.surfgrad) for op in OPERATORS}
    report["bl_options"] = {cls.bl_idname: sorted(cls.bl_options) for cls in classes}
    results = _wrap_executes(classes)

    bpy.ops.mesh.primitive_uv_sphere_add()
    sphere = bpy.context.active_object
    sphere.name = "SG Sphere"
    win = bpy.context.window_manager.windows[0]
    view3d = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
    view3d_override = dict(window=win, area=view3d,
                           region=next(r for r in view3d.regions if r.type == 'WINDOW'))

    # The sidebar panel -------------------------------------------------------------------
    panel = getattr(bpy.types, "NODE_PT_surfgrad", None)
    report["panel"] = {"registered": panel is not None and panel.is_registered}
    if panel is not None:
        report["panel"].update(space=panel.bl_space_type, region=panel.bl_region_type,
                               category=panel.bl_category, label=panel.bl_label)
        with bpy.context.temp_override(**view3d_override):
            report["panel"]["poll_view3d"] = bool(panel.poll(bpy.context))
    override, space = _shader_editor(bpy, None)
    space.pin = False
    if panel is not None:
        with bpy.context.temp_override(**override):
            report["panel"]["poll_shader_editor_no_tree"] = bool(panel.poll(bpy.context))
        override["area"].ui_type = 'GeometryNodeTree'
        with bpy.context.temp_override(**override):
            report["panel"]["poll_geometry_editor"] = bool(panel.poll(bpy.context))

    # Misuse before there is a material ------------------------------------------------------
    override, space = _shader_editor(bpy, None)
    space.pin = False
    misuse = {}
    misuse["layer_stack_no_material"] = _misuse(bpy, results, "surfgrad.add_layer_stack",
                                                override)
    misuse["decal_no_material"] = _misuse(bpy, results, "surfgrad.add_decal_projector",
                                          override)
    bpy.context.view_layer.objects.active = None
    misuse["layer_stack_no_object"] = _misuse(bpy, results, "surfgrad.add_layer_stack",
                                              override)
    bpy.context.view_layer.objects.active = sphere

    mat = _principled_material(bpy, MATERIAL, sphere)
    override, space = _shader_editor(bpy, mat.node_tree)
    if panel is not None:
        with bpy.context.temp_override(**override):
            report["panel"]["poll_shader_editor"] = bool(panel.poll(bpy.context))
            layout = Layout()
            panel.draw(SimpleNamespace(layout=layout), bpy.context)
            report["panel"]["draws"] = layout.operators
    bpy.ops.ed.undo_push(message="start")

    # 1. Layer stack ----------------------------------------------------------------------------
    def layer_stack_state():
        tree = _tree(bpy)
        bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
        chain, socket = [], bsdf.inputs["Normal"]
        while socket is not None and socket.is_linked:
            node = socket.links[0].from_node
            chain.append(node.node_tree.name if node.bl_idname == "ShaderNodeGroup"
                         else node.bl_idname)
            nxt = {"SG Resolve": "Surface Gradient", "SG Combine": "A"}.get(chain[-1])
            socket = node.inputs[nxt] if nxt else None
        groups = [n.node_tree.name for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"]
        return {"chain": chain, "group_nodes": sorted(groups), "n_nodes": len(tree.nodes),
                "node_groups": sorted(g.name for g in bpy.data.node_groups)}
    n_done = len(results["surfgrad.add_layer_stack"])
    add_layer_stack = _undoable(bpy, "surfgrad.add_layer_stack", override)
    report["layer_stack"] = _undo_twice(bpy, layer_stack_state, add_layer_stack,
                                        add_layer_stack)
    report["layer_stack"]["executed"] = results["surfgrad.add_layer_stack"][n_done:]

    # Misuse: a material whose output has no BSDF with a Normal input.
    emit_mat = new_material("SG Emission")
    if emit_mat.node_tree is None:
        emit_mat.use_nodes = True
    et = emit_mat.node_tree
    et.nodes.clear()
    emit = et.nodes.new("ShaderNodeEmission")
    out = et.nodes.new("ShaderNodeOutputMaterial")
    et.links.new(emit.outputs[0], out.inputs["Surface"])
    sphere = bpy.data.objects["SG Sphere"]
    sphere.data.materials.append(emit_mat)
    sphere.active_material_index = 1
    override, space = _shader_editor(bpy, emit_mat.node_tree)
    misuse["layer_stack_emission"] = _misuse(bpy, results, "surfgrad.add_layer_stack",
                                             override, snapshot_of="SG Emission")
    et.links.clear()
    misuse["layer_stack_unlinked_output"] = _misuse(bpy, results, "surfgrad.add_layer_stack",
                                                    override, snapshot_of="SG Emission")
    sphere.active_material_index = 0

    # 2. Convert: a Normal Map node fed by an image into the BSDF's Normal, and a Bump node.
    tree = _tree(bpy)
    for node in [n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"]:
        tree.nodes.remove(node)               # back to a bare Principled BSDF
    image = bpy.data.images.new("SG Normal Image", 16, 16, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.name = "SG Image"
    tex.image = image
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    nmap.name = "SG Normal Map node"
    nmap.uv_map = "UVMap"
    nmap.inputs["Strength"].default_value = 0.7
    tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    bump = tree.nodes.new("ShaderNodeBump")
    bump.name = "SG Bump node"
    bump.inputs["Distance"].default_value = 0.25
    tree.links.new(tex.outputs["Alpha"], bump.inputs["Height"])
    tree.links.new(bump.outputs["Normal"], bsdf.inputs["Coat Normal"])
    override, space = _shader_editor(bpy, tree)

    # Misuse first: no active node, an active BSDF, an object-space Normal Map, the 3D view.
    tree.nodes.active = None
    for n in tree.nodes:
        n.select = False
    misuse["convert_no_active_node"] = _misuse(bpy, results, "surfgrad.convert_node", override)
    tree.nodes.active = bsdf
    misuse["convert_bsdf"] = _misuse(bpy, results, "surfgrad.convert_node", override)
    obj_nm = tree.nodes.new("ShaderNodeNormalMap")
    obj_nm.name = "SG Object-space Normal Map"
    obj_nm.space = "OBJECT"
    tree.nodes.active = obj_nm
    misuse["convert_object_space"] = _misuse(bpy, results, "surfgrad.convert_node", override)
    tree.nodes.remove(obj_nm)
    tree.nodes.active = tree.nodes["SG Normal Map node"]
    misuse["convert_in_view3d"] = _misuse(bpy, results, "surfgrad.convert_node",
                                          view3d_override)
    bpy.ops.ed.undo_push(message="convert set-up")

    def convert_state():
        tree = _tree(bpy)
        bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")

        def upstream(socket):
            """The group chain feeding socket: [(group, {input: source node or value})]."""
            chain = []
            while socket.is_linked:
                node = socket.links[0].from_node
                if node.bl_idname != "ShaderNodeGroup":
                    chain.append((node.bl_idname, {}))
                    break
                ins = {}
                for s in node.inputs:
                    if s.is_linked:
                        ins[s.name] = s.links[0].from_node.name
                    elif s.name in ("Strength", "Bump Scale"):
                        ins[s.name] = round(s.default_value, 6)
                chain.append((node.node_tree.name, ins))
                nxt = "Surface Gradient" if node.node_tree.name == "SG Resolve" else None
                if nxt is None:
                    break
                socket = node.inputs[nxt]
            return chain
        return {"normal": upstream(bsdf.inputs["Normal"]),
                "coat_normal": upstream(bsdf.inputs["Coat Normal"]),
                "node_names": sorted(n.name for n in tree.nodes)}

    def convert(name):
        """Convert the node `name`, made active, in a Shader Editor showing the tree as it is
        now (the first call's undo step reloads it)."""
        def call():
            tree = _tree(bpy)
            for n in tree.nodes:
                n.select = n.name == name
            tree.nodes.active = tree.nodes[name]
            override = _shader_editor(bpy, tree)[0]
            return _call(bpy, "surfgrad.convert_node", override, 'EXEC_DEFAULT', True)
        return call

    n_done = len(results["surfgrad.convert_node"])
    report["convert"] = _undo_twice(bpy, convert_state, convert("SG Normal Map node"),
                                    convert("SG Bump node"))
    report["convert"]["executed"] = results["surfgrad.convert_node"][n_done:]

    # 3. Decal projector --------------------------------------------------------------------
    override, space = _shader_editor(bpy, _tree(bpy))
    misuse["decal_unknown_image"] = _misuse(bpy, results, "surfgrad.add_decal_projector",
                                            override, image="No Such Image")
    bpy.ops.ed.undo_push(message="decal set-up")

    def decal_state():
        tree = _tree(bpy)
        empties = sorted(o.name for o in bpy.data.objects if o.type == 'EMPTY')
        decals = [n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"
                  and n.node_tree.name == "SG Decal"]
        state = {"empties": empties, "n_decals": len(decals), "decals": []}
        anim = tree.animation_data
        drivers = list(anim.drivers) if anim else []
        for node in decals:
            entry = {"name": node.name}
            cd = node.inputs["Decal Coordinates"]
            # Through SG Projector Coordinates (precise far away) to its Texture Coordinate.
            pc = cd.links[0].from_node if cd.is_linked else None
            entry["projector_group"] = pc.node_tree.name if pc is not None and getattr(
                pc, "node_tree", None) else None
            tcin = pc.inputs["Decal Coordinates"] if entry["projector_group"] else None
            tc = tcin.links[0].from_node if tcin is not None and tcin.is_linked else None
            entry["coords_from"] = [tc.bl_idname, tcin.links[0].from_socket.name,
                                    tc.object.name if tc.object else None] if tc else None
            col = node.inputs["Color"]
            texn = col.links[0].from_node if col.is_linked else None
            entry["color_from"] = [texn.bl_idname, texn.image.name if texn.image else None,
                                   texn.extension] if texn else None
            vec = texn.inputs["Vector"] if texn else None
            grp = vec.links[0].from_node if vec is not None and vec.is_linked else None
            entry["vector_from"] = grp.node_tree.name if grp is not None else None
            g_in = grp.inputs[0] if grp is not None else None
            entry["coords_group_input_from"] = (g_in.links[0].from_node.name
                                                if g_in is not None and g_in.is_linked else None)
            entry["coords_node"] = pc.name if pc else None
            entry["drivers"] = {}
            for axis in ("Axis X", "Axis Y"):
                path = node.inputs[axis].path_from_id("default_value")
                fcs = sorted((d for d in drivers if d.data_path == path),
                             key=lambda d: d.array_index)
                entry["drivers"][axis] = [{
                    "index": d.array_index, "type": d.driver.type,
                    "expression": d.driver.expression,
                    "simple": d.driver.is_simple_expression,
                    "valid": d.driver.is_valid,
                    "targets": sorted({v.targets[0].id.name for v in d.driver.variables
                                       if v.targets[0].id is not None})} for d in fcs]
            entry["projector_drivers"] = []
            if entry["projector_group"]:
                paths = {pc.inputs[k].path_from_id("default_value") for k in (
                    "Projector Location", "To Projector X", "To Projector Y", "To Projector Z")}
                entry["projector_drivers"] = [{
                    "simple": d.driver.is_simple_expression, "valid": d.driver.is_valid,
                    "targets": sorted({v.targets[0].id.name for v in d.driver.variables
                                       if v.targets[0].id is not None})}
                    for d in drivers if d.data_path in paths]
            state["decals"].append(entry)
        for name in empties:
            o = bpy.data.objects[name]
            state.setdefault("empty_info", {})[name] = {
                "display": o.empty_display_type, "location": list(o.location),
                "in_scene": o.name in bpy.context.scene.collection.objects}
        return state

    bpy.context.scene.cursor.location = (0.5, -0.25, 1.5)
    n_done = len(results["surfgrad.add_decal_projector"])
    image_name = "SG Normal Image"
    add_decal = _undoable(bpy, "surfgrad.add_decal_projector", override, image=image_name)
    report["decal"] = _undo_twice(bpy, decal_state, add_decal, add_decal)
    report["decal"]["executed"] = results["surfgrad.add_decal_projector"][n_done:]
    scene = bpy.context.scene                 # fetched again: undo reloads IDs
    report["decal"]["cursor"] = list(scene.cursor.location)

    # The drivers follow the empty (after redo: the restored empty drives the restored nodes).
    tree = _tree(bpy)
    followed = {}
    for node in [n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"
                 and n.node_tree.name == "SG Decal"]:
        pc = node.inputs["Decal Coordinates"].links[0].from_node
        empty = pc.inputs["Decal Coordinates"].links[0].from_node.object
        empty.rotation_euler = (0.3, -0.5, 1.2)
        empty.scale = (2.0, 0.5, 1.0)
        bpy.context.view_layer.update()
        scene.frame_set(scene.frame_current)
        m = np.array(empty.matrix_world)[:3, :3]
        err = 0.0
        for axis, column in (("Axis X", 0), ("Axis Y", 1)):
            got = np.array(node.inputs[axis].default_value)
            err = max(err, float(np.abs(got - m[:, column] / np.linalg.norm(m[:, column]))
                                 .max()))
        followed[node.name] = err
    report["decal"]["driver_error"] = followed

    report["misuse"] = misuse
    surfgrad_addon.unregister()
    report["unregistered"] = {op: op.split(".")[1] in dir(bpy.ops.surfgrad) for op in OPERATORS}
    report["unregistered"]["panel"] = hasattr(bpy.types, "NODE_PT_surfgrad")
    write_report(work, report, "SG_OPERATORS_DONE")


# ---------------------------------------------------------------------------------------------
# pytest side
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def session_report(tmp_path_factory):
    return run_session(__file__, tmp_path_factory, "operators", "SG_OPERATORS_DONE")


def test_operators_are_registered_with_undo(session_report):
    r = session_report
    assert r["registered"] == {op: True for op in OPERATORS}
    for op in OPERATORS:
        assert r["bl_options"][op] == ["REGISTER", "UNDO"], (op, r["bl_options"][op])
    assert r["unregistered"] == {**{op: False for op in OPERATORS}, "panel": False}


def test_sidebar_panel_polls_only_in_a_shader_editor(session_report):
    p = session_report["panel"]
    assert p["registered"]
    assert (p["space"], p["region"], p["category"]) == ("NODE_EDITOR", "UI", "Surface Gradient")
    assert p["poll_shader_editor"] is True
    assert p["poll_shader_editor_no_tree"] is True      # a Shader Editor, even without a tree
    assert p["poll_view3d"] is False and p["poll_geometry_editor"] is False
    assert p["draws"] == [*OPERATORS, "surfgrad.freeze_stack", "surfgrad.thaw_stack",
                          "surfgrad.update_groups"]


def _finished_twice(r):
    """Both calls finished, as bpy.ops returned and as execute returned; their states."""
    assert [c["returned"] for c in r["calls"]] == [["FINISHED"], ["FINISHED"]], r["calls"]
    assert r["executed"] == [["FINISHED"], ["FINISHED"]]
    return r["states"]


def _check_undo(states, equal=lambda a, b: a == b):
    s = states
    assert not equal(s["start"], s["first"]) and not equal(s["first"], s["second"])
    assert equal(s["undo_1"], s["first"]), "undo did not remove only the second call's work"
    assert equal(s["undo_2"], s["start"]), "undo did not remove the first call's work"
    assert equal(s["redo_1"], s["first"]) and equal(s["redo_2"], s["second"]), "redo"


def test_layer_stack_wires_the_bsdf_normal_and_undoes(session_report):
    r = session_report["layer_stack"]
    s = _finished_twice(r)
    assert s["start"]["chain"] == [] and s["start"]["n_nodes"] == 2
    # SG Normal Map -> SG Combine (A) -> SG Resolve -> the BSDF's Normal.
    for key in ("first", "second"):
        assert s[key]["chain"] == ["SG Resolve", "SG Combine", "SG Normal Map"], s[key]
    assert s["first"]["n_nodes"] == 5 and s["second"]["n_nodes"] == 8
    assert s["second"]["group_nodes"] == sorted(["SG Resolve", "SG Combine",
                                                 "SG Normal Map"] * 2)
    # The groups the first call built are gone with its undo, and back with redo.
    assert {"SG Resolve", "SG Combine", "SG Normal Map"} <= set(s["first"]["node_groups"])
    assert not {"SG Resolve", "SG Combine", "SG Normal Map"} & set(s["start"]["node_groups"])
    _check_undo(s)
    # The INFO report tells the artist what was added and that the link was replaced.
    out = session_report["stdout"]
    assert "Added SG Normal Map, SG Combine and SG Resolve; link your normal map image" in out
    assert "(replaced the previous link into Normal)" in out


def test_convert_replaces_normal_map_and_bump_and_undoes(session_report):
    r = session_report["convert"]
    s = _finished_twice(r)
    assert s["start"]["normal"] == [["ShaderNodeNormalMap", {}]]
    assert s["start"]["coat_normal"] == [["ShaderNodeBump", {}]]
    # The Normal Map node becomes SG Normal Map -> SG Resolve, its image and Strength kept.
    (resolve, r_in), (sg_nm, nm_in) = s["first"]["normal"]
    assert resolve == "SG Resolve" and sg_nm.startswith("SG Normal Map")
    assert nm_in == {"Color": "SG Image", "Strength": 0.7}, nm_in
    assert "SG Normal Map node" not in s["first"]["node_names"]
    assert s["first"]["coat_normal"] == s["start"]["coat_normal"]
    # The Bump node becomes SG Height Map Forward -> SG Resolve, Distance as the bump scale.
    (resolve, _), (sg_h, h_in) = s["second"]["coat_normal"]
    assert resolve == "SG Resolve" and sg_h.startswith("SG Height Map Forward"), sg_h
    assert h_in == {"Height": "SG Image", "Bump Scale": 0.25}, h_in
    assert "SG Bump node" not in s["second"]["node_names"]
    _check_undo(s)
    assert "Converted the Normal Map node to surface gradients" in session_report["stdout"]
    assert "Converted the Bump node to surface gradients" in session_report["stdout"]


def test_decal_projector_adds_a_driven_chain_and_undoes(session_report):
    r = session_report["decal"]
    s = _finished_twice(r)
    assert s["start"]["empties"] == [] and s["start"]["n_decals"] == 0
    assert len(s["first"]["empties"]) == 1 and s["first"]["n_decals"] == 1
    assert len(s["second"]["empties"]) == 2 and s["second"]["n_decals"] == 2
    for name, info in s["second"]["empty_info"].items():
        assert info["display"] == "CUBE" and info["in_scene"], (name, info)
        assert info["location"] == pytest.approx(r["cursor"]), (name, info)   # the 3D cursor
    for entry in s["second"]["decals"]:
        # Texture Coordinate (Object of the empty) -> SG Decal Coordinates -> Image Texture
        # (the image, CLIP) -> SG Decal; the Object coordinates also into SG Decal.
        coords_from = entry["coords_from"]
        assert entry["projector_group"] == "SG Projector Coordinates"
        assert coords_from[:2] == ["ShaderNodeTexCoord", "Object"]
        assert coords_from[2] in s["second"]["empties"]
        assert entry["color_from"] == ["ShaderNodeTexImage", "SG Normal Image", "CLIP"]
        assert entry["vector_from"] == "SG Decal Coordinates"
        assert entry["coords_group_input_from"] == entry["coords_node"]
        # Axis X and Y: three drivers each, simple expressions on that empty, valid.
        for axis in ("Axis X", "Axis Y"):
            drivers = entry["drivers"][axis]
            assert [d["index"] for d in drivers] == [0, 1, 2], (axis, drivers)
            for d in drivers:
                assert d["type"] == "SCRIPTED" and d["simple"] and d["valid"], d
                assert d["targets"] == [coords_from[2]], d
        # SG Projector Coordinates: location and three inverse rows, 12 simple valid drivers.
        assert len(entry["projector_drivers"]) == 12, entry["projector_drivers"]
        for d in entry["projector_drivers"]:
            assert d["simple"] and d["valid"] and d["targets"] == [coords_from[2]], d
    # Each decal is driven by its own empty.
    assert len({e["coords_from"][2] for e in s["second"]["decals"]}) == 2
    _check_undo(s)
    # After redo the restored drivers still follow the restored empties.
    assert len(r["driver_error"]) == 2
    assert max(r["driver_error"].values()) < 1e-5, r["driver_error"]
    assert "scale it to size the decal" in session_report["stdout"]


MISUSE = {
    # case: (words the error must contain)
    "layer_stack_no_material": ("has no material", "Material Properties"),
    "layer_stack_no_object": ("No active object",),
    "layer_stack_emission": ("has no Normal input", "Principled BSDF"),
    "layer_stack_unlinked_output": ("no shader linked", "link a BSDF first"),
    "decal_no_material": ("has no material",),
    "decal_unknown_image": ("No image named 'No Such Image'", "Image > Open"),
    "convert_no_active_node": ("No active node", "Normal Map or Bump node"),
    "convert_bsdf": ("is a ShaderNodeBsdfPrincipled", "select a Normal Map or a Bump node"),
    "convert_object_space": ("object-space Normal Map", "SG Object Normal"),
}


@pytest.mark.parametrize("case", sorted(MISUSE))
def test_misuse_is_reported_and_cancelled(session_report, case):
    m = session_report["misuse"][case]
    assert m["error"] is not None and m["returned"] is None, m   # bpy.ops raised the report
    assert m["error"].startswith("Error:"), m["error"]
    for words in MISUSE[case]:
        assert words in m["error"], (case, m["error"])
    assert m["executed"] == [["CANCELLED"]], m                   # what execute returned
    assert m["unchanged"], f"{case} changed the file"


def test_convert_polls_false_outside_a_shader_editor(session_report):
    m = session_report["misuse"]["convert_in_view3d"]
    assert m["executed"] == [] and m["unchanged"], m          # execute never ran
    assert "poll()" in m["error"] and "Works in a Shader Editor with a node tree" in \
        m["error"], m["error"]


if __name__ == "__main__":
    session(sys.argv[1])
