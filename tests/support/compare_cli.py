"""The compare command run in the pytest process on the open file, saved first."""


def compare_cli_refuses(tmp_path, file_name, obj_name, method):
    """Save the open file as tmp_path/file_name, run `compare` on it at 16^2; True where it
    exits 2 (refused) and writes no output folder."""
    import bpy
    from surfgrad_addon.harness.cli import main
    blend = tmp_path / file_name
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "out" / "c.json"
    rc = main(["compare", "--blend", str(blend), "--object", obj_name, "--method", method,
               "--resolution", "16", "--json", str(out)])
    return rc == 2 and not out.parent.exists()
