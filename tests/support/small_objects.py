"""What the small-object rounds (test_faults_small_objects*.py) share: a test object scaled
down, a height-map stack on it, and bake-normal-map run in the pytest process on the open
file, saved first."""


def scaled_test_object(name, scale):
    """A new scene's test object `name` (harness/scenes.py), scaled by `scale` on every axis."""
    import bpy
    from surfgrad_addon.harness import scenes
    obj = scenes.new_scene((name,))[name]
    obj.scale = (scale,) * 3
    bpy.context.view_layer.update()
    return obj


def bake_open_file(tmp_path, capsys, stem, *more, obj_name="Sphere"):
    """Save the open file as tmp_path/stem.blend and bake obj_name at 16^2, 1 sample, to
    tmp_path/stem.png (`more`: further arguments). Returns (exit code, stderr, whether the
    map was written)."""
    import bpy
    from surfgrad_addon.harness.cli import main
    blend, out = tmp_path / f"{stem}.blend", tmp_path / f"{stem}.png"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    capsys.readouterr()
    rc = main(["bake-normal-map", "--blend", str(blend), "--object", obj_name, "--output",
               str(out), "--resolution", "16", "--samples", "1", *more])
    return rc, capsys.readouterr().err, out.exists()


def height_map_stack(obj, name="Tiny", bump=None):
    """A material `name` on obj: SG Height Map Forward (node 'Height', its Bump Scale `bump`,
    None: the default) in a layer stack; its derivative comes from the bake's steps."""
    from surfgrad_addon import api
    from surfgrad_addon.addon.compat import new_material
    mat = new_material(name)
    obj.data.materials.append(mat)
    combine = api.add_layer_stack(mat, "UVMap")["combine"]
    height = mat.node_tree.nodes.new("ShaderNodeGroup")
    height.node_tree = api.node_group("SG Height Map Forward")
    height.name = "Height"
    if bump is not None:
        height.inputs["Bump Scale"].default_value = bump
    mat.node_tree.links.new(height.outputs["Surface Gradient"], combine.inputs["B"])
    return mat
