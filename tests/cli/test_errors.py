"""How the command line reports bad input: one line on stderr, exit 2, no traceback, no markup.

Regression tests for the defects the command line itself owned.
"""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.io import read_image, write_image

runner = CliRunner()


def _invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def _one_error_line(result, *fragments: str) -> str:
    """The result is exit 2 with exactly one ``error:`` line on stderr and nothing on stdout."""
    assert result.exit_code == 2, result.output
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    return lines[0]


@pytest.mark.parametrize("spec", ["[/]", "[bold]lambertian", "lambertian(albedo=[/])"])
def test_user_text_is_never_read_as_markup(spec):
    _one_error_line(_invoke("check", spec), spec)


def test_a_path_keeps_its_brackets_in_the_error(tmp_path):
    path = tmp_path / "[bold]paint.binary"
    _one_error_line(_invoke("fit", path), "[bold]paint.binary")


def test_json_output_holds_no_error(tmp_path):
    result = _invoke("check", "lambertian(albedo=2)", "--json")
    _one_error_line(result, "rho")


def test_long_errors_are_not_wrapped(tmp_path):
    path = tmp_path / ("a-rather-long-folder-name-" * 6) / "missing.binary"
    line = _one_error_line(_invoke("fit", path), "missing.binary")
    assert len(line) > 120


def test_an_internal_error_is_not_a_failed_check(monkeypatch):
    import brdfkit.checks.properties

    def broken(*args, **kwargs):
        raise RuntimeError("a bug")

    monkeypatch.setattr(brdfkit.checks.properties, "check", broken)
    result = _invoke("check", "lambertian")
    assert result.exit_code == 3
    assert result.stderr.startswith("internal error: RuntimeError: a bug")


@pytest.mark.parametrize(
    ("args", "option"),
    [
        (("solid-angle", "disk", "--order", "100000"), "--order"),
        (("lighting", "x.exr", "-m", "mirror-ball", "--height", "100000"), "--height"),
        (("render", "-r", "100000"), "--resolution"),
        (("plot", "lobe", "lambertian", "-r", "100000"), "--resolution"),
        (("render", "-s", "10000000"), "--samples"),
        (("fit", "x.binary", "--starts", "1000"), "--starts"),
        (("ps", "x", "--step", "1000"), "--step"),
    ],
)
def test_size_options_have_a_maximum(args, option):
    _one_error_line(_invoke(*args), option)


@pytest.mark.parametrize(
    "spec", ["ggx(alpha=1e308)", "blinn_phong(n=1e308)", "torrance_sparrow(m=1e-320)"]
)
def test_parameters_that_would_evaluate_to_nan_are_refused(tmp_path, spec):
    out = tmp_path / "out.exr"
    _one_error_line(_invoke("render", "-r", "8", "-s", "1", "-b", spec, "-o", out))
    assert not out.exists()


def _sphere(tmp_path):
    from brdfkit.render import Sphere, gbuffer

    g = gbuffer(Sphere(), None, 16)
    image = np.repeat((g.normals[..., 2:] * g.mask[..., None]).clip(0, None), 3, axis=-1)
    write_image(tmp_path / "sphere.exr", image.astype(np.float32))
    np.save(tmp_path / "normals.npy", g.normals)
    return tmp_path / "sphere.exr", tmp_path / "normals.npy"


def test_lighting_refuses_a_nan_albedo(tmp_path):
    image, normals = _sphere(tmp_path)
    out = tmp_path / "light.json"
    _one_error_line(_invoke("lighting", image, "--normals", normals, "--albedo", "nan", "-o", out))
    assert not out.exists()


@pytest.mark.parametrize("content", [b"\x80\x03]q\x00.", b"\x93NUMPY\x01\x00v\x00{'descr"])
def test_a_pickled_or_truncated_normals_file_is_one_error(tmp_path, content):
    image, _ = _sphere(tmp_path)
    normals = tmp_path / "bad.npy"
    normals.write_bytes(content)
    _one_error_line(_invoke("lighting", image, "--normals", normals), "bad.npy")


def test_a_truncated_exr_is_one_line(tmp_path):
    image, normals = _sphere(tmp_path)
    data = image.read_bytes()
    image.write_bytes(data[: len(data) // 2])
    _one_error_line(_invoke("lighting", image, "--normals", normals), "sphere.exr")


def test_a_corrupt_png_prints_no_opencv_lines(tmp_path):
    image, normals = _sphere(tmp_path)
    mask = tmp_path / "mask.png"
    mask.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\x00" * 40)
    _one_error_line(_invoke("lighting", image, "--normals", normals, "--mask", mask), "mask.png")


def test_fit_refuses_an_unknown_fixed_parameter(tmp_path):
    from brdfkit.brdf import Lambertian
    from brdfkit.measured import write_merl

    path = tmp_path / "grey.binary"
    write_merl(path, Lambertian(0.5))
    _one_error_line(
        _invoke("fit", path, "--model", "lambertian", "--fix", "roughness"), "roughness"
    )


def test_hdr_with_pixels_never_well_exposed_writes_no_nan(tmp_path):
    """~1 % of the pixels are saturated in every exposure: they take the nearest exposure (and
    the fallback mask), and nothing in the merge, the response or the mask is NaN."""
    rng = np.random.default_rng(3)
    radiance = rng.uniform(0.02, 0.2, (40, 40, 3))
    radiance[:4, :4] = 1e3  # 16 of 1600 pixels: 1 %
    paths, times = [], (1.0, 2.0, 4.0, 8.0)
    for k, t in enumerate(times):
        paths.append(tmp_path / f"e{k}.png")
        write_image(paths[-1], np.clip(radiance * t, 0, 1), srgb=False)
    out, csv, mask = tmp_path / "merged.exr", tmp_path / "g.csv", tmp_path / "fallback.png"
    result = _invoke(
        "hdr", *paths, "--times", ",".join(map(str, times)), "-o", out, "--response", csv,
        "--fallback-mask", mask,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "16 pixel(s)" in result.stdout
    assert np.isfinite(read_image(out)).all()
    assert np.isfinite(np.loadtxt(csv, delimiter=",")).all()
    fell_back = read_image(mask)[..., 0] > 0.5
    assert fell_back.sum() == 16 and fell_back[:4, :4].all()


def test_no_runtime_warning_reaches_the_terminal(tmp_path):
    result = _invoke("render", "-r", "8", "-s", "1", "-b", "ggx(alpha=0.001)", "-o",
                     tmp_path / "r.png", "-l", "directional:0,0,1")  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "Warning" not in result.output


def test_a_result_holding_nan_is_refused_in_one_line(monkeypatch):
    """``fit --json`` of a degenerate input failed with "Out of range float values are not JSON
    compliant: inf" and wrote that as the whole story."""
    import json

    import brdfkit.checks.properties

    def degenerate(*args, **kwargs):
        return json.dumps({"rmse": float("inf")}, allow_nan=False)

    monkeypatch.setattr(brdfkit.checks.properties, "check", degenerate)
    _one_error_line(_invoke("check", "lambertian"), "the result holds", "nothing was written")
