"""Image reading/writing, sRGB encoding, tone mapping and the data folder."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from brdfkit import io

ENVMAPS = ("probulator", "polyhaven")


def _hdr_paths(shared_data: Path) -> list[Path]:
    paths = [
        p for folder in ENVMAPS for p in sorted((shared_data / "envmaps" / folder).glob("*.hdr"))
    ]
    assert paths, "no .hdr maps found in the shared data"
    return paths


def _mitsuba():
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    return mi


# -------------------------------------------------------------------------------- reading


@pytest.mark.oracle
@pytest.mark.data
def test_hdr_matches_mitsuba(shared_data):
    mi = _mitsuba()
    for path in _hdr_paths(shared_data):
        image = io.read_image(path)
        assert image.dtype == np.float32 and image.ndim == 3 and image.shape[-1] == 3
        np.testing.assert_array_equal(image, np.array(mi.Bitmap(str(path))), err_msg=path.name)


@pytest.mark.data
def test_exr_matches_openexr_and_mitsuba(shared_data):
    import OpenEXR

    path = shared_data / "envmaps" / "pbrt" / "grace_latlong.exr"
    image = io.read_image(path)
    assert image.shape == (512, 1024, 3) and image.dtype == np.float32
    with OpenEXR.File(str(path)) as exr:
        reference = exr.channels()["RGB"].pixels
    assert reference.dtype == np.float16
    np.testing.assert_array_equal(image, reference.astype(np.float32))
    mi = _mitsuba()
    np.testing.assert_array_equal(image, np.array(mi.Bitmap(str(path))).astype(np.float32))


@pytest.mark.parametrize("suffix", [".tga", ".jpg", ".bmp", ".tif"])
def test_8_bit_formats_read_codes_over_255(tmp_path, suffix):
    from PIL import Image

    codes = np.random.default_rng(7).integers(0, 256, (6, 5, 3), dtype=np.uint8)
    path = tmp_path / f"a{suffix}"
    Image.fromarray(codes).save(path, quality=100)
    image = io.read_image(path)
    assert image.shape == (6, 5, 3) and image.dtype == np.float32
    if suffix == ".jpg":  # lossy: compare with the decoded codes
        codes = np.asarray(Image.open(path))
    np.testing.assert_array_equal(image, codes / np.float32(255))


@pytest.mark.data
def test_real_tga_set_reads(shared_data):
    paths = sorted((shared_data / "photometric_stereo" / "psm" / "gray").glob("*.tga"))
    image = io.read_image(paths[0])
    assert image.shape == (340, 512, 3) and 0 <= image.min() and image.max() <= 1
    assert image.max() > 0.5  # a lit sphere, not a black frame


@pytest.mark.data
def test_16_bit_png_keeps_all_bits(shared_data):
    cv2 = pytest.importorskip("cv2")
    path = shared_data / "normal_integration" / "diligent" / "bear" / "normal_map.png"
    image = io.read_image(path)
    codes = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)[..., ::-1]
    assert codes.dtype == np.uint16
    np.testing.assert_array_equal(image, codes / np.float32(65535))
    assert np.any((codes % 256) != 0)  # the low byte carries information


def test_srgb_to_linear_decodes_colour_not_alpha(tmp_path):
    rgba = np.random.default_rng(0).random((5, 6, 4))
    path = io.write_image(tmp_path / "a.png", rgba, bit_depth=16)
    stored = io.read_image(path)
    linear = io.read_image(path, srgb_to_linear=True)
    np.testing.assert_allclose(linear[..., :3], io.srgb_decode(stored[..., :3]), rtol=1e-6)
    np.testing.assert_array_equal(linear[..., 3], stored[..., 3])
    np.testing.assert_allclose(stored[..., 3], rgba[..., 3], atol=0.5 / 65535 + 1e-7)


# -------------------------------------------------------------------------------- round trips


@pytest.mark.data
def test_exr_round_trip_half_and_float(shared_data, tmp_path):
    image = io.read_image(shared_data / "envmaps" / "pbrt" / "grace_latlong.exr")
    io.write_image(tmp_path / "half.exr", image, half=True)  # values are half floats already
    np.testing.assert_array_equal(io.read_image(tmp_path / "half.exr"), image)
    noise = np.random.default_rng(1).random((7, 9, 3)).astype(np.float32) * 1e3
    io.write_image(tmp_path / "float.exr", noise)
    np.testing.assert_array_equal(io.read_image(tmp_path / "float.exr"), noise)
    io.write_image(tmp_path / "rounded.exr", noise, half=True)
    np.testing.assert_array_equal(
        io.read_image(tmp_path / "rounded.exr"), noise.astype(np.float16).astype(np.float32)
    )


@pytest.mark.parametrize("channels", [1, 4])
def test_exr_grey_and_alpha_channels(tmp_path, channels):
    image = np.random.default_rng(2).random((4, 5, channels)).astype(np.float32)
    io.write_image(tmp_path / "a.exr", image)
    np.testing.assert_array_equal(io.read_image(tmp_path / "a.exr"), image)


@pytest.mark.data
def test_hdr_round_trip(shared_data, tmp_path):
    image = io.read_image(shared_data / "envmaps" / "probulator" / "grace.hdr")
    io.write_image(tmp_path / "same.hdr", image)  # already RGBE-representable: exact
    np.testing.assert_array_equal(io.read_image(tmp_path / "same.hdr"), image)
    noise = np.random.default_rng(3).random((16, 16, 3)) * np.logspace(-3, 3, 16)[:, None, None]
    io.write_image(tmp_path / "noise.hdr", noise)
    back = io.read_image(tmp_path / "noise.hdr")
    # RGBE: an 8-bit mantissa per channel and a shared exponent set by the largest channel.
    largest = noise.max(axis=-1, keepdims=True)
    assert np.all(np.abs(back - noise) <= largest / 128)
    grey = noise[..., :1]
    io.write_image(tmp_path / "grey.hdr", grey)
    back = io.read_image(tmp_path / "grey.hdr")
    assert back.shape == (16, 16, 3) and np.all(back[..., 0] == back[..., 2])


@pytest.mark.parametrize("bit_depth", [8, 16])
def test_png_round_trip(tmp_path, bit_depth):
    linear = np.random.default_rng(4).random((6, 7, 3)) * 1.2 - 0.1
    path = io.write_image(tmp_path / "a.png", linear, bit_depth=bit_depth)
    maximum = 2**bit_depth - 1
    expected = np.rint(io.srgb_encode(np.clip(linear, 0, 1)) * maximum) / maximum
    np.testing.assert_allclose(io.read_image(path), expected, rtol=0, atol=1e-7)
    back = io.read_image(path, srgb_to_linear=True)
    step = np.abs(io.srgb_decode(expected + 0.5 / maximum) - io.srgb_decode(expected))
    assert np.all(np.abs(back - np.clip(linear, 0, 1)) <= step + 1e-6)


def test_png_exposure_and_raw_values(tmp_path):
    linear = np.full((2, 3), 0.125)
    io.write_image(tmp_path / "a.png", linear, exposure=2.0, srgb=False, bit_depth=16)
    np.testing.assert_allclose(io.read_image(tmp_path / "a.png")[..., 0], 0.5, atol=1e-5)


def test_png_matches_imageio_reader(tmp_path):
    iio = pytest.importorskip("imageio.v3")
    image = np.random.default_rng(5).random((8, 9, 3))
    path = io.write_image(tmp_path / "a.png", image)
    np.testing.assert_array_equal(io.read_image(path), iio.imread(path) / np.float32(255))


# ------------------------------------------------------------- codecs against other readers


@pytest.mark.parametrize("width", [5, 300])  # narrower than any run-length scanline; wider
def test_hdr_written_reads_back_in_opencv(tmp_path, width):
    cv2 = pytest.importorskip("cv2")
    image = np.random.default_rng(6).random((4, width, 3)) * np.logspace(-4, 4, width)[:, None]
    image[1, :2] = 0.0
    path = io.write_image(tmp_path / "a.hdr", image)
    opencv = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)[..., ::-1]
    ours = io.read_image(path)
    np.testing.assert_array_equal(ours, opencv)
    assert np.all(np.abs(ours - image) <= image.max(axis=-1, keepdims=True) / 128)


def test_hdr_written_by_opencv_with_runs_reads_the_same(tmp_path):
    cv2 = pytest.importorskip("cv2")
    image = np.zeros((6, 200, 3), np.float32)
    image[:, 50:] = np.random.default_rng(8).random((6, 150, 3)) * 5  # runs, then literals
    path = tmp_path / "opencv.hdr"
    assert cv2.imwrite(str(path), image[..., ::-1], [cv2.IMWRITE_HDR_COMPRESSION, 1])
    np.testing.assert_array_equal(
        io.read_image(path), cv2.imread(str(path), cv2.IMREAD_UNCHANGED)[..., ::-1]
    )


def test_hdr_run_length_scanlines_decode_run_by_run(tmp_path):
    """Run-length scanlines written by hand, each channel's runs chosen to mix the kinds
    (runs of 1 to 127 copies, literals of 1 to 128 bytes, back to back): every pixel
    equals Ward's decoding of the bytes, written out here run by run."""
    rng = np.random.default_rng(21)
    width, height = 300, 3
    body, expected = bytearray(), np.empty((height, 4, width), np.uint8)
    for row in range(height):
        body += bytes([2, 2, width >> 8, width & 0xFF])
        for channel in range(4):
            filled, plane = 0, []
            for length in (1, 127, 1, 128, 30, 13, 128):
                length = min(length, width - filled)
                if length == 0:
                    break
                if length <= 127 and rng.random() < 0.5:  # a run: count + 128, then the byte
                    value = int(rng.integers(1, 256))
                    body += bytes([128 + length, value])
                    plane += [value] * length
                else:  # a literal: count, then the bytes
                    values = rng.integers(0, 256, length).tolist()
                    body += bytes([length, *values])
                    plane += values
                filled += length
            expected[row, channel] = plane
    path = tmp_path / "runs.hdr"
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 3 +X 300\n" + bytes(body))
    rgbe = expected.transpose(0, 2, 1)
    scale = np.ldexp(np.float32(1), rgbe[..., 3:].astype(int) - 136).astype(np.float32)
    np.testing.assert_array_equal(
        io.read_image(path), np.where(rgbe[..., 3:] > 0, rgbe[..., :3] * scale, 0.0)
    )


