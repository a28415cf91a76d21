"""Red team 53d: the artist's operators with the Shader Editor (or a Geometry Nodes editor)
showing the inside of one of surfgrad's own groups (Tab), where that group is an older
surfgrad's (a file from a previous version, not yet updated) or is the group being added; and
an older group that is a library override.

Measured on 5.2 and 4.2 before the fix (main at b91a8c8):

1. Convert to Surface Gradient on the Normal Map node inside an older "SG Normal Map [UVMap]"
   (the artist Tabs into the group and clicks its Normal Map node): the check pass let the
   request through, the real pass rebuilt the group in place (its nodes freed, the clicked
   node too), and the next build read the freed node's UV map: Blender crashed (SIGSEGV, exit
   -11; 5.2), the artist's unsaved work lost; on 4.2 it was refused after the rebuild (stamp
   23 -> 24). Inside a stale ".001" copy of it (an append), which the real pass also rebuilds,
   it crashed on 5.2 and 4.2. Now refused in the check pass, naming the group and the fix,
   nothing changed; the UV map is read once, before any build.
2. The Add menu's "SG Decal" inside an older SG Decal, and Add Decal Projector there, were
   refused ("cannot be added inside itself") only after that group had been rebuilt in place
   (its stamp 23 -> 24, its interior replaced): a refusal that changed the file. Now the
   containment is checked on the check pass's scratch groups: stamp 23 kept, the file as it
   was.
3. A Sampler group added inside itself (5.0+: "SG Height Map HQ (Sampler)", current or older)
   reported Blender's raw 'bpy_prop_collection[key]: key "Sampler" not found' (Blender leaves
   a group node holding its own tree empty); an older one was rebuilt first too. Now the
   refusal names the group and says to leave it (Tab).
4. SG Displace added inside SG Displace from the Geometry Nodes Add menu (4.5+): FINISHED
   with an empty group node added in the group (63 -> 64 nodes; Blender refuses the tree
   silently), its inside changed. Now refused, 63 nodes.

5. A library override of an older surfgrad's group (a linked "SG Resolve", stamp 23, made an
   override): the Add menu's SG Resolve rebuilt the override in place (stamp 24 in the
   session, FINISHED) and gave the new node that override; saved and reopened, the override
   was the library's stamp-23 group again (Blender saves an override's changed values, not a
   rebuilt inside), and the sidebar said nothing of it (only linked groups were named). Now
   the request is refused naming the library and the fix, the override as it was; a stale
   ".001" override is no longer rebuilt as a copy; the sidebar names it with the linked ones.

6. SG Displace from the Geometry Nodes Add menu into a library override's Geometry Nodes
   tree (a linked asset's, made an override; Blender calls it editable): FINISHED, 1 node in
   it; saved and reopened, 0 nodes, with no word (the shader side refused overrides already,
   material_inputs.edits_lost; the Geometry Nodes side checked is_editable alone). Now refused
   as linked or override data. The operator's poll in a Geometry Nodes editor gave the
   Shader Editor's reason ("not a Shader Editor"); now the Geometry Nodes editor's.

Adding a different group inside an older one (SG Normal Map inside an older SG Resolve) is
still added there: the artist asked for it.
"""

import textwrap

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import groups as G  # noqa: E402
from surfgrad_addon.addon import operators as O  # noqa: E402
from surfgrad_addon.addon import ui  # noqa: E402
from surfgrad_addon.addon.group_names import VERSION_KEY  # noqa: E402
from support.child import run_python  # noqa: E402
from test_extension import _shader_editor  # noqa: E402

pytestmark = pytest.mark.tier("blender")

OLDER = G.VERSION - 1


def _groups():
    """Every node group: its stamp, nodes and links (what a rebuild changes)."""
    return {g.name: (g.get(VERSION_KEY), sorted(f"{n.name}:{n.bl_idname}" for n in g.nodes),
                     len(g.links)) for g in bpy.data.node_groups}


