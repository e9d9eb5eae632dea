"""``brdfkit render bundled:NAME``: the library's render of a bundled mesh; a bad name is one
line."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.io import read_image
from brdfkit.light import DirectionalLight
from brdfkit.render.bundled_meshes import load_mesh
from brdfkit.render.mesh import render_mesh
from brdfkit.render.mitsuba_frame import look_at_camera

pytest.importorskip("embreex", reason="embreex (the mesh extra) is not installed")

runner = CliRunner()


def test_a_bundled_mesh_renders_as_the_library_does(tmp_path):
    out = tmp_path / "knot.exr"
    result = runner.invoke(
        app,
        ["render", "bundled:knot", "-b", "lambertian(albedo=0.5)", "-l", "directional:0.3,1,0.2:3",
         "--look-at", "0,2,3:0,0.5,0:0,1,0", "--fov", "40", "--size", "16x12", "-s", "1",
         "-o", str(out)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    camera = look_at_camera((0, 2, 3), (0, 0.5, 0), (0, 1, 0), fov=40, size=(12, 16))
    light = DirectionalLight((0.3, 1, 0.2), irradiance=3.0)
    expected = render_mesh(
        load_mesh("bundled:knot"), parse("lambertian(albedo=0.5)"), light, camera, (12, 16),
        samples=1,
    )  # fmt: skip
    image = read_image(out)
    assert np.count_nonzero(image) > 100
    assert np.allclose(image, expected, rtol=1e-6, atol=1e-7)


def test_an_unknown_bundled_name_is_one_line(tmp_path):
    result = runner.invoke(app, ["render", "bundled:teapot", "-o", str(tmp_path / "x.png")])
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and "knot, shaderball" in lines[0] and "teapot" in lines[0]
    assert not (tmp_path / "x.png").exists()