def _rle_scanlines(rgbe: np.ndarray) -> bytes:
    """Run-length encoded scanlines of RGBE bytes ``(H, W, 4)``: a run for each stretch of 2
    to 127 equal bytes, literals of one byte between them."""
    height, width = rgbe.shape[:2]
    body = bytearray()
    for row in range(height):
        body += bytes([2, 2, width >> 8, width & 0xFF])
        for channel in range(4):
            plane, i = rgbe[row, :, channel].tolist(), 0
            while i < width:
                j = i
                while j < width and j - i < 127 and plane[j] == plane[i]:
                    j += 1
                if j - i >= 2:
                    body += bytes([128 + j - i, plane[i]])
                else:
                    body += bytes([1, plane[i]])
                    j = i + 1
                i = j
    return b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width) + bytes(body)


@pytest.mark.parametrize("rows_per_block", [1, 3, None])
def test_hdr_run_length_blocks_of_rows_decode_the_same_contiguous_image(
    tmp_path, monkeypatch, rows_per_block
):
    """Run-length scanlines are expanded a block of rows at a time into one C-contiguous
    image (no copy needed by a map): the same pixels whatever the block."""
    rng = np.random.default_rng(29)
    rgbe = rng.integers(0, 256, (7, 40, 4)).astype(np.uint8)
    rgbe[2:5, 5:30] = rgbe[2, 5]  # stretches of equal bytes: runs
    path = tmp_path / "blocks.hdr"
    path.write_bytes(_rle_scanlines(rgbe))
    if rows_per_block is not None:
        monkeypatch.setattr(io, "_RGBE_BLOCK_BYTES", rows_per_block * 4 * rgbe.shape[1])
    image = io.read_image(path)
    scale = np.ldexp(np.float32(1), rgbe[..., 3:].astype(int) - 136).astype(np.float32)
    expected = np.where(rgbe[..., 3:] > 0, rgbe[..., :3] * scale, 0.0)
    assert image.flags.c_contiguous and image.dtype == np.float32
    np.testing.assert_array_equal(image, expected)


