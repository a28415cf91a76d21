"""Red team 37a: the reference evaluator as a library takes the arrays a caller has.

- uint8 / uint16 images (a PNG or TIFF as imageio or PIL load it): sample_image and
  deriv_from_height_map read them as values 0..255 / 0..65535, where Blender's Image Texture
  reads value / 255 and value / 65535. A normal map decoded as 2 * 255 - 1 lay far off the unit
  sphere: its normals were 35 degrees off (median) on a hemisphere tile, 91 at most; a height
  map's slopes were 255 (65535) times too steep. No error, no warning.
- UDIM tiles as a script has them (reference/tiles.parse_tiles, which the bake request and
  bake-batch read): a numpy array (np.unique of a layout's tiles) raised numpy's "truth value
  of an array is ambiguous" out of api.bake_normal_map, a numpy integer was refused, and
  1001.5 was cut to tile 1001 (True to tile 1).
- A grey normal map (H, W), as a library user loads one: its samples (N,) were read as one
  colour of the first three texels, so every texel got the same normal (no error); (H, W, 1)
  and grey and alpha (H, W, 2) raised an IndexError. Blender loads a grey file as (g, g, g),
  and so does the reference now (image_sampling.sample_colour). A height image (H, W, 1) in
  the forward variant broadcast its derivatives to an (N, N, 3) array (N texels: 224 of them
  gave 224 x 224 x 3; a 1024^2 bake would ask for terabytes), and a colour height image
  raised numpy's broadcast error; now (H, W, 1) is read as (H, W) and colour is refused
  naming the fix, by every height method.
- A normal map texel of exactly (0.5, 0.5, 0.5) (m = 0: a float map's empty background): the
  Normal Map node's Strength blend 1 + 1 (z - 1) rounded Listing 2's floor away, 0 / 0 gave a
  NaN surface gradient, and the resolve dropped every layer added to it. compare called a
  correct `layered` stack wrong, p99 36.1 / max 55.0 deg at 32^2 on 5.2 and 5.0 (a sphere, the
  hemisphere map's flat part mid-grey); now p99 0.0011 / max 0.006. On 4.2 and 4.5 the group
  itself dropped those layers (p99 45 deg at 24^2, which the old reference matched): its
  Listing 2 colour handed the Normal Map node (0.5, 0.5, 0.5), whose zero vector those lines
  do not turn into the shading normal, and Listing 5 of that is the base normal, not zero.
  The colour's blue now stays above 0.5 (NODE_Z_FLOOR): every line keeps the layers.
- rasterize with a float size (16.0, as a script's arithmetic gives it): numpy's "Cannot cast
  array data from dtype('float64') to dtype('int64')" (or numba's "expected a sequence of
  integers") from deep inside; now a ValueError naming the size. A MeshArrays whose
  matrix_world scales an axis to zero raised numpy's bare "Singular matrix"; now named.
"""

import numpy as np
import pytest

from surfgrad_addon.reference import height_map as HM
from surfgrad_addon.reference import image_sampling as IS
from surfgrad_addon.reference import methods as M

pytestmark = pytest.mark.tier("numpy")


@pytest.fixture(params=["0", "1"], ids=["numpy", "compiled"])
def route(request, monkeypatch):
    monkeypatch.setenv("SURFGRAD_REFERENCE_COMPILED", request.param)


@pytest.mark.parametrize("dtype, top", [(np.uint8, 255), (np.uint16, 65535)])
def test_file_pixels_read_as_blender_reads_them(route, dtype, top):
    # A normal map tilted 30 degrees about v, as an 8- or 16-bit file stores it.
    tilt = np.radians(30.0)
    normal = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    colour = np.round((normal + 1) / 2 * top).astype(dtype)
    image = np.broadcast_to(colour, (8, 8, 3)).copy()
    st = IS.texel_centres(8, 8).reshape(-1, 2)
    for interpolation in IS.INTERPOLATIONS:
        sampled = IS.sample_image(image, st, interpolation)
        np.testing.assert_allclose(sampled, np.broadcast_to(colour / top, sampled.shape),
                                   rtol=0, atol=1e-15)
    deriv = M.normal_map_node_derivative(IS.sample_image(image, st))
    # Eq. 15: (-x / z, -y / z) of the stored normal, within the file's rounding.
    np.testing.assert_allclose(deriv, np.broadcast_to([-np.tan(tilt), 0.0], deriv.shape),
                               atol=0.01)
    # A height ramp one step per texel along u: dH/du is one step in pixel units (1 / top).
    ramp = np.broadcast_to(np.arange(16, dtype=dtype) * 3, (16, 16)).copy()
    inner = np.stack(np.meshgrid(np.arange(2, 13) + 0.5, np.arange(16) + 0.5), -1) / 16
    for hq in (False, True):
        d = HM.deriv_from_height_map(ramp, inner.reshape(-1, 2), hq=hq, extension="EXTEND")
        np.testing.assert_allclose(d, np.broadcast_to([3 / top, 0.0], d.shape), atol=1e-12)


