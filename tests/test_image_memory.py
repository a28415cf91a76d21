"""The images a bake reads count in the request's memory check, from their files' headers,
before any is loaded (addon/image_memory.py, image_headers.pixel_size, memory_limit). Before,
only the bake's texels counted: under `ulimit -v` 2.5 GB (SGE's h_vmem) an 8192^2 float EXR
crashed Blender's load (exit 139, no line), and an 8192^2 16-bit PNG was called damaged (the
load's failed allocation reads as "unknown file-format")."""

import struct
import zlib

import pytest

pytestmark = pytest.mark.tier("numpy")


def write_png16(path, width, height, rgb=(32768, 32768, 65535)):
    """A valid 16-bit RGB PNG of one colour (PNG spec: IHDR, one IDAT, IEND), written row by
    row, so a large one costs neither memory nor Blender's slow writer."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))
    row = b"\0" + struct.pack(">HHH", *rgb) * width
    z = zlib.compressobj(1)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n"
                + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, 2, 0, 0, 0)))
        data = b"".join(z.compress(row) for _ in range(height)) + z.flush()
        f.write(chunk(b"IDAT", data) + chunk(b"IEND", b""))


@pytest.mark.tier("blender")
@pytest.mark.parametrize("kind", ["png8 RGB", "png8 RGBA", "png8 BW", "png16", "jpeg", "exr half",
                                  "exr float", "tiff", "tiff16", "hdr", "bmp", "tga",
                                  "tga_raw RGBA", "webp RGB", "webp RGBA", "webp lossless",
                                  "hand png16"])
def test_the_header_size_is_what_blender_loads(kind, tmp_path):
    """Width, height and float buffer from the header alone, against the image Blender loads
    from the same file. Before, TIFF, HDR and BMP gave None, and TGA and WebP until round
    38: under `ulimit -v` an 8192^2 16-bit TIFF or HDR, or a 16384^2 TGA, was loaded and
    called damaged. (WebP: lossy VP8, lossless VP8L, VP8X with alpha.)"""
    bpy = pytest.importorskip("bpy")
    import numpy as np
    from surfgrad_addon.addon.image_headers import pixel_size
    w, h = 48, 20
    path = tmp_path / "img"
    if kind == "hand png16":
        write_png16(path, w, h)
    else:
        img = bpy.data.images.new("src", w, h, float_buffer=True)
        img.pixels.foreach_set(np.random.default_rng(0).random(w * h * 4).astype(np.float32))
        s = bpy.context.scene.render.image_settings
        fmt, _, rest = kind.partition(" ")
        s.file_format = {"png8": "PNG", "png16": "PNG", "jpeg": "JPEG", "exr": "OPEN_EXR",
                         "tiff": "TIFF", "tiff16": "TIFF", "hdr": "HDR", "bmp": "BMP",
                         "tga": "TARGA", "tga_raw": "TARGA_RAW", "webp": "WEBP"}[fmt]
        s.color_mode = rest if fmt in ("png8", "tga_raw") or rest == "RGBA" else "RGB"
        if fmt == "webp":
            s.quality = 100 if rest == "lossless" else 90       # (100: lossless)
        if fmt in ("png8", "png16", "tiff", "tiff16"):
            s.color_depth = "8" if fmt in ("png8", "tiff") else "16"
        if fmt == "exr":
            s.color_depth = "16" if rest == "half" else "32"
        img.save_render(str(path), scene=bpy.context.scene)
        bpy.data.images.remove(img)
    with open(path, "rb") as f:
        size = pixel_size(f)
    loaded = bpy.data.images.load(str(path), check_existing=False)
    try:
        assert size is not None, kind
        assert (size.width, size.height, size.float_buffer) == (
            *loaded.size, loaded.is_float), kind
    finally:
        bpy.data.images.remove(loaded)


def test_images_count_in_the_memory_check(monkeypatch):
    """The bake's texels plus what its images hold, or the largest image's check copy where
    that is more; the message names the largest image and the fix."""
    import resource
    from surfgrad_addon.addon import memory_limit as ML
    from surfgrad_addon.addon.image_memory import ImagesMemory
    gb = 1024 ** 3
    monkeypatch.setattr(resource, "getrlimit", lambda _: (int(3.5 * gb), resource.RLIM_INFINITY))
    monkeypatch.setattr(ML, "address_space_in_use", lambda: 1 * gb)
    monkeypatch.setattr(ML, "machine_memory", lambda: None)
    texels = 8192 * 8192
    # an 8192^2 float image: 16 + 8 bytes a texel for the bake, 16 + 16 while checked
    big = ImagesMemory(1, 24 * texels, 32 * texels, "1 image(s) (the largest 'n.exr', "
                                                    "8192x8192 float)")
    # 256^2: the check's copy, 2 GB, + 128 MB for Cycles' threads, fits 2.5 GB of room
    assert ML.bake_memory_problem(256, 1, big) is None
    problem = ML.bake_memory_problem(4096, 1, big)      # 2.8 + 1.5 GB + 128 MB
    assert problem.startswith("a 4096x4096 bake of 1 tile(s) reading 1 image(s) (the largest "
                              "'n.exr', 8192x8192 float) needs at least 4.4 GB of memory "), problem
    assert problem.endswith("bake at a lower --resolution or from smaller images")
    # a 16^2 float texture is no part of a 4096^2 bake's need: only the resolution is the fix
    tiny = ImagesMemory(1, 24 * 256, 32 * 256, "1 image(s) (the largest 't', 16x16 float)")
    assert ML.bake_memory_problem(4096, 1, tiny).endswith("bake at a lower --resolution")
    checked = ImagesMemory(1, 0, int(2.5 * gb), "x")                    # the check's copy
    assert "needs at least 2.6 GB" in ML.bake_memory_problem(16, 1, checked)   # + 128 MB
    assert ML.bake_memory_problem(2048, 1, ImagesMemory(0, 0, 0, "")) is None


@pytest.mark.tier("child")
def test_a_large_image_under_an_address_space_limit_is_refused_before_it_is_loaded(tmp_path):
    """`ulimit -v` 2.5 GB and an 8192^2 16-bit PNG (1 GB as Blender's float buffer, 2 GB with
    the check's copy) read by SG Normal Map: refused, exit 2, one line naming the image and the
    fix, nothing written. Before: "could not be read (damaged ...)" (the same with an EXR was
    exit 139)."""
    pytest.importorskip("bpy")
    from test_faults_pipeline34 import _command
    from test_faults_pipeline_leftovers import _scene
    write_png16(tmp_path / "big.png", 8192, 8192)
    blend = _scene(tmp_path / "a.blend", tmp_path / "big.png", via="SG Normal Map")
    out = tmp_path / "out"
    out.mkdir()
    done = _command(["bake-normal-map", "--blend", blend, "--object", "Plane", "--output",
                     out / "n.png", "--resolution", "64"], tmp_path, 2500000 * 1024)
    assert done.returncode == 2, done.stderr[-2000:]
    (line,) = [x for x in done.stderr.splitlines() if x.startswith("surfgrad: error")]
    assert line.startswith("surfgrad: error: a 64x64 bake of 1 tile(s) reading 1 image(s) (the "
                           "largest 'big.png', 8192x8192 float) needs at least 2.1 GB"), line
    assert "address-space limit of 2.4 GB" in line and "damaged" not in line, line
    assert list(out.iterdir()) == [] and list((tmp_path / "tmp").iterdir()) == []


@pytest.mark.tier("blender")
@pytest.mark.parametrize("source", ["packed", "sequence"])
def test_packed_images_and_the_sequence_frame_read_now_count(source, tmp_path):
    """A packed 16-bit PNG, and an Image Sequence at scene frame 2 whose frames differ in size:
    counted from the packed data's header and from the frame file read now. Before neither
    counted: under `ulimit -v` 2.5 GB an 8192^2 EXR frame crashed the check's load (exit
    -11, no line), a packed 8192^2 16-bit PNG was called damaged."""
    bpy = pytest.importorskip("bpy")
    import numpy as np
    from surfgrad_addon.addon import memory_limit as ML
    from surfgrad_addon.addon.image_memory import images_memory
    from test_faults_pipeline_leftovers import _exr_of_channels, _scene
    from test_faults_pipeline_more import _scene as _source_scene
    if source == "packed":
        write_png16(tmp_path / "n.png", 48, 20)
        blend = _scene(tmp_path / "s.blend", tmp_path / "n.png", pack=True)
        (tmp_path / "n.png").unlink()           # its header is read from the packed data
        name, (w, h) = "n.png", (48, 20)
    else:
        for f, (w, h) in ((1, (16, 16)), (2, (40, 8)), (3, (16, 16))):
            plane = np.full((h, w), 0.5)
            _exr_of_channels(tmp_path / f"seq.{f:04d}.exr", {c: plane for c in "RGB"})
        blend = _source_scene(tmp_path / "s.blend", tmp_path / "seq.0001.exr", "SEQUENCE")
        node = next(n for n in bpy.data.materials["Mat"].node_tree.nodes
                    if n.bl_idname == "ShaderNodeTexImage")
        node.image_user.frame_duration = 3
        bpy.context.scene.frame_current = 2
        bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
        name, (w, h) = "seq.0001.exr", (40, 8)
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    found = images_memory(bpy.data.objects["Plane"])
    texels = w * h
    assert found.count == 1 and found.what == f"1 image(s) (the largest {name!r}, {w}x{h} float)"
    assert found.baked == texels * (ML.IMAGE_BYTES_PER_TEXEL[True]
                                    + ML.CYCLES_BYTES_PER_TEXEL[True])
    assert found.checked == texels * (ML.IMAGE_BYTES_PER_TEXEL[True]
                                      + ML.CHECK_COPY_BYTES_PER_TEXEL)


@pytest.mark.tier("blender")
def test_each_tile_of_a_packed_udim_image_counts(tmp_path):
    """A packed UDIM image of two 16-bit PNG tiles of different sizes: each tile baked counts,
    from its own packed data. Before, only the first tile's (image.packed_file) was read."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.addon import memory_limit as ML
    from surfgrad_addon.addon.image_memory import images_memory
    from test_faults_pipeline_more import _scene as _source_scene
    sizes = {1001: (48, 20), 1002: (30, 64)}
    for tile, (w, h) in sizes.items():
        write_png16(tmp_path / f"n.{tile}.png", w, h)
    blend = _source_scene(tmp_path / "s.blend", tmp_path / "n.1001.png", "TILED",
                          second_tile=True)
    bpy.data.images["n.1001.png"].pack()
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=False)
    for tile in sizes:
        (tmp_path / f"n.{tile}.png").unlink()
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    per_texel = ML.IMAGE_BYTES_PER_TEXEL[True] + ML.CYCLES_BYTES_PER_TEXEL[True]
    obj = bpy.data.objects["Plane"]
    for covered in ((1001, 1002), (1002,)):
        found = images_memory(obj, covered)
        assert found.baked == sum(w * h for t, (w, h) in sizes.items() if t in covered) \
            * per_texel, covered
    assert images_memory(obj, (1001, 1002)).what == \
        "1 image(s) (the largest 'n.1001.png', 30x64 float)"