@pytest.fixture
def registered():
    classes = (*O.CLASSES, ui.SURFGRAD_OT_add_group)
    for cls in classes:
        bpy.utils.register_class(cls)
    yield
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)


def _older(tree):
    tree[VERSION_KEY] = OLDER
    return tree


def _refused(override, op_id, **props):
    with bpy.context.temp_override(**override):
        with pytest.raises(RuntimeError) as said:
            getattr(bpy.ops.surfgrad, op_id)('EXEC_DEFAULT', True, **props)
    return str(said.value)


# The Convert crash runs in a child: before the fix it ended the process (SIGSEGV).
CONVERT = textwrap.dedent('''
    import bpy
    from surfgrad_addon.addon import groups as G, operators as O
    from surfgrad_addon.addon.group_names import VERSION_KEY
    from test_extension import _shader_editor
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for cls in O.CLASSES:
        bpy.utils.register_class(cls)
    tree = G.normal_map_group("UVMap")
    if COPY:                       # an append's stale copy beside a current original
        tree.name = "SG Normal Map [UVMap].001"
        G.normal_map_group("UVMap")
    tree[VERSION_KEY] = G.VERSION - 1
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeNormalMap")
    tree.nodes.active = node
    names = sorted(n.name for n in tree.nodes)
    override, _ = _shader_editor(bpy, tree)
    with bpy.context.temp_override(**override):
        try:
            print("RESULT", bpy.ops.surfgrad.convert_node('EXEC_DEFAULT', True))
        except RuntimeError as err:
            print("REFUSED", str(err).splitlines()[0])
    print("STAMP", tree[VERSION_KEY], "SAME", sorted(n.name for n in tree.nodes) == names)
    for cls in O.CLASSES:          # (4.2's bpy module crashes at exit with them registered)
        bpy.utils.unregister_class(cls)
''')


@pytest.mark.tier("child")
@pytest.mark.parametrize("copy", [False, True], ids=["group", "stale_copy"])
def test_convert_inside_an_older_normal_map_group_is_refused_not_a_crash(copy):
    out = run_python(["-c", f"COPY = {copy}\n" + CONVERT], timeout=120)
    assert out.returncode == 0, f"exit {out.returncode}\n{out.stdout[-2000:]}\n{out.stderr[-3000:]}"
    name = "SG Normal Map [UVMap]" + (".001" if copy else "")
    assert f"REFUSED Error: The editor shows the inside of node group {name!r}" in out.stdout, \
        out.stdout
    assert "leave the group (Tab)" in out.stdout
    assert f"STAMP {OLDER} SAME True" in out.stdout, out.stdout


@pytest.mark.parametrize("op_id, props", [("add_group", {"group": "SG Decal"}),
                                          ("add_decal_projector", {})],
                         ids=["add_menu", "decal_projector"])
def test_adding_an_older_group_inside_itself_leaves_it_as_it_was(fresh, registered, op_id,
                                                                    props):
    tree = _older(G.decal_group())
    before = (_groups(), sorted(o.name for o in bpy.data.objects))
    override, _ = _shader_editor(bpy, tree)
    said = _refused(override, op_id, **props)
    assert "The editor shows the inside of node group 'SG Decal', and this edit adds " \
           "'SG Decal' nodes" in said, said
    assert bpy.data.node_groups["SG Decal"][VERSION_KEY] == OLDER      # was rebuilt: 24
    assert (_groups(), sorted(o.name for o in bpy.data.objects)) == before


def test_another_group_inside_an_older_one_is_still_added(fresh, registered):
    tree = _older(G.resolve_group())
    override, _ = _shader_editor(bpy, tree)
    count = len(tree.nodes)
    with bpy.context.temp_override(**override):
        assert bpy.ops.surfgrad.add_group(group="SG Normal Map") == {'FINISHED'}
    assert len(tree.nodes) == count + 1
    assert tree.nodes.active.node_tree.name == "SG Normal Map"