@pytest.mark.parametrize(
    ("channel_runs", "message"),
    [
        ([bytes([0]), bytes([128 + 8, 7]), *[bytes([128 + 8, 5])] * 3], "run of length 0"),
        (
            [
                bytes([128 + 5, 1]),
                bytes([128 + 6, 2]),
                bytes([128 + 5, 3]),
                bytes([128 + 8, 5]) * 2,
            ],
            "run across channels",
        ),
        (
            [bytes([128 + 9, 1]), bytes([128 + 9, 2]), bytes([128 + 9, 3]), bytes([128 + 9, 4])],
            "past its width 8",
        ),
    ],
)
def test_hdr_corrupt_runs_are_refused_naming_the_file_and_scanline(tmp_path, channel_runs, message):
    """A scanline whose runs have no length, or cross from one channel into the next, or
    overfill the row, is refused with the file and the scanline named."""
    good = bytes([2, 2, 0, 8]) + bytes([128 + 8, 5]) * 4
    bad = bytes([2, 2, 0, 8]) + b"".join(channel_runs)
    path = tmp_path / "corrupt.hdr"
    header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 3 +X 8\n"
    path.write_bytes(header + good + bad + good)
    with pytest.raises(io.ImageReadError, match=rf"corrupt\.hdr.*scanline 1 .*{message}"):
        io.read_image(path)


