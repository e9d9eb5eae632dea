"""``brdfkit render MESH``: the library's render, written atomically; bad input is one line."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.io import read_image
from brdfkit.light import DirectionalLight, EnvironmentMap
from brdfkit.render.mesh import MeshScene, render_mesh, torus_over_plane
from brdfkit.render.mitsuba_frame import look_at_camera, mitsuba_oriented

pytest.importorskip("embreex", reason="embreex (the mesh extra) is not installed")

runner = CliRunner()
LOOK_AT = "0,2.2,3.2:0,0.4,0:0,1,0"
MODEL = "ggx(alpha=0.3, material='Au')"


def _invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def _one_error_line(result, *fragments: str) -> None:
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("mesh") / "scene.ply"
    torus_over_plane(sections=16).export(path, vertex_normal=True)
    return path


def test_the_command_writes_the_librarys_render(scene_file, tmp_path, shared_data):
    envmap = shared_data / "envmaps" / "probulator" / "grace.hdr"
    out = tmp_path / "torus.exr"
    result = _invoke(
        "render", scene_file, "-b", MODEL, "-l", f"envmap:{envmap}", "-l",
        "directional:0.5,1,0.3:3", "--look-at", LOOK_AT, "--fov", 40, "--size", "16x12",
        "-s", 4, "--supersample", 2, "-o", out,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    camera = look_at_camera((0, 2.2, 3.2), (0, 0.4, 0), (0, 1, 0), fov=40, size=(12, 16))
    lights = [
        mitsuba_oriented(EnvironmentMap.from_file(envmap)),
        DirectionalLight((0.5, 1, 0.3), irradiance=3.0),
    ]
    expected = render_mesh(
        MeshScene.from_file(scene_file), parse(MODEL), lights, camera, (12, 16),
        supersample=2, samples=4,
    )  # fmt: skip
    image = read_image(out)
    assert image.shape == (12, 16, 3)
    assert np.count_nonzero(image) > 100
    assert np.allclose(image, expected, rtol=1e-6, atol=1e-7)


def test_the_mesh_is_never_overwritten(scene_file):
    before = scene_file.read_bytes()
    result = _invoke("render", scene_file, "-o", scene_file.with_suffix(".png"), "-r", 8)
    assert result.exit_code == 0, result.output
    _one_error_line(_invoke("render", scene_file, "-o", scene_file), "scene.ply")
    assert scene_file.read_bytes() == before


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--look-at", "0,2:0,0,0:0,1,0"], "--look-at"),
        (["--look-at", "0,0,0:0,0,0:0,1,0"], "--look-at"),
        (["--fov", "180"], "fov"),
        (["--size", "64"], "--size"),
    ],
)
def test_bad_camera_options_are_one_line(scene_file, tmp_path, args, fragment):
    out = tmp_path / "x.png"
    _one_error_line(_invoke("render", scene_file, *args, "-o", out), fragment)
    assert not out.exists()


def test_camera_options_need_a_mesh(tmp_path):
    _one_error_line(_invoke("render", "sphere", "--fov", 30, "-o", tmp_path / "x.png"), "mesh")


def test_a_missing_or_broken_mesh_is_one_line(tmp_path):
    _one_error_line(_invoke("render", tmp_path / "none.obj", "-o", tmp_path / "x.png"), "none.obj")
    broken = tmp_path / "broken.ply"
    broken.write_text("garbage")
    _one_error_line(_invoke("render", broken, "-o", tmp_path / "x.png"), "broken.ply")
