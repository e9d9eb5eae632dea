"""Fuzzing the image readers: mutated PNG, Radiance HDR, OpenEXR, TGA, TIFF and JPEG files.

Seeds are small images written here in every layout the readers meet (8/16-bit, grey, RGB,
RGBA) and, when the shared data is present, real light probes and photometric-stereo images.
A mutated file must read as a float32 (H, W, C) image or raise an ImageReadError.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from _fuzzing import fuzz_settings, mutated, run_case
from hypothesis import given
from hypothesis import strategies as st

from brdfkit.io import data_path, read_image, write_image


def _written(suffix: str) -> list[bytes]:
    """Small images of each layout, written by brdfkit itself (PNG, HDR, EXR) or Pillow."""
    rng = np.random.default_rng(0)
    seeds = []
    with tempfile.TemporaryDirectory() as folder:
        for channels in (1, 3) if suffix in (".hdr", ".jpg") else (1, 3, 4):
            image = rng.uniform(0, 1, (5, 7, channels)).astype(np.float32)
            path = Path(folder) / f"seed{channels}{suffix}"
            if suffix in (".png", ".hdr", ".exr"):
                write_image(path, image, srgb=False)
                seeds.append(path.read_bytes())
                if suffix == ".png":
                    write_image(path, image, srgb=False, bit_depth=16)
                    seeds.append(path.read_bytes())
            else:
                import imageio.v3 as iio

                codes = (image * 255).astype(np.uint8)
                iio.imwrite(path, codes[..., 0] if channels == 1 else codes, plugin="pillow")
                seeds.append(path.read_bytes())
    return seeds


def _real(*parts: str) -> list[bytes]:
    try:
        return [data_path(*parts).read_bytes()]
    except FileNotFoundError:
        return []


SEEDS = {
    ".png": _written(".png"),
    ".hdr": _written(".hdr") + _real("envmaps", "probulator", "pisa.hdr"),
    ".exr": _written(".exr"),
    ".tga": _written(".tga") + _real("photometric_stereo", "psm", "gray", "gray.0.tga"),
    ".tif": _written(".tif"),
    ".jpg": _written(".jpg"),
}


def _read(data: bytes, suffix: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"fuzzed{suffix}"
        path.write_bytes(data)
        image = run_case(suffix.lstrip("."), read_image, path)
    if image is not None:
        assert image.dtype == np.float32 and image.ndim == 3 and image.shape[-1] in (1, 2, 3, 4)


@pytest.mark.parametrize("suffix", sorted(SEEDS))
def test_image_readers_take_any_bytes(suffix):
    @fuzz_settings(ci_cases=120)
    @given(data=mutated(SEEDS[suffix]))
    def check(data: bytes) -> None:
        _read(data, suffix)

    check()


@fuzz_settings(ci_cases=60)
@given(data=st.binary(max_size=256), suffix=st.sampled_from(sorted(SEEDS)))
def test_image_readers_take_random_bytes(data, suffix):
    _read(data, suffix)


def _declaring(data: bytes, suffix: str, width: int, height: int) -> bytes:
    """A seed with the size its header declares rewritten to ``width`` × ``height``."""
    import struct
    import zlib

    if suffix == ".png":
        ihdr = data[12:16] + struct.pack(">II", width, height) + data[24:29]
        crc = struct.pack(">I", zlib.crc32(ihdr) & 0xFFFFFFFF)
        return data[:12] + ihdr + crc + data[33:]
    if suffix == ".hdr":
        head, _, rest = data.partition(b"\n\n")
        return (
            head + b"\n\n" + f"-Y {height} +X {width}".encode() + b"\n" + rest.partition(b"\n")[2]
        )
    key = b"dataWindow\0box2i\0"
    at = data.index(key) + len(key) + 4
    return data[:at] + struct.pack("<4i", 0, 0, width - 1, height - 1) + data[at + 16 :]


_SIDES = st.one_of(st.integers(1, 64), st.integers(12_000, 2**31 - 1))
"""Sides small enough to decode at once, or large enough that no image of them is read."""


@pytest.mark.parametrize("suffix", [".png", ".hdr", ".exr"])
def test_image_headers_declaring_any_size(suffix):
    """A header declaring a huge image is refused before decoding (ImageTooLargeError); one
    declaring a small image reads or raises a documented error."""
    from brdfkit.io import MAX_IMAGE_PIXELS, ImageReadError, ImageTooLargeError

    # OpenEXR refuses some such headers itself (an offset table it cannot hold), unread
    refused = ImageReadError if suffix == ".exr" else ImageTooLargeError

    @fuzz_settings(ci_cases=40)
    @given(seed=st.sampled_from(SEEDS[suffix][:2]), width=_SIDES, height=_SIDES)
    def check(seed: bytes, width: int, height: int) -> None:
        data = _declaring(seed, suffix, width, height)
        if width * height <= MAX_IMAGE_PIXELS:
            _read(data, suffix)
            return
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / f"declared{suffix}"
            path.write_bytes(data)
            with pytest.raises(refused, match="declared"):
                read_image(path)

    check()
