"""``brdfkit fit``: a table on the console, and fit.json + side-by-side spheres with -o."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.io import read_image

runner = CliRunner()


@pytest.mark.slow
def test_fit_a_cornell_file_and_write_outputs(shared_data, tmp_path):
    path = shared_data / "measured" / "cornell" / "garnet_red.brdf"
    out = tmp_path / "garnet"
    result = runner.invoke(
        app,
        [
            "fit",
            str(path),
            "--model",
            "lambertian + ward",
            "--starts",
            "1",
            "-o",
            str(out),
            "-r",
            "32",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "1.ward.alpha_x" in result.output and "cosine_rmse" in result.output
    record = json.loads((out / "fit.json").read_text())
    model = parse(record["spec"])  # the spec is usable everywhere else
    assert model.lobes[1].alpha_x == record["params"]["1.ward.alpha_x"]
    assert record["errors"]["cosine_rmse"] > 0 and record["samples"] > 1000
    assert record["loss"] == "soft_l1" and record["loss_scale"] > 0
    image = read_image(out / "spheres.png")
    assert image.shape[:2] == (32, 64)  # measured | fitted
    left, right = image[:, :32, :3], image[:, 32:, :3]
    assert left.max() > 0 and right.max() > 0
    # both spheres are red: garnet
    assert left[..., 0].sum() > left[..., 2].sum() and right[..., 0].sum() > right[..., 2].sum()
    assert not list(tmp_path.glob(".garnet*"))  # no temporary left behind


def test_bad_inputs_fail_cleanly(tmp_path):
    missing = runner.invoke(app, ["fit", str(tmp_path / "nope.binary")])
    assert missing.exit_code == 2 and "does not exist" in " ".join(missing.output.split())
    other = tmp_path / "x.txt"
    other.write_text("1")
    wrong = runner.invoke(app, ["fit", str(other)])
    assert wrong.exit_code == 2 and ".binary" in wrong.output
    bad = tmp_path / "bad.binary"
    bad.write_bytes(np.array([1, 2, 3], "<i4").tobytes())
    header = runner.invoke(app, ["fit", str(bad)])
    assert header.exit_code == 2 and "header dimensions" in " ".join(header.output.split())
