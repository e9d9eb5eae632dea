"""Degenerate and hostile inputs through the command line: each refused before any work, with
one error line naming the file or argument, exit 2 and no output written."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.io import write_image

runner = CliRunner()


def _refused(result, *fragments: str) -> str:
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    return lines[0]


def _exposures(folder, times=(1, 2, 4)) -> list[str]:
    base = np.random.default_rng(0).uniform(0.05, 0.3, (12, 12, 3))
    paths = []
    for k, t in enumerate(times):
        path = folder / f"exposure{k}.png"
        write_image(path, np.clip(base * t, 0, 1), srgb=False)
        paths.append(str(path))
    return paths


def test_hdr_refuses_equal_times_for_differing_images(tmp_path):
    """``hdr -t 1,1,1`` on three different exposures wrote a constant image and exited 0."""
    out = tmp_path / "merged.exr"
    result = runner.invoke(app, ["hdr", *_exposures(tmp_path), "-t", "1,1,1", "-o", str(out)])
    _refused(result, "times", "differ")
    assert not out.exists()


def _png_declaring(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IEND", b"")


def test_hdr_refuses_a_png_bomb_naming_it(tmp_path):
    """A 20000 × 20000 PNG was decoded (10.4 GB) and the error blamed "a smaller size option"."""
    images = _exposures(tmp_path)
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_declaring(20_000, 20_000))
    out = tmp_path / "merged.exr"
    result = runner.invoke(app, ["hdr", *images[:2], str(bomb), "-t", "1,2,4", "-o", str(out)])
    _refused(result, "bomb.png", "MAX_IMAGE_PIXELS")
    assert not out.exists()


def test_an_environment_map_holding_nan_is_refused_naming_it(tmp_path):
    """A NaN or negative EXR map gave "image must hold finite, non-negative radiance values"
    without the file."""
    from brdfkit.errors import FormatError
    from brdfkit.light.environment import EnvironmentMap

    image = np.ones((4, 8, 3), np.float32)
    image[1, 2, 0] = np.nan
    path = tmp_path / "sky.exr"
    write_image(path, image, nan_marks_missing=True)  # as a file made elsewhere may hold
    with pytest.raises(FormatError, match=r"sky\.exr.*NaN"):
        EnvironmentMap.from_file(path)
