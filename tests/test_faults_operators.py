"""Fault injection for the artist operators (issue 20, item 5): all-or-nothing, on the tree the
Shader Editor shows, and a Sampler group that keeps the texture's other uses.

- A user's own (non-surfgrad) node group under one of our names: Add Layer Stack, Add Decal
  Projector, Convert and the Add menu report it cleanly (ERROR, CANCELLED) and leave the file as
  it was: nodes, links, objects, node groups and drivers counted before and after. A foreign
  hidden helper (".SG Safe Normal") fails a group half-way through its build: the half-built
  group is taken away again.
- A Sampler group added around an Image Texture that also feeds Base Color and Roughness keeps
  those links (before 5.0, where the Sampler groups do not exist, the refusal names 5.0 and the
  links are kept too).
- A Shader Editor pinned to another material: the layer stack and the decal go into the shown
  material, the object's own material is untouched. Showing the World: refused, nothing changed.

The session runs the registered extension in a subprocess (this file run as a script), driving
the operators through bpy.ops in a Shader Editor override, as tests/test_operators_ui.py does.
"""

import sys
from pathlib import Path

import pytest

from support.operator_session import run_session, write_report  # noqa: E402

pytestmark = pytest.mark.tier("child")


MATERIAL = "SG Faults"
OTHER = "SG Pinned"


# ---------------------------------------------------------------------------------------------
# Blender-side code (runs in the subprocess)
# ---------------------------------------------------------------------------------------------

def _foreign_group(bpy, name):
    """A user's own shader group under `name`: one node in it, no surfgrad stamp."""
    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    tree.nodes.new("ShaderNodeMath")
    return tree


def _counts(bpy, *materials):
    """What an operator may add or remove, counted and listed: nodes and links of each named
    material, objects, node groups (and each group's node count), drivers."""
    out = {"objects": sorted(o.name for o in bpy.data.objects),
           "node_groups": sorted(f"{g.name}:{len(g.nodes)}" for g in bpy.data.node_groups)}
    for name in materials:
        tree = bpy.data.materials[name].node_tree
        anim = tree.animation_data
        out[name] = {
            "nodes": sorted(f"{n.name}:{n.bl_idname}" for n in tree.nodes),
            "links": sorted(f"{lk.from_node.name}.{lk.from_socket.identifier}->"
                            f"{lk.to_node.name}.{lk.to_socket.identifier}" for lk in tree.links),
            "drivers": len(anim.drivers) if anim else 0}
    return out


def _case(bpy, results, op_id, override, materials=(MATERIAL,), **kw):
    from test_operators_ui import _call
    before = _counts(bpy, *materials)
    n = len(results[op_id])
    out = _call(bpy, op_id, override, **kw)
    out["executed"] = results[op_id][n:]
    after = _counts(bpy, *materials)
    out["unchanged"] = after == before
    out["before"], out["after"] = before, after
    return out


