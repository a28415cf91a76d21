"""A multi-tile bake puts all its tile files in place or none: a tile file another process
made between the request's checks and the publish (a second bake of the same names) stops
the bake, and the tiles it had already put in place are removed again."""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.addon import publish_files as PF  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402

pytestmark = pytest.mark.tier("bake")


def test_a_tile_made_by_another_process_mid_bake_leaves_no_tile(tmp_path, monkeypatch, capsys):
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001, 1002, 1003),
                           image_size=16)
    out = tmp_path / "maps"
    out.mkdir()
    real = PF._move_in

    def other_process_writes_1002(temp, final, replace):
        if final.name == "n.1002.png":
            final.write_bytes(b"another bake's tile")
        return real(temp, final, replace)
    monkeypatch.setattr(PF, "_move_in", other_process_writes_1002)
    capsys.readouterr()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(out / "n.<UDIM>.png"), "--resolution", "16"])
    err = capsys.readouterr().err
    assert rc != exit_codes.OK, err
    assert "n.1002.png exists; pass --overwrite to replace it" in err, err
    # 1001 was put in place before 1002 failed: removed again; the other process's file kept.
    assert sorted(p.name for p in out.iterdir()) == ["n.1002.png"], err
    assert (out / "n.1002.png").read_bytes() == b"another bake's tile"

    # Without the interference the same bake writes every tile.
    monkeypatch.setattr(PF, "_move_in", real)
    (out / "n.1002.png").unlink()
    rc = commands.execute(["bake-normal-map", "--blend", str(blend), "--object", "Rock",
                           "--output", str(out / "n.<UDIM>.png"), "--resolution", "16"])
    assert rc == exit_codes.OK, capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["n.1001.png", "n.1002.png", "n.1003.png"]