@pytest.mark.parametrize("older", [False, True], ids=["current", "older"])
def test_a_sampler_group_inside_itself_is_refused_by_name(fresh, registered, older):
    name = "SG Height Map HQ (Sampler)"
    if G.unavailable_reason(name):
        pytest.skip(G.unavailable_reason(name))
    tree = G.height_map_sampler_group()
    if older:
        _older(tree)
    before = _groups()
    override, _ = _shader_editor(bpy, tree)
    said = _refused(override, "add_group", group=name)
    assert "not found" not in said, said                     # Blender's raw KeyError text
    assert f"node group {name!r}, and this edit adds {name!r} nodes" in said, said
    assert _groups() == before


def test_sg_displace_inside_itself_is_refused(fresh, registered):
    if G.unavailable_reason("SG Displace"):
        pytest.skip(G.unavailable_reason("SG Displace"))
    tree = G.displace_group()
    host = bpy.data.node_groups.new("Host", "GeometryNodeTree")
    host.nodes.new("GeometryNodeGroup").node_tree = tree
    override, space = _shader_editor(bpy, host)
    override["area"].ui_type = 'GeometryNodeTree'
    space = override["area"].spaces.active
    space.pin = True
    space.node_tree = tree
    count = len(tree.nodes)
    said = _refused(override, "add_group", group="SG Displace")
    assert "node group 'SG Displace', and this edit adds 'SG Displace' nodes" in said, said
    assert len(tree.nodes) == count                     # was count + 1: an empty group node


def test_an_older_group_overridden_from_a_library_is_refused_not_rebuilt(fresh, registered,
                                                                         tmp_path):
    lib = tmp_path / "library.blend"
    bpy.data.libraries.write(str(lib), {_older(G.resolve_group())}, fake_user=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with bpy.data.libraries.load(str(lib), link=True) as (_, linked):
        linked.node_groups = ["SG Resolve"]
    override = bpy.data.node_groups["SG Resolve"].override_create(remap_local_usages=True)
    assert override.library is None and override[VERSION_KEY] == OLDER
    mat = bpy.data.materials.new("M")
    mat.use_nodes = True
    before = (_groups(), len(mat.node_tree.nodes))
    editor, _ = _shader_editor(bpy, mat.node_tree)
    said = _refused(editor, "add_group", group="SG Resolve")
    # Before: FINISHED, the override rebuilt in this session (stamp 24) and the new node given
    # it; saved and reopened, the override was the library's stamp-23 group again.
    assert "node group 'SG Resolve' is a library override of a group from" in said, said
    assert "library.blend" in said and "would not be saved" in said
    assert override[VERSION_KEY] == OLDER
    assert (_groups(), len(mat.node_tree.nodes)) == before
    from surfgrad_addon.addon.group_updates import linked_stale_text
    assert "library.blend" in (linked_stale_text() or ""), linked_stale_text()


def test_sg_displace_into_an_overridden_geometry_nodes_tree_is_refused(fresh, registered,
                                                                       tmp_path):
    if G.unavailable_reason("SG Displace"):
        pytest.skip(G.unavailable_reason("SG Displace"))
    lib = tmp_path / "library.blend"
    bpy.data.libraries.write(str(lib), {bpy.data.node_groups.new("Rock GN", "GeometryNodeTree")},
                             fake_user=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with bpy.data.libraries.load(str(lib), link=True) as (_, linked):
        linked.node_groups = ["Rock GN"]
    tree = bpy.data.node_groups["Rock GN"].override_create(remap_local_usages=True)
    assert tree.is_editable                      # Blender calls it editable, yet ...
    editor, _ = _shader_editor(bpy, bpy.data.materials.new("M").node_tree)
    editor["area"].ui_type = 'GeometryNodeTree'
    space = editor["area"].spaces.active
    space.pin = True
    space.node_tree = tree
    # Before: FINISHED, one node in the override; saved and reopened, 0 nodes (an override
    # keeps its changed values only).
    said = _refused(editor, "add_group", group="SG Displace")
    assert "not editable (linked or override data)" in said, said
    assert len(tree.nodes) == 0 and "SG Displace" not in bpy.data.node_groups
