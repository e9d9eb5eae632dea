"""``brdfkit ps`` writes its measures as metrics.json and runs the non-Lambertian methods."""

from __future__ import annotations

import json

import numpy as np
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.vision import bivariate_stereo, datasets
from brdfkit.vision.photometric_stereo import sphere_normals

runner = CliRunner()


def test_metrics_json_and_a_nonlambertian_method(tmp_path):
    normals, mask = sphere_normals((30, 36), (17.5, 14.5), 12.0)
    lights = datasets.diligent_like_lights(6, 4, np.radians(35))
    data = datasets.render_synthetic(
        normals, mask, lights, albedo=[0.7, 0.5, 0.3], specular=0.8, shininess=40.0
    )
    datasets.save_diligent(data, tmp_path / "ballPNG")
    out = tmp_path / "out"
    args = ["ps", str(tmp_path / "ballPNG"), "-m", "bipolynomial", "-o", str(out), "--json"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    printed = json.loads(result.output)
    written = json.loads((out / "metrics.json").read_text(encoding="utf-8"))
    assert "metrics.json" in printed["files"]
    # The file holds the measures: what --json prints, less where the files went.
    assert written == {k: v for k, v in printed.items() if k not in ("output", "files")}
    loaded = datasets.load_diligent(tmp_path / "ballPNG")
    expected = bivariate_stereo.bipolynomial(loaded.images, loaded.light_directions, loaded.mask)
    np.testing.assert_allclose(np.load(out / "normals.npy"), expected.normals)
    assert written["method"] == "bipolynomial"
    assert written["angular_error_deg"]["mean"] < 2.0
    # A second run replaces the files it wrote (the manifest knows them).
    again = runner.invoke(app, [*args[:-1]])
    assert again.exit_code == 0, again.output
    assert "mean angular error" in again.output