def test_hdr_other_layouts_are_refused_naming_the_file(tmp_path):
    xyze = tmp_path / "xyze.hdr"
    xyze.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n" + bytes(4))
    with pytest.raises(io.ImageReadError, match=r"xyze\.hdr.*32-bit_rle_xyze"):
        io.read_image(xyze)
    flipped = tmp_path / "flipped.hdr"
    flipped.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 1 +X 1\n" + bytes(4))
    with pytest.raises(io.ImageReadError, match="-Y height \\+X width"):
        io.read_image(flipped)


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_16_bit_png_written_reads_in_pypng_and_back(tmp_path, channels):
    png = pytest.importorskip("png")
    image = np.random.default_rng(9).random((5, 6, channels))
    path = io.write_image(tmp_path / "a.png", image, srgb=False, bit_depth=16)
    width, height, rows, info = png.Reader(filename=str(path)).asDirect()
    codes = np.array([list(row) for row in rows]).reshape(height, width, channels)
    assert info["bitdepth"] == 16
    np.testing.assert_array_equal(codes, np.rint(image * 65535))
    np.testing.assert_array_equal(io.read_image_codes(path), codes)


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_8_bit_png_written_reads_in_pillow(tmp_path, channels):
    from PIL import Image

    image = np.random.default_rng(10).random((5, 6, channels))
    path = io.write_image(tmp_path / "a.png", image, srgb=False)
    with Image.open(path) as pillow:
        codes = np.asarray(pillow).reshape(5, 6, channels)
    np.testing.assert_array_equal(codes, np.rint(image * 255))


def test_png_palette_and_grey_alpha_read_as_rgb(tmp_path):
    from PIL import Image

    rgb = np.random.default_rng(11).integers(0, 256, (4, 5, 3), dtype=np.uint8)
    Image.fromarray(rgb).quantize(8).save(tmp_path / "palette.png")
    with Image.open(tmp_path / "palette.png") as pillow:
        expected = np.asarray(pillow.convert("RGB"))
    np.testing.assert_array_equal(io.read_image_codes(tmp_path / "palette.png"), expected)
    grey_alpha = rgb[..., :2]
    Image.fromarray(grey_alpha, "LA").save(tmp_path / "la.png")
    np.testing.assert_array_equal(
        io.read_image_codes(tmp_path / "la.png"), grey_alpha[..., [0, 0, 0, 1]]
    )


@pytest.mark.parametrize(
    ("dtype", "planar"), [(np.uint16, False), (np.uint16, True), (np.float32, False)]
)
def test_tiff_keeps_16_bit_and_float_samples(tmp_path, dtype, planar):
    tifffile = pytest.importorskip("tifffile")
    rng = np.random.default_rng(12)
    image = (rng.random((5, 6, 3)) * (65535 if dtype == np.uint16 else 1)).astype(dtype)
    stored = np.moveaxis(image, -1, 0) if planar else image
    path = tmp_path / "a.tif"
    tifffile.imwrite(path, stored, photometric="rgb", planarconfig="separate" if planar else None)
    if dtype == np.uint16:
        np.testing.assert_array_equal(io.read_image_codes(path), image)
    np.testing.assert_array_equal(
        io.read_image(path), image / np.float32(65535) if dtype == np.uint16 else image
    )


def test_a_float_tiff_bomb_is_refused_before_decoding(tmp_path):
    tifffile = pytest.importorskip("tifffile")
    path = tmp_path / "bomb.tif"
    tifffile.imwrite(path, np.ones((2, 2, 3), np.float32), photometric="rgb")
    with tifffile.TiffFile(path, mode="r+b") as tiff:
        tiff.pages.first.tags["ImageWidth"].overwrite(20_000)
        tiff.pages.first.tags["ImageLength"].overwrite(20_000)
    with pytest.raises(io.ImageTooLargeError, match=r"bomb\.tif.*20000 × 20000"):
        io.read_image(path)


def test_write_accepts_torch(tmp_path):
    torch = pytest.importorskip("torch")
    image = torch.rand(3, 4, 3, dtype=torch.float64)
    io.write_image(tmp_path / "t.exr", image)
    np.testing.assert_array_equal(
        io.read_image(tmp_path / "t.exr"), image.numpy().astype(np.float32)
    )


