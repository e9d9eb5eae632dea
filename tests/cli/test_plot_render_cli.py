"""``brdfkit plot`` and ``brdfkit render`` write real images and reject bad input."""

from __future__ import annotations

import numpy as np
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.io import read_image

runner = CliRunner()


def test_plot_writes_png_and_svg(tmp_path):
    out = tmp_path / "lobe.svg"
    result = runner.invoke(app, ["plot", "lobe", "ward(alpha_x=0.1)", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text().startswith("<?xml")
    out = tmp_path / "albedo.png"
    result = runner.invoke(app, ["plot", "albedo", "lambertian", "phong(n=20)", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert read_image(out).shape[2] >= 3


def test_plot_and_render_errors_name_the_problem(tmp_path):
    result = runner.invoke(app, ["plot", "pie", "lambertian", "-o", str(tmp_path / "x.png")])
    assert result.exit_code == 2 and "kind must be one of" in result.output
    result = runner.invoke(
        app, ["render", "sphere", "--brdf", "nope", "-o", str(tmp_path / "x.png")]
    )
    assert result.exit_code == 2 and "unknown model 'nope'" in result.output
    result = runner.invoke(
        app, ["render", "sphere", "-l", "laser:1", "-o", str(tmp_path / "x.png")]
    )
    assert result.exit_code == 2 and "unknown kind 'laser'" in result.output
    assert not list(tmp_path.iterdir())


def test_render_directional_lambertian_matches_closed_form(tmp_path):
    out = tmp_path / "s.exr"
    args = [
        "render",
        "sphere",
        "--brdf",
        "lambertian(albedo=1)",
        "-l",
        "directional:1,0,0:3.14159265358979",
    ]
    result = runner.invoke(app, [*args, "-r", "32", "-o", str(out)])
    assert result.exit_code == 0, result.output
    image = read_image(out)
    from brdfkit.render import Sphere, gbuffer

    g = gbuffer(Sphere(), None, 32)
    np.testing.assert_allclose(
        image[..., 0], np.clip(g.normals[..., 0], 0, None) * g.mask, atol=1e-5
    )


def test_render_under_the_bundled_environment_map(tmp_path):
    out = tmp_path / "s.png"
    result = runner.invoke(app, ["render", "sphere", "-r", "24", "-s", "8", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert read_image(out).mean() > 0.05