FILM = [("DPX", "RGB", "8", ""), ("DPX", "RGBA", "10", ""), ("DPX", "BW", "12", ""),
        ("DPX", "RGB", "16", ""), ("CINEON", "RGB", "10", ""), ("IRIS", "RGB", "8", ""),
        ("IRIS", "RGBA", "8", ""), ("IRIS", "BW", "8", ""), ("JPEG2000", "RGB", "8", "JP2"),
        ("JPEG2000", "RGBA", "12", "JP2"), ("JPEG2000", "BW", "16", "J2K"),
        ("JPEG2000", "RGBA", "8", "J2K")]


def _write(bpy, path, fmt, mode, depth, codec, size=(48, 36)):
    """A file Blender writes itself (48x36: JPEG 2000's 6 resolution levels need 32 texels a
    side)."""
    import numpy as np
    img = bpy.data.images.new("src", *size, float_buffer=True)
    img.pixels.foreach_set(np.random.default_rng(1).random(size[0] * size[1] * 4)
                           .astype(np.float32))
    s = bpy.context.scene.render.image_settings
    s.file_format, s.color_mode = fmt, mode
    if fmt in ("DPX", "JPEG2000"):
        s.color_depth = depth
    if codec:
        s.jpeg2k_codec = codec
    img.save_render(str(path), scene=bpy.context.scene)
    bpy.data.images.remove(img)


