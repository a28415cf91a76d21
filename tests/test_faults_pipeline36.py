"""Fault injection, red team 36a: Blender's other tile token, and checks that read one part of
what the bake reads.

`--output m.<UVTILE>.png` (Blender's u<U>_v<V> tile token) wrote a file named with the token,
exit 0; <UVTILE> is now refused before baking."""

import pytest

bpy = pytest.importorskip("bpy")

from surfgrad_addon.addon import commands, exit_codes  # noqa: E402
from surfgrad_addon.harness import batch_assets as BA  # noqa: E402


@pytest.mark.tier("blender")
def test_the_uvtile_token_is_refused_before_baking(tmp_path, capsys):
    """Before: bake-normal-map and bake-batch with <UVTILE> in the output name, one tile,
    wrote `m.<UVTILE>.png` itself, exit 0. Now exit 2 naming the token and the fix, and the
    folder stays empty."""
    blend = BA.write_asset(tmp_path / "a.blend", ("Rock",), tiles=(1001,), image_size=16)
    out = tmp_path / "out"
    out.mkdir()
    said = "has <UVTILE>, which this bake does not fill in"
    for args in (["bake-normal-map", "--blend", str(blend), "--object", "Rock", "--output",
                  str(out / "m.<UVTILE>.png")],
                 ["bake-batch", str(blend), "--output", str(out / "{object}.<UVTILE>.png"),
                  "--workers", "0"]):
        capsys.readouterr()
        rc = commands.execute(args + ["--resolution", "16", "--samples", "1"])
        err = capsys.readouterr().err
        assert rc == exit_codes.BAD_REQUEST and said in err.strip().splitlines()[-1], err
    assert list(out.iterdir()) == []
