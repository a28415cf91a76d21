"""Fault injection for files from outside the project (red team 28): a .blend saved by a newer
Blender line than the one running (5.x's new file header reads as "not a blend file" to 4.x),
asset lists and settings files with a UTF-8 byte-order mark (Windows editors, PowerShell), and
a zero scale axis that comes from the delta scale, a parent or a constraint (the message showed
the object's own, whole scale), an output name longer than the file system takes. Numpy tier:
headers, text files, names and messages, no bpy."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from surfgrad_addon.addon import open_blend
from surfgrad_addon.addon.bake_request import zero_scale_problem
from surfgrad_addon.addon.batch import plan

pytestmark = pytest.mark.tier("numpy")


@pytest.mark.parametrize("header,version", [
    (b"BLENDER-v402REND", (4, 2)),              # 64-bit little-endian, the layout up to 4.x
    (b"BLENDER_V279REND", (2, 79)),             # 32-bit big-endian
    (b"BLENDER17-01v0502", (5, 2)),             # the header from 5.0 on
    (b"BLENDER17-01v1003", (10, 3)),
    (b"\x28\xb5\x2f\xfd....", None),            # zstd-compressed: the header is not readable
    (b"not a blend", None),
    (b"BLENDER-vabc", None),
])
def test_the_version_a_blend_was_saved_by_is_read_from_its_header(header, version):
    assert open_blend.saved_by(header) == version


def test_only_a_newer_line_is_named(tmp_path):
    blend = tmp_path / "asset.blend"
    blend.write_bytes(b"BLENDER17-01v0502REND" + b"\0" * 64)
    assert open_blend.newer_than_running(blend, (4, 2, 23)) == "5.2"
    assert open_blend.newer_than_running(blend, (5, 2, 3)) is None
    assert open_blend.newer_than_running(blend, (5, 3, 0)) is None
    assert open_blend.newer_than_running(tmp_path / "missing.blend", (4, 2, 0)) is None


def test_an_asset_list_with_a_byte_order_mark(tmp_path):
    (tmp_path / "rock.blend").write_bytes(b"")
    listing = tmp_path / "assets.txt"
    listing.write_bytes("\ufeffrock.blend:Rock\r\n# a comment\r\nrock.blend:Stone\r\n"
                        .encode("utf-8"))
    assert plan.read_asset_list(listing) == [f"{tmp_path / 'rock.blend'}:Rock",
                                             f"{tmp_path / 'rock.blend'}:Stone"]


def test_a_settings_file_with_a_byte_order_mark(tmp_path):
    settings = tmp_path / "settings.json"
    settings.write_bytes(b"\xef\xbb\xbf" + json.dumps(
        {"defaults": {"resolution": 64}, "assets": {"Rock": {"samples": 4}}}).encode())
    loaded = plan.load_settings_file(settings)
    assert loaded["defaults"] == {"resolution": 64}
    assert loaded["assets"] == {"Rock": {"samples": 4}}


def _obj(scale):
    return SimpleNamespace(name="Rock", scale=scale)


def test_a_zero_axis_from_elsewhere_is_said_to_come_from_elsewhere():
    squashed = np.diag([1.0, 0.0, 1.0, 1.0])          # e.g. a delta scale of (1, 0, 1)
    text = zero_scale_problem(_obj((1.0, 1.0, 1.0)), squashed)
    assert text == ("object 'Rock': its scale has a zero axis (scale (1.0, 1.0, 1.0), its world "
                    "matrix is singular: the zero comes from its delta scale, a parent or a "
                    "constraint), so its normals cannot be baked: apply a non-zero scale on "
                    "every axis")
    own = zero_scale_problem(_obj((1.0, 0.0, 1.0)), squashed)
    assert "scale (1.0, 0.0, 1.0), its world matrix is singular)" in own
    assert zero_scale_problem(_obj((1.0, 1.0, 1.0)), np.eye(4)) is None


def test_an_output_name_too_long_for_the_file_system_is_refused(tmp_path):
    """A name the file system refuses raised OSError out of the command (a traceback, before
    or after the bake: the temporary file beside the output has a longer name)."""
    from surfgrad_addon.addon import normal_bake as NB
    longest = 255 - NB.TEMP_NAME_EXTRA             # tmp_path's file system: 255-byte names
    fits = tmp_path / ("a" * (longest - 4) + ".png")
    assert NB.check_output(fits) == fits
    for name in ("a" * (longest - 3) + ".png", "a" * 300 + ".png"):
        with pytest.raises(NB.NormalBakeError, match=f"is {len(name)} bytes: the folder's "
                           f"file system takes {longest} for it"):
            NB.check_output(tmp_path / name)
    with pytest.raises(NB.NormalBakeError, match=r"cannot be used \(File name too long\): "
                                                 r"give a shorter or plainer file name"):
        NB.check_output(tmp_path / ("d" * 300) / "n.png")


def test_a_material_without_a_node_tree_is_named():
    """(Files from before 5.0; the whole refusal: test_faults_scene_settings.py on 4.x.)"""
    from surfgrad_addon.addon.material_inputs import no_tree_problem
    assert no_tree_problem(SimpleNamespace(name="Bare", node_tree=None)) == (
        "material 'Bare' has no node tree (Use Nodes is off), so the bake has nowhere to "
        "write its faces: turn on Use Nodes for it (Material Properties > Surface), or give "
        "its faces another material")
    assert no_tree_problem(SimpleNamespace(name="Mat", node_tree=object())) is None