def test_tiles_as_a_script_gives_them():
    from surfgrad_addon.reference.tiles import parse_tiles
    # np.unique of a layout's tile numbers: numpy's "truth value of an array is ambiguous".
    assert parse_tiles(np.array([1002, 1001, 1002])) == [1001, 1002]
    assert parse_tiles(np.array([], dtype=np.int64)) is None
    assert parse_tiles(np.int64(1003)) == [1003]
    assert parse_tiles([1001.0, "1002"]) == [1001, 1002]
    # 1001.5 was cut to tile 1001, True taken as tile 1.
    for bad in ([1001.5], np.array([1001.5]), [True], [None]):
        with pytest.raises(ValueError, match="give UDIM numbers like 1001,1002"):
            parse_tiles(bad)


def test_grey_normal_maps_and_one_channel_heights(route):
    from surfgrad_addon.reference import images, meshes, raster
    td = raster.rasterize(meshes.uv_sphere(16, 8), "UVMap", 16, 16)
    grey = 0.2 + 0.25 * images.wave_height_image(32)        # (off 0.5: m = 0 is another case)
    # Blender loads a grey file as (g, g, g): each method reads the grey image as that RGB.
    rgb = np.stack([grey, grey, grey], -1)
    for as_given in (grey, grey[..., None], np.stack([grey, np.ones_like(grey)], -1)):
        for method in (lambda im: M.normal_map_surfgrad(td, im),
                       lambda im: M.procedural_basis_surfgrad(td, im, "Detail"),
                       lambda im: M.triplanar_surfgrad(td, im)):
            np.testing.assert_array_equal(method(as_given)[1], method(rgb)[1])
    height = images.wave_height_image(32)
    for variant in M.HEIGHT_VARIANTS:
        want = M.height_map_surfgrad(td, height, variant)[1]
        got = M.height_map_surfgrad(td, height[..., None], variant)[1]
        assert got.shape == (td.texel_count, 3)
        np.testing.assert_array_equal(got, want)
        with pytest.raises(ValueError, match=r"one-channel image .*\(32, 32, 3\): give one"):
            M.height_map_surfgrad(td, np.stack([height] * 3, -1), variant)


def test_a_mid_grey_normal_map_texel_adds_nothing(route):
    from surfgrad_addon.reference import images, meshes, raster
    # m = 0 (colour (0.5, 0.5, 0.5)): Listing 2's zero derivative at every Strength, where
    # 1 + 1 (z - 1) rounded to 0 and gave 0 / 0.
    grey = np.full((4, 3), 0.5)
    for strength in (1.0, 2.0, 0.5):
        np.testing.assert_array_equal(M.normal_map_node_derivative(grey, strength), 0.0)
    # So a mid-grey map is a flat one, and the layers added to it stay (its NaN surface
    # gradient made the resolve drop the detail and noise layers at those texels).
    td = raster.rasterize(meshes.uv_sphere(16, 8), "UVMap", 16, 16)
    detail = images.hemisphere_tile_image(16)
    mid = M.layered_normal(td, np.full((8, 8, 3), 0.5), detail)
    flat = M.layered_normal(td, np.broadcast_to([0.5, 0.5, 1.0], (8, 8, 3)), detail)
    np.testing.assert_array_equal(mid, flat)
    assert np.degrees(np.arccos(np.clip(np.sum(mid * M.unit_base_normal(td), -1), -1, 1))).max() > 5


@pytest.mark.tier("bake")
def test_compare_of_a_stack_on_a_mid_grey_normal_map(fresh):
    from surfgrad_addon.harness import compare, scenes
    from surfgrad_addon.reference import images
    obj = scenes.new_scene(["Sphere"])["Sphere"]
    pixels = images.hemisphere_tile_image(64)
    pixels[np.all(pixels == [0.5, 0.5, 1.0], axis=-1)] = 0.5     # the flat part mid-grey
    report, _ = compare.compare_object(obj, "layered", 24, image=pixels, log=lambda *_: None)
    # p99 only: a texel or two where the rim's colour blends into mid-grey (m near 0, the
    # derivative at Listing 2's 128) face away from the surface or not by float32 rounding
    # (5.0: one texel, 92 deg); layers dropped were a third of the texels (p99 36-45 deg).
    assert report["p99_deg"] < 0.1, report


def test_rasterize_takes_whole_numbers_of_texels(route):
    from surfgrad_addon.reference import meshes, raster
    mesh = meshes.plane(subdivisions=2)
    want = raster.rasterize(mesh, "UVMap", 16, 8)
    got = raster.rasterize(mesh, "UVMap", np.int64(16), np.int32(8))
    np.testing.assert_array_equal(got.pixel, want.pixel)
    for bad in (16.0, 16.5, True):
        with pytest.raises(ValueError, match=r"whole numbers of texels, got .* x 8"):
            raster.rasterize(mesh, "UVMap", bad, 8)


def test_a_mesh_scaled_to_zero_on_an_axis_is_named():
    import dataclasses
    from surfgrad_addon.reference import meshes, raster
    mesh = dataclasses.replace(meshes.plane(), matrix_world=np.diag([1.0, 0.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="matrix_world scales an axis to zero.*fix the object"):
        raster.rasterize(mesh, "UVMap", 8, 8)