@pytest.mark.tier("blender")
@pytest.mark.parametrize("fmt, mode, depth, codec", FILM)
def test_film_formats_header_size_is_what_blender_loads(fmt, mode, depth, codec, tmp_path):
    """DPX, Cineon, SGI and JPEG 2000 (a JP2 file, a bare codestream): before round 39 their
    header was not read (None), so an image of these formats was left out of the memory
    check. Width, height and float buffer against the image Blender loads, channels and bits
    per sample against what Blender was asked to write."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.addon.film_image_headers import film_header_size
    from surfgrad_addon.addon.header_reads import path_headers
    from surfgrad_addon.addon.image_headers import pixel_size
    path = tmp_path / f"img_{fmt}_{mode}_{depth}"
    _write(bpy, path, fmt, mode, depth, codec)
    with open(path, "rb") as f:
        size = pixel_size(f)
        f.seek(0)
        head = f.read(33)
        f.seek(0)
        header = film_header_size(f, head)
    loaded = bpy.data.images.load(str(path), check_existing=False)
    try:
        assert size is not None
        assert (size.width, size.height, size.float_buffer) == (*loaded.size, loaded.is_float)
        channels = {"BW": 1, "RGB": 3, "RGBA": 4}[mode]
        if fmt == "JPEG2000" and mode == "BW" and bpy.app.version < (5, 2):
            channels = 3            # a line fact, pinned: before 5.2 its grey JPEG 2000 is RGB
        assert (header.channels, header.bits) == (channels, int(depth))
        assert path_headers(path).size == size          # what the memory check reads
    finally:
        bpy.data.images.remove(loaded)


@pytest.mark.tier("blender")
@pytest.mark.parametrize("fmt, codec", [("DPX", ""), ("CINEON", ""), ("IRIS", ""),
                                        ("JPEG2000", "JP2"), ("JPEG2000", "J2K")])
def test_a_damaged_film_header_is_not_read_nor_taken_for_tga(fmt, codec, tmp_path):
    """TGA has no magic: its header is read by its fields' values alone. A file of these
    formats cut inside its header (SGI: a dimension of 7, which the format lacks) gives None,
    not a size misread."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.addon.image_headers import pixel_size
    path = tmp_path / "img"
    _write(bpy, path, fmt, "RGB", "8" if fmt == "JPEG2000" else "10", codec)
    data = path.read_bytes()
    path.write_bytes(data[:4] + b"\0\0\0\7" + data[8:] if fmt == "IRIS" else data[:40])
    with open(path, "rb") as f:
        assert pixel_size(f) is None


@pytest.mark.tier("blender")
def test_a_16_bit_sgi_is_counted_as_the_float_image_blender_loads(tmp_path):
    """Blender writes SGI at 8 bits only: a verbatim 16-bit one (SGI image file format: the
    512-byte header, then each channel's rows of big-endian shorts) made here by hand."""
    bpy = pytest.importorskip("bpy")
    from surfgrad_addon.addon.image_headers import pixel_size
    w, h, z = 8, 6, 3
    head = struct.pack(">HBBHHHHii", 474, 0, 2, 3, w, h, z, 0, 65535).ljust(512, b"\0")
    path = tmp_path / "sgi16.rgb"
    path.write_bytes(head + struct.pack(f">{w * h * z}H", *((i * 997) % 65536
                                                            for i in range(w * h * z))))
    with open(path, "rb") as f:
        size = pixel_size(f)
    loaded = bpy.data.images.load(str(path), check_existing=False)
    try:
        assert (size.width, size.height, size.float_buffer) == (*loaded.size, loaded.is_float)
        assert loaded.is_float                          # what makes it count 16 bytes a texel
    finally:
        bpy.data.images.remove(loaded)
