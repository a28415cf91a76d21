"""The main job's outputs, the PNG writer and the command line's refusals."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from surfgrad_addon.harness import main_job
from surfgrad_addon.harness.pictures import write_png

pytestmark = pytest.mark.tier("child")


ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.tier("numpy")
def test_png_writer_round_trips_through_an_independent_reader(tmp_path):
    from matplotlib import image as mpimg
    rgba = np.zeros((3, 5, 4))
    rgba[0, 0] = [1, 0, 0, 1]        # bottom-left in Blender's order
    rgba[2, 4] = [0, 0.5, 1, 1]      # top-right
    path = write_png(tmp_path / "a.png", rgba)
    back = mpimg.imread(path)        # top row first
    assert back.shape == (3, 5, 4)
    np.testing.assert_allclose(back[2, 0], [1, 0, 0, 1])
    np.testing.assert_allclose(back[0, 4], [0, 128 / 255, 1, 1], atol=1 / 255)
    with pytest.raises(FileExistsError, match="overwrite"):
        write_png(path, rgba)
    # RGB and grey, rounded to the nearest 8-bit value, NaN as black, rows as given when not
    # bottom-up; read back by Pillow (what encodes them) and matplotlib alike.
    from PIL import Image
    rgb = np.array([[[0.2, np.nan, 1.7], [1 / 255 * 0.49, 1 / 255 * 0.51, 0.5]]])
    back = np.asarray(Image.open(write_png(tmp_path / "rgb.png", rgb, bottom_up=False)))
    assert back.dtype == np.uint8 and back.tolist() == [[[51, 0, 255], [0, 1, 128]]]
    grey = write_png(tmp_path / "g.png", np.array([[0, 64], [128, 255]]), bottom_up=True)
    assert Image.open(grey).mode == "L"
    assert np.asarray(Image.open(grey)).tolist() == [[128, 255], [0, 64]]
    with pytest.raises(ValueError, match="1, 3 or 4 channels"):
        write_png(tmp_path / "bad.png", np.zeros((2, 2, 2)))
    assert not (tmp_path / "bad.png").exists()


@pytest.mark.tier("bake")
def test_main_job_writes_maps_and_summary(tmp_path):
    summary = main_job.run(tmp_path, resolution=48, log=lambda *_: None)
    for scene in ("sphere", "torus"):
        for name in ("normal-map", "volume-noise", "baseline-geiss-triplanar"):
            img = np.load(tmp_path / f"{scene}_{name}.npy")
            assert img.shape == (48, 48, 3) and img.dtype == np.float32
            covered = np.isfinite(img).all(-1)
            assert covered.mean() > 0.8
            np.testing.assert_allclose(np.linalg.norm(img[covered], axis=-1), 1, atol=1e-5)
            assert (tmp_path / f"{scene}_{name}.png").stat().st_size > 100
        methods = summary["scenes"][scene]["methods"]
        assert all(m["finite_unit_fraction"] == 1.0 for m in methods.values())
        # Perlin's addition really differs from the surface gradient somewhere.
        assert methods["baseline-perlin1985-noise"]["difference_from_sg"]["max_deg"] > 5
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["resolution"] == 48
    assert "| normal-map |" in (tmp_path / "summary.md").read_text()
    assert (tmp_path / "overview.png").exists()


def test_cli_refuses_to_overwrite_without_being_told(tmp_path):
    (tmp_path / "summary.json").write_text("{}")
    cmd = [sys.executable, "-m", "surfgrad_addon", "demo", "--out", str(tmp_path),
           "--resolution", "16"]
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 2
    assert "exists; pass --overwrite" in out.stderr
    assert (tmp_path / "summary.json").read_text() == "{}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"]   # nothing written
