"""``brdfkit hdr --method``: every calibration method merges a stack; bad choices exit 2."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.io import read_image
from brdfkit.vision.response import METHODS

runner = CliRunner()
TIMES = [1 / 64, 1 / 16, 1 / 4, 1.0, 4.0]


@pytest.fixture(scope="module")
def exposures(tmp_path_factory):
    """A gamma-2.2 stack of 40 × 40 log-uniform radiances, as 8-bit PNGs."""
    cv2 = pytest.importorskip("cv2")
    folder = tmp_path_factory.mktemp("stack")
    radiance = np.exp(np.random.default_rng(3).uniform(-3, 3, (40, 40, 3)))
    paths = []
    for k, t in enumerate(TIMES):
        codes = np.round(255 * np.clip(radiance * t, 0, 1) ** (1 / 2.2)).astype(np.uint8)
        paths.append(folder / f"e{k}.png")
        cv2.imwrite(str(paths[-1]), codes[..., ::-1])
    return radiance, paths


@pytest.mark.parametrize("method", METHODS)
def test_every_method_merges_the_stack(exposures, tmp_path, method):
    radiance, paths = exposures
    out = tmp_path / "merged.exr"
    args = ["hdr", *map(str, paths), "--times", ",".join(map(str, TIMES)), "-o", str(out),
            "--method", method, "--samples", "1000"]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    ratio = np.log(read_image(out).astype(np.float64) / radiance)
    assert np.std(ratio) < 0.05  # radiance up to one global scale


def test_an_unknown_method_or_contradicting_times_exit_2(exposures, tmp_path):
    _, paths = exposures
    out = tmp_path / "bad.exr"
    times = ",".join(map(str, TIMES))
    result = runner.invoke(app, ["hdr", *map(str, paths), "--times", times, "-o", str(out),
                                 "--method", "gsolve"])  # fmt: skip
    assert result.exit_code == 2 and "--method" in result.output
    same = ",".join(map(str, [TIMES[0], TIMES[0], *TIMES[2:]]))
    result = runner.invoke(app, ["hdr", *map(str, paths), "--times", same, "-o", str(out)])
    assert result.exit_code == 2 and "same exposure time" in result.output
    assert not out.exists()


def test_exposure_times_from_exif(exposures, tmp_path):
    """JPEGs that record their exposure times need no --times: the merge matches the one
    with the times given; a photo without the tag is named and nothing is written."""
    from PIL import Image

    from brdfkit.vision.calibration import read_exposure_time

    _, paths = exposures
    jpegs = []
    for k, (path, seconds) in enumerate(zip(paths, TIMES, strict=True)):
        exif = Image.Exif()
        exif.get_ifd(0x8769)[0x829A] = seconds
        jpegs.append(tmp_path / f"e{k}.jpg")
        Image.open(path).save(jpegs[-1], quality=100, exif=exif)
        assert read_exposure_time(jpegs[-1]) == pytest.approx(seconds)
    read, given = tmp_path / "read.exr", tmp_path / "given.exr"
    result = runner.invoke(app, ["hdr", *map(str, jpegs), "-o", str(read)])
    assert result.exit_code == 0, result.output
    times = ",".join(map(str, TIMES))
    assert (
        runner.invoke(app, ["hdr", *map(str, jpegs), "-t", times, "-o", str(given)]).exit_code == 0
    )
    np.testing.assert_allclose(read_image(read), read_image(given), rtol=1e-6)
    Image.open(paths[2]).save(jpegs[2], quality=100)  # no Exif
    assert read_exposure_time(jpegs[2]) is None
    out = tmp_path / "missing.exr"
    result = runner.invoke(app, ["hdr", *map(str, jpegs), "-o", str(out)])
    assert result.exit_code != 0 and "e2.jpg records no exposure time" in result.output
    assert not out.exists()