# -------------------------------------------------------------------------------- atomic writes


def test_failed_write_leaves_old_file_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "out.png"
    io.write_image(path, np.zeros((2, 2, 3)))
    before = path.read_bytes()

    write_bytes = Path.write_bytes

    def broken(self, data):
        write_bytes(self, data[: len(data) // 2])
        raise OSError("disk full")

    monkeypatch.setattr(Path, "write_bytes", broken)
    with pytest.raises(OSError, match="disk full"):
        io.write_image(path, np.ones((2, 2, 3)))
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["out.png"]


def test_atomic_write_keeps_the_suffix_and_replaces_only_on_success(tmp_path):
    path = tmp_path / "sub" / "table.binary"
    seen = []

    def write(tmp):
        seen.append(tmp)
        tmp.write_bytes(b"new")

    assert io.atomic_write(str(path), write) == path
    assert path.read_bytes() == b"new"
    assert seen[0].parent == path.parent and seen[0].suffix == ".binary" and seen[0] != path

    def broken(tmp):
        tmp.write_bytes(b"half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        io.atomic_write(path, broken)
    assert path.read_bytes() == b"new"
    assert sorted(os.listdir(path.parent)) == ["table.binary"]


def test_write_creates_folders_and_overwrites(tmp_path):
    path = tmp_path / "a" / "b" / "c.exr"
    io.write_image(path, np.zeros((2, 2, 3)))
    io.write_image(path, np.ones((2, 2, 3)))
    np.testing.assert_array_equal(io.read_image(path), np.ones((2, 2, 3)))
    assert sorted(os.listdir(path.parent)) == ["c.exr"]


# -------------------------------------------------------------------------------- errors


@pytest.mark.data
@pytest.mark.parametrize("name", ["probulator/grace.hdr", "pbrt/grace_latlong.exr"])
@pytest.mark.parametrize("fraction", [0.01, 0.5, 0.99])
def test_truncated_files_raise_naming_the_file(shared_data, tmp_path, name, fraction):
    source = shared_data / "envmaps" / name
    data = source.read_bytes()
    path = tmp_path / f"cut{source.suffix}"
    path.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(io.ImageReadError, match=str(path)):
        io.read_image(path)


@pytest.mark.parametrize("suffix", [".png", ".hdr", ".exr", ".tga", ".jpg", ".tif"])
def test_text_file_with_image_extension_raises(tmp_path, suffix):
    path = tmp_path / f"notes{suffix}"
    path.write_text("this is not an image\n" * 20)
    with pytest.raises(ValueError, match=str(path)):
        io.read_image(path)


def test_missing_file_is_value_and_file_not_found_error(tmp_path):
    path = tmp_path / "nothing.exr"
    with pytest.raises(io.ImageNotFoundError, match="no such file") as info:
        io.read_image(path)
    assert isinstance(info.value, ValueError) and isinstance(info.value, FileNotFoundError)
    assert str(path) in str(info.value)


def test_unknown_extension_lists_supported(tmp_path):
    with pytest.raises(ValueError, match=r"\.hdr, \.exr, \.png"):
        io.read_image(tmp_path / "a.webp")
    with pytest.raises(ValueError, match=r"\.exr, \.hdr, \.png"):
        io.write_image(tmp_path / "a.jpg", np.zeros((2, 2, 3)))


@pytest.mark.parametrize(
    ("name", "image", "kwargs", "message"),
    [
        ("a.png", np.zeros((2, 2, 2)), {}, "shape"),
        ("a.png", np.zeros(5), {}, "shape"),
        ("a.hdr", np.zeros((2, 2, 4)), {}, "shape"),
        ("a.exr", np.zeros((2, 2, 5)), {}, "shape"),
        ("a.hdr", -np.ones((2, 2, 3)), {}, "non-negative"),
        ("a.png", np.full((2, 2, 3), np.nan), {}, "finite"),
        ("a.png", np.zeros((2, 2, 3)), {"bit_depth": 12}, "bit_depth"),
        ("a.png", np.zeros((2, 2, 3)), {"exposure": np.inf}, "exposure"),
    ],
)
def test_write_rejects_bad_input(tmp_path, name, image, kwargs, message):
    with pytest.raises(ValueError, match=message):
        io.write_image(tmp_path / name, image, **kwargs)
    assert not os.listdir(tmp_path)


@pytest.mark.parametrize("name", ["a.exr", "a.hdr", "a.png"])
@pytest.mark.parametrize(
    ("bad", "exposure", "shown"), [(np.nan, 0.0, "nan"), (np.inf, 0.0, "inf"), (1e300, 100, "inf")]
)
def test_no_output_holds_nan_or_infinity(tmp_path, name, bad, exposure, shown):
    """write_image wrote NaN and infinity into EXR files (and 1e300 at +100 stops overflowed)."""
    from brdfkit.errors import ParameterError

    image = np.full((3, 4, 3), 0.5)
    image[1, 2, 0] = bad
    with pytest.raises(ParameterError, match=rf"a\.{name[2:]}: .* holds {shown} at pixel "):
        io.write_image(tmp_path / name, image, exposure=exposure)
    assert not os.listdir(tmp_path)


def test_nan_marks_missing_pixels_in_exr_only(tmp_path):
    from brdfkit.errors import ParameterError

    depth = np.where(np.eye(3, dtype=bool), np.nan, 2.0)
    path = io.write_image(tmp_path / "depth.exr", depth, nan_marks_missing=True)
    np.testing.assert_array_equal(io.read_image(path)[..., 0], depth.astype(np.float32))
    with pytest.raises(ParameterError, match=r"depth\.png: .* holds nan"):
        io.write_image(tmp_path / "depth.png", depth, nan_marks_missing=True)
    with pytest.raises(ParameterError, match=r"depth\.exr: .* holds -inf"):
        io.write_image(tmp_path / "depth.exr", -np.full((2, 2), np.inf), nan_marks_missing=True)
    assert sorted(os.listdir(tmp_path)) == ["depth.exr"]


def test_half_floats_refuse_values_beyond_their_range(tmp_path):
    from brdfkit.errors import ParameterError

    with pytest.raises(ParameterError, match=r"a\.exr: .*70000.*largest half float"):
        io.write_image(tmp_path / "a.exr", np.full((2, 2), 7e4), half=True)
    assert not os.listdir(tmp_path)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs Linux's /dev/full")
def test_a_short_write_names_the_output(tmp_path):
    """NumPy's short write on a full disk ("32640 requested and 21488 written") is an OSError
    with no errno and no file name: it named nothing."""
    from brdfkit.errors import OutputError

    def short(tmp: Path) -> None:
        with open("/dev/full", "wb") as full:  # a device that is always full
            np.zeros(4080).tofile(full)

    path = tmp_path / "depth.npy"
    with pytest.raises(OutputError, match=r"depth\.npy could not be written: 4080 requested"):
        io.atomic_write(path, short)

    def full(tmp: Path) -> None:
        with open("/dev/full", "wb") as device:
            np.save(device, np.zeros(4080))

    with pytest.raises(OutputError, match=r"depth\.npy could not be written: No space left"):
        io.atomic_write(path, full)
    assert not os.listdir(tmp_path)


def test_a_failure_naming_another_file_keeps_its_name(tmp_path):
    """An input the writer reads is named by its own error, not blamed on the output."""

    def reads_an_input(tmp: Path) -> None:
        tmp.write_bytes((tmp_path / "missing.txt").read_bytes())

    with pytest.raises(FileNotFoundError, match=r"missing\.txt") as raised:
        io.atomic_write(tmp_path / "out.txt", reads_an_input)
    assert type(raised.value) is FileNotFoundError
    assert not os.listdir(tmp_path)


def test_an_output_folder_that_cannot_be_made_is_named(tmp_path):
    from brdfkit.errors import OutputError

    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match=r"file/out\.txt could not be written"):
        io.atomic_write(tmp_path / "file" / "out.txt", lambda tmp: tmp.write_text("y"))


# -------------------------------------------------------------------------------- colour


def test_srgb_matches_colour_science_and_inverts():
    colour = pytest.importorskip("colour")
    x = np.linspace(0.0, 1.5, 30001)
    np.testing.assert_allclose(io.srgb_encode(x), colour.cctf_encoding(x, "sRGB"), atol=1e-12)
    # colour-science decodes linearly up to 1.055·0.0031308^(1/2.4) − 0.055 = 0.0404482, the
    # standard up to 0.04045; between the two the standard's pieces differ by ≤ 2.4e-9.
    gap = abs(0.04045 / 12.92 - ((0.04045 + 0.055) / 1.055) ** 2.4)
    assert gap < 2.4e-9
    np.testing.assert_allclose(io.srgb_decode(x), colour.cctf_decoding(x, "sRGB"), atol=gap)
    outside = (x < 0.0404482) | (x > 0.04045)
    np.testing.assert_allclose(
        io.srgb_decode(x[outside]), colour.cctf_decoding(x[outside], "sRGB"), atol=1e-12
    )
    np.testing.assert_allclose(io.srgb_decode(io.srgb_encode(x)), x, rtol=0, atol=1e-12)
    x32 = x.astype(np.float32)
    roundtrip = io.srgb_decode(io.srgb_encode(x32))
    assert roundtrip.dtype == np.float32
    np.testing.assert_allclose(roundtrip, x32, rtol=0, atol=1e-6)


def test_srgb_clamps_negative_and_is_continuous():
    assert io.srgb_encode(np.array(-0.2)) == 0.0 and io.srgb_decode(np.array(-0.2)) == 0.0
    eps = 1e-12
    for f, b in ((io.srgb_encode, 0.0031308), (io.srgb_decode, 0.04045)):
        assert f(np.array(b - eps)) == pytest.approx(f(np.array(b + eps)), abs=1e-7)


def test_srgb_torch_gradients():
    torch = pytest.importorskip("torch")
    x = torch.tensor([0.0, 0.002, 0.5, 1.0], dtype=torch.float32, requires_grad=True)
    y = io.srgb_encode(x)
    assert y.dtype == torch.float32
    y.sum().backward()
    assert torch.all(torch.isfinite(x.grad))
    np.testing.assert_allclose(x.grad[1].item(), 12.92, rtol=1e-6)
    np.testing.assert_allclose(x.grad[2].item(), 1.055 / 2.4 * 0.5 ** (1 / 2.4 - 1), rtol=1e-5)


def test_luminance_rec709(backend):
    colour = pytest.importorskip("colour")
    rgb = np.random.default_rng(6).random((10, 3))
    result = io.luminance(backend(rgb))
    assert result.shape == (10, 1)
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    y_row = srgb.matrix_RGB_to_XYZ[1]  # the same primaries and white: weights agree to 1e-4
    np.testing.assert_allclose(np.asarray(result)[:, 0], rgb @ y_row, atol=1e-4)
    np.testing.assert_allclose(np.asarray(io.luminance(backend(np.ones(3)))), [1.0], rtol=1e-6)
    with pytest.raises(ValueError, match="rgb"):
        io.luminance(np.ones((4, 2)))


def test_tonemap():
    image = np.array([[0.25, 0.5, 4.0]])
    np.testing.assert_allclose(io.tonemap(image), [[0.25, 0.5, 1.0]])
    np.testing.assert_allclose(io.tonemap(image, exposure=1.0), [[0.5, 1.0, 1.0]])
    bright = np.array([[0.5, 1.0, 1.5]])  # stays below 1 after the operator
    mapped = io.tonemap(bright, method="reinhard")
    lum = io.luminance(bright)
    np.testing.assert_allclose(io.luminance(mapped), lum / (1 + lum))
    np.testing.assert_allclose(mapped / mapped[..., :1], bright / bright[..., :1])  # hue kept
    with pytest.raises(ValueError, match="method"):
        io.tonemap(image, method="filmic")


# -------------------------------------------------------------------------------- data folder


def test_data_path_uses_environment(tmp_path, monkeypatch):
    (tmp_path / "envmaps").mkdir()
    monkeypatch.setenv("BRDFKIT_DATA", str(tmp_path))
    assert io.data_path("envmaps") == tmp_path / "envmaps"
    with pytest.raises(FileNotFoundError, match=r"missing\.hdr"):
        io.data_path("envmaps", "missing.hdr")
    monkeypatch.setenv("BRDFKIT_DATA", str(tmp_path / "nowhere"))
    with pytest.raises(FileNotFoundError, match="BRDFKIT_DATA"):
        io.data_path()


@pytest.mark.data
def test_data_path_default_finds_shared_folder(shared_data, monkeypatch, tmp_path):
    monkeypatch.delenv("BRDFKIT_DATA", raising=False)
    monkeypatch.chdir(tmp_path)  # not beside the data: the repository's location is used
    if not (Path(io.__file__).resolve().parents[3] / "shared" / "data").is_dir():
        pytest.skip("package not installed from a checkout beside shared/data")
    assert io.data_path("envmaps", "probulator", "grace.hdr").samefile(
        shared_data / "envmaps" / "probulator" / "grace.hdr"
    )


@pytest.mark.data
def test_copy_of_real_file_reads(tmp_path, shared_data):
    source = shared_data / "envmaps" / "probulator" / "pisa.hdr"
    copy = tmp_path / "PISA.HDR"  # extensions are case-insensitive
    shutil.copy(source, copy)
    np.testing.assert_array_equal(io.read_image(copy), io.read_image(source))


# -------------------------------------------------------------------------------- hostile paths


@pytest.mark.parametrize("suffix", [".png", ".hdr", ".exr"])
def test_non_utf8_paths_round_trip(tmp_path, suffix):
    """A name that is not valid UTF-8 never reaches a native library (it crashed OpenCV)."""
    folder = tmp_path / os.fsdecode(b"\xff\xfe-folder")
    path = folder / os.fsdecode(b"image-\xff" + suffix.encode())
    image = np.full((3, 4, 3), 0.25, np.float32)
    io.write_image(path, image, srgb=False)
    np.testing.assert_allclose(io.read_image(path), image, rtol=0.02, atol=2 / 255)
    assert os.listdir(os.fsencode(folder)) == [os.fsencode(path.name)]


def test_written_files_follow_the_umask(tmp_path):
    """Not mkstemp's 0600: the atlas's page and every output can be served and shared."""
    previous = os.umask(0o022)
    try:
        io.write_image(tmp_path / "a.png", np.zeros((2, 2, 3)))
        io.atomic_write(tmp_path / "b.txt", lambda tmp: tmp.write_text("x"))
    finally:
        os.umask(previous)
    for name in ("a.png", "b.txt"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o644


def _png_header(width: int, height: int) -> bytes:
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(b"\0" * 16))
        + chunk(b"IEND", b"")
    )


@pytest.mark.parametrize(
    ("name", "data"),
    [
        ("huge.png", _png_header(100_000, 100_000)),
        ("huge.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n" + bytes(64)),
    ],
)
def test_header_beyond_the_pixel_limit_is_an_image_read_error(tmp_path, name, data):
    """OpenCV's pixel limit raised a raw cv2.error out of read_image."""
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(io.ImageReadError, match=name.replace(".", r"\.")):
        io.read_image(path)


def _exr_declaring(tmp_path: Path, width: int, height: int) -> bytes:
    """A small EXR whose dataWindow is rewritten to ``width`` × ``height``."""
    import struct

    io.write_image(tmp_path / "small.exr", np.ones((2, 2, 3), np.float32))
    data = (tmp_path / "small.exr").read_bytes()
    at = data.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    return data[:at] + struct.pack("<4i", 0, 0, width - 1, height - 1) + data[at + 16 :]


@pytest.mark.parametrize(
    ("name", "declared"),
    [
        ("bomb.png", lambda tmp: _png_header(20_000, 20_000)),  # Pillow's own limit
        ("big.png", lambda tmp: _png_header(12_000, 12_000)),
        ("bomb.hdr", lambda tmp: b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 20000 +X 20000\n"),
        ("bomb.exr", lambda tmp: _exr_declaring(tmp, 20_000, 20_000)),
    ],
)
def test_an_image_bomb_is_refused_before_decoding_naming_the_file(
    tmp_path, monkeypatch, name, declared
):
    """A 1.2 MB PNG declaring 20000 × 20000 pixels was decoded (10.4 GB) before any refusal."""
    from brdfkit.errors import ResourceError

    path = tmp_path / name
    path.write_bytes(declared(tmp_path))

    def never(path, data):
        raise AssertionError("decoded")

    monkeypatch.setitem(io._READERS, path.suffix, never)
    with pytest.raises(io.ImageTooLargeError, match=f"{name}.*MAX_IMAGE_PIXELS") as info:
        io.read_image(path)
    assert isinstance(info.value, ResourceError)


def test_an_image_beyond_the_memory_available_is_refused(tmp_path, monkeypatch):
    import brdfkit._checks

    monkeypatch.setattr(brdfkit._checks, "available_memory", lambda: 1000)
    path = tmp_path / "photo.png"
    path.write_bytes(_png_header(100, 100))
    with pytest.raises(io.ImageTooLargeError, match=r"photo\.png: decoding its 100 × 100 × 3"):
        io.read_image(path)


@pytest.mark.data
def test_truncated_exr_prints_nothing(shared_data, tmp_path, capfd):
    """OpenEXR's own diagnostics (30+ lines) are captured; the error says it in one line."""
    data = (shared_data / "envmaps" / "pbrt" / "grace_latlong.exr").read_bytes()
    path = tmp_path / "cut.exr"
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(io.ImageReadError) as info:
        io.read_image(path)
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    assert "\n" not in str(info.value) and "cut.exr" in str(info.value)


def test_reader_errors_are_format_errors(tmp_path):
    from brdfkit.errors import FormatError

    path = tmp_path / "x.png"
    path.write_bytes(b"\x89PNG garbage")
    with pytest.raises(FormatError):
        io.read_image(path)