def session(work):
    import bpy

    import surfgrad_addon
    from surfgrad_addon.addon import operators as O, ui
    from surfgrad_addon.addon.sampler_zone import has_closures
    from test_extension import _shader_editor
    from test_operators_ui import _principled_material, _wrap_executes

    work = Path(work)
    report = {"line": bpy.app.version_string, "closures": has_closures()}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    surfgrad_addon.register()
    results = _wrap_executes((O.SURFGRAD_OT_add_layer_stack, O.SURFGRAD_OT_convert_node,
                              O.SURFGRAD_OT_add_decal_projector, ui.SURFGRAD_OT_add_group))
    bpy.ops.mesh.primitive_uv_sphere_add()
    sphere = bpy.context.active_object
    sphere.name = "SG Sphere"
    mat = _principled_material(bpy, MATERIAL, sphere)
    override, space = _shader_editor(bpy, mat.node_tree)
    cases = {}

    # 1. A foreign hidden helper: the first group that needs it fails half-way (no group of
    # ours exists yet), and the half-built group is removed again.
    helper = _foreign_group(bpy, ".SG Safe Normal")
    cases["helper_layer_stack"] = _case(bpy, results, "surfgrad.add_layer_stack", override)
    cases["helper_add_menu"] = _case(bpy, results, "surfgrad.add_group", override,
                                     group="SG Resolve")
    bpy.data.node_groups.remove(helper)

    # 2. A foreign group under a top-level name of ours.
    tree = mat.node_tree
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    nmap.name = "User Normal Map"
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    tree.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    for name, op_id, kw in (("SG Resolve", "surfgrad.add_layer_stack", {}),
                            ("SG Combine", "surfgrad.add_layer_stack", {}),
                            ("SG Decal", "surfgrad.add_decal_projector", {}),
                            ("SG Projector Coordinates", "surfgrad.add_decal_projector", {}),
                            ("SG Resolve", "surfgrad.convert_node", {}),
                            ("SG Normal Map", "surfgrad.convert_node", {}),
                            ("SG Resolve", "surfgrad.add_group", {"group": "SG Resolve"})):
        tree.nodes.active = nmap
        foreign = _foreign_group(bpy, name)
        cases[f"foreign {name} {op_id}"] = _case(bpy, results, op_id, override, **kw)
        bpy.data.node_groups.remove(foreign)
    tree.nodes.remove(nmap)

    # 3. The Sampler group around a texture that also feeds Base Color and Roughness.
    img = bpy.data.images.new("SG Height", 32, 16, float_buffer=True)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.name = "User Texture"
    tex.image = img
    uvn = tree.nodes.new("ShaderNodeUVMap")
    uvn.name = "User UV"
    tree.links.new(uvn.outputs[0], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(tex.outputs["Alpha"], bsdf.inputs["Roughness"])
    tree.nodes.active = tex
    before = _counts(bpy, MATERIAL)
    sampler = {"call": _case(bpy, results, "surfgrad.add_group", override,
                             group="SG Height Map HQ (Sampler)")}
    base, rough = bsdf.inputs["Base Color"], bsdf.inputs["Roughness"]
    sampler["base_color_from"] = [f"{lk.from_node.name}.{lk.from_socket.name}"
                                  for lk in base.links]
    sampler["roughness_from"] = [f"{lk.from_node.name}.{lk.from_socket.name}"
                                 for lk in rough.links]
    sampler["texture_vector_from"] = [lk.from_node.name for lk in tex.inputs["Vector"].links]
    group = tree.nodes.active
    if has_closures():
        zout = group.inputs["Sampler"].links[0].from_node
        inside = zout.inputs["Color"].links[0].from_node
        sampler["zone_texture"] = {"is_user_texture": inside == tex,
                                   "image": inside.image.name if inside.image else None,
                                   "vector_from": inside.inputs["Vector"].links[0]
                                   .from_node.bl_idname}
        sampler["group_uv_from"] = [lk.from_node.name for lk in group.inputs["UV"].links]
    sampler["links_kept"] = set(before[MATERIAL]["links"]) <= set(
        _counts(bpy, MATERIAL)[MATERIAL]["links"])
    cases["sampler"] = sampler
    bpy.ops.ed.undo_push(message="sampler")

    # 4. Pinned to another material: the shown tree is edited, the object's material is not.
    other = bpy.data.materials.new(OTHER)
    if other.node_tree is None:
        other.use_nodes = True
    other.use_fake_user = True
    pinned, pspace = _shader_editor(bpy, other.node_tree)
    for op_id in ("surfgrad.add_layer_stack", "surfgrad.add_decal_projector"):
        out = _case(bpy, results, op_id, pinned, materials=(MATERIAL, OTHER))
        out["object_material_unchanged"] = out["after"][MATERIAL] == out["before"][MATERIAL]
        out["shown_groups"] = sorted(n.node_tree.name for n in other.node_tree.nodes
                                     if n.bl_idname == "ShaderNodeGroup")
        cases[f"pinned {op_id}"] = out
    shown = other.node_tree
    bsdf2 = next(n for n in shown.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    into = bsdf2.inputs["Normal"].links
    cases["pinned_normal_chain"] = into[0].from_node.node_tree.name if into else None

    # 5. The World shown: refused, nothing changed (the world's tree counted too).
    world = bpy.data.worlds.new("SG World")
    if world.node_tree is None:
        world.use_nodes = True
    bpy.context.scene.world = world
    wover, wspace = _shader_editor(bpy, world.node_tree)
    wspace.shader_type = 'WORLD'
    for op_id in ("surfgrad.add_layer_stack", "surfgrad.add_decal_projector"):
        n_world = (len(world.node_tree.nodes), len(world.node_tree.links))
        out = _case(bpy, results, op_id, wover, materials=(MATERIAL, OTHER))
        out["world_unchanged"] = n_world == (len(world.node_tree.nodes),
                                             len(world.node_tree.links))
        cases[f"world {op_id}"] = out
    # Pinned to the World's tree with the editor left on Object: refused the same way.
    wspace.shader_type = 'OBJECT'
    wspace.node_tree = world.node_tree
    cases["world pinned as object"] = _case(bpy, results, "surfgrad.add_layer_stack", wover,
                                            materials=(MATERIAL, OTHER))

    report["cases"] = cases
    surfgrad_addon.unregister()
    write_report(work, report, "SG_FAULTS_OPERATORS_DONE")


# ---------------------------------------------------------------------------------------------
# pytest side
# ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def report(tmp_path_factory):
    return run_session(__file__, tmp_path_factory, "faults_operators",
                       "SG_FAULTS_OPERATORS_DONE")


def _refused(case, *words):
    assert case["error"] is not None and case["returned"] is None, case
    assert case["error"].startswith("Error:"), case["error"]
    assert "Traceback" not in case["error"], case["error"]
    for w in words:
        assert w in case["error"], (w, case["error"])
    assert case["executed"] == [["CANCELLED"]], case
    assert case["unchanged"], (case["before"], case["after"])


def test_no_traceback_reaches_the_user(report):
    assert "Traceback" not in report["stderr"], report["stderr"][-3000:]


@pytest.mark.parametrize("case", ["helper_layer_stack", "helper_add_menu"])
def test_a_foreign_helper_group_leaves_no_half_built_group(report, case):
    c = report["cases"][case]
    _refused(c, "'.SG Safe Normal' already exists and is not a surface-gradient group",
             "rename it")
    # Nothing of ours was left: not the half-built SG Resolve, nor anything else.
    assert c["after"]["node_groups"] == [".SG Safe Normal:1"], c["after"]["node_groups"]


FOREIGN = [("SG Resolve", "surfgrad.add_layer_stack"), ("SG Combine", "surfgrad.add_layer_stack"),
           ("SG Decal", "surfgrad.add_decal_projector"),
           ("SG Projector Coordinates", "surfgrad.add_decal_projector"),
           ("SG Resolve", "surfgrad.convert_node"), ("SG Normal Map", "surfgrad.convert_node"),
           ("SG Resolve", "surfgrad.add_group")]


@pytest.mark.parametrize("name,op_id", FOREIGN)
def test_a_foreign_group_under_our_name_is_reported_and_nothing_changes(report, name, op_id):
    c = report["cases"][f"foreign {name} {op_id}"]
    _refused(c, f"a node group named {name!r} already exists and is not a surface-gradient "
                f"group", "rename it")
    # The user's group is still theirs (one node), and no empty object was left.
    assert f"{name}:1" in c["after"]["node_groups"]
    assert c["after"]["objects"] == ["SG Sphere"]


def test_the_sampler_group_keeps_the_textures_other_uses(report):
    s = report["cases"]["sampler"]
    assert s["base_color_from"] == ["User Texture.Color"]
    assert s["roughness_from"] == ["User Texture.Alpha"]
    assert s["texture_vector_from"] == ["User UV"]
    assert s["links_kept"]
    if report["closures"]:
        assert s["call"]["executed"] == [["FINISHED"]], s["call"]
        # A copy of the texture samples the same image inside the zone; the group's UV is
        # what fed the texture.
        assert s["zone_texture"] == {"is_user_texture": False, "image": "SG Height",
                                     "vector_from": "NodeClosureInput"}
        assert s["group_uv_from"] == ["User UV"]
    else:
        _refused(s["call"], "needs Blender 5.0 or newer")


@pytest.mark.parametrize("op_id", ["surfgrad.add_layer_stack", "surfgrad.add_decal_projector"])
def test_a_pinned_editor_edits_the_shown_material(report, op_id):
    c = report["cases"][f"pinned {op_id}"]
    assert c["error"] is None and c["executed"] == [["FINISHED"]], c
    assert c["object_material_unchanged"], (c["before"][MATERIAL], c["after"][MATERIAL])
    added = set(c["after"][OTHER]["nodes"]) - set(c["before"][OTHER]["nodes"])
    want = {"surfgrad.add_layer_stack": 3, "surfgrad.add_decal_projector": 5}[op_id]
    assert len(added) == want, added
    groups = {"surfgrad.add_layer_stack": {"SG Normal Map", "SG Combine", "SG Resolve"},
              "surfgrad.add_decal_projector": {"SG Projector Coordinates",
                                               "SG Decal Coordinates", "SG Decal"}}[op_id]
    assert groups <= set(c["shown_groups"]), c["shown_groups"]


def test_the_pinned_layer_stack_is_wired_into_the_shown_bsdf(report):
    assert report["cases"]["pinned_normal_chain"] == "SG Resolve"


@pytest.mark.parametrize("case", ["world surfgrad.add_layer_stack",
                                  "world surfgrad.add_decal_projector", "world pinned as object"])
def test_the_world_shown_is_refused(report, case):
    c = report["cases"][case]
    if case.startswith("world surfgrad."):
        # The editor on World: refused by the operator's poll since round 54 (greyed out in
        # the menu, the reason in its tooltip; nothing runs).
        assert c["returned"] is None and c["executed"] == [], c
        assert "poll()" in c["error"] and "Traceback" not in c["error"], c["error"]
        for w in ("Shader Editor shows the World", "switch the editor to Object"):
            assert w in c["error"], (w, c["error"])
    else:
        _refused(c, "Shader Editor shows the World", "switch the editor to Object")
    assert c.get("world_unchanged", True)


if __name__ == "__main__":
    session(sys.argv[1])
