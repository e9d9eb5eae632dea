"""Tests of ``brdfkit solid-angle``: printed values agree with the library and the closed forms,
bad input exits with status 2 and a message."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit import radiometry as rad
from brdfkit.cli import app

runner = CliRunner()


def invoke(*args: str):
    return runner.invoke(app, ["solid-angle", *args], env={"COLUMNS": "160"})


def numbers(text: str) -> list[float]:
    """The ten-decimal numbers printed in the table, in order."""
    return [float(x) for x in re.findall(r"-?\d+\.\d{10}\b", text)]


def difference(text: str) -> float:
    return float(re.search(r"\|numerical − exact\| = ([0-9.e+-]+)", text).group(1))


def test_disk_on_axis_prints_closed_form_fraction_and_cross_check():
    result = invoke("disk", "--radius", "1", "--distance", "2")
    assert result.exit_code == 0, result.output
    expected = 2 * math.pi * (1 - 2 / math.sqrt(5))
    # rows: rim contour, on-axis closed form, numerical integral; columns: Ω and Ω/2π
    values = numbers(result.output)
    assert len(values) == 6
    for omega, fraction in zip(values[::2], values[1::2], strict=True):
        assert omega == pytest.approx(expected, abs=1e-9)
        assert fraction == pytest.approx(expected / (2 * math.pi), abs=1e-9)
    assert difference(result.output) < 1e-10


def test_rectangle_off_axis_matches_library():
    result = invoke("rectangle", "--width", "2", "--height", "1", "--distance", "0.5")
    assert result.exit_code == 0, result.output
    exact = rad.solid_angle_rectangle([-1, -0.5, 0], [2, 0, 0], [0, 1, 0], [0.0, 0.0, 0.5])
    # on the axis of a w × h rectangle: Ω = 4 asin(ab / √((a² + d²)(b² + d²))), a, b half-sides
    assert exact == pytest.approx(4 * math.asin(0.5 / math.sqrt(1.25 * 0.5)), rel=1e-12)
    values = numbers(result.output)
    assert values[0] == pytest.approx(exact, abs=1e-9)
    assert values[2] == pytest.approx(exact, abs=1e-4)  # the numerical integral
    result = invoke("rectangle", "--distance", "0.7", "--offset", "1.3")
    exact = rad.solid_angle_rectangle([-0.5, -0.5, 0], [1, 0, 0], [0, 1, 0], [1.3, 0.0, 0.7])
    assert numbers(result.output)[0] == pytest.approx(exact, abs=1e-9)


def test_triangle_with_vertices():
    vertices = "0,0,0;1,0,0;0,1,0"
    result = invoke("triangle", "--vertices", vertices, "--distance", "1", "--offset", "0.2")
    assert result.exit_code == 0, result.output
    exact = rad.solid_angle_triangle(
        np.zeros(3), np.array([1.0, 0, 0]), np.array([0.0, 1, 0]), np.array([0.2, 0, 1])
    )
    values = numbers(result.output)
    assert values[0] == pytest.approx(exact, abs=1e-9)
    assert values[2] == pytest.approx(exact, abs=1e-4)


@pytest.mark.parametrize(("degrees", "expected"), [(90.0, 2 * math.pi), (180.0, 4 * math.pi)])
def test_cap_hemisphere_and_sphere(degrees, expected):
    result = invoke("cap", "--half-angle", str(degrees))
    assert result.exit_code == 0, result.output
    values = numbers(result.output)
    assert values[0] == pytest.approx(expected, abs=1e-9)
    assert values[1] == pytest.approx(expected / (2 * math.pi), abs=1e-9)
    assert values[2] == pytest.approx(expected, abs=1e-6)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("disk", "--radius", "-1"), "radius must be in (0.0, inf]; got -1"),
        (("disk", "--distance", "0"), "must not lie on the disk"),
        (("triangle", "--vertices", "0,0,0;1,0"), "--vertices"),
        (("triangle", "--distance", "0"), "must not lie on the triangle"),
        (("cap", "--half-angle", "200"), "--half-angle"),
        (("rectangle", "--order", "0"), "--order"),
    ],
)
def test_bad_input_exits_with_status_2(args, message):
    result = invoke(*args)
    assert result.exit_code == 2
    assert message in " ".join(result.output.split())


def test_unknown_shape_is_rejected():
    result = invoke("hexagon")
    assert result.exit_code != 0
