"""``brdfkit solid-angle``: the solid angle of a disk, rectangle, triangle or spherical cap, with
the lectures' surface integral Ω = ∬ r·n̂ dS/|r|³ computed numerically as a cross-check."""

from __future__ import annotations

import json
import math
from enum import StrEnum
from typing import Annotated, Any

import typer

from brdfkit.cli._app import app, console, fail

DEFAULT_VERTICES = "-0.5,-0.288675,0;0.5,-0.288675,0;0,0.57735,0"


class Shape(StrEnum):
    """The shapes the command knows."""

    disk = "disk"
    rectangle = "rectangle"
    triangle = "triangle"
    cap = "cap"


_ShapeArgument = Annotated[
    Shape, typer.Argument(metavar="SHAPE", help="disk, rectangle, triangle or cap.")
]
_Radius = Annotated[float, typer.Option("--radius", "-r", metavar="R", help="Disk radius.")]
_Width = Annotated[float, typer.Option("--width", metavar="W", help="Rectangle width (along x).")]
_Height = Annotated[
    float, typer.Option("--height", metavar="H", help="Rectangle height (along y).")
]
_Vertices = Annotated[
    str,
    typer.Option(
        "--vertices",
        metavar="X,Y,Z;X,Y,Z;X,Y,Z",
        show_default=False,
        help="Triangle vertices (default: a unit equilateral triangle in z = 0, centred at the "
        "origin).",
    ),
]
_Distance = Annotated[
    float,
    typer.Option(
        "--distance", "-d", metavar="D", help="Observer height above the shape's plane (z)."
    ),
]
_Offset = Annotated[
    float, typer.Option("--offset", metavar="X", help="Observer offset along x from the axis.")
]
_HalfAngle = Annotated[
    float,
    typer.Option(
        "--half-angle",
        metavar="DEGREES",
        help="Cap half-angle α in degrees (90: the hemisphere).",
    ),
]
_Order = Annotated[
    int,
    typer.Option(
        "--order",
        metavar="N",
        min=1,
        max=2048,
        help="Gauss–Legendre nodes per parameter of the numerical integral (1–2048).",
    ),
]
_Json = Annotated[bool, typer.Option("--json", help="Print the table as JSON.")]


def _parse_vertices(text: str) -> list[list[float]]:
    try:
        vertices = [[float(x) for x in part.split(",")] for part in text.split(";")]
    except ValueError:
        vertices = []
    if len(vertices) != 3 or any(len(v) != 3 for v in vertices):
        fail(f"--vertices must be three 'x,y,z' points separated by ';'; got {text!r}")
    return vertices


def _planar(shape: Shape, radius: float, width: float, height: float, vertices: str):
    """(description, exact-method label, exact Ω(point), parametric surface) of a planar shape
    lying in the plane z = 0."""
    import numpy as np

    from brdfkit import radiometry as rad

    origin, z = np.zeros(3), np.array([0.0, 0.0, 1.0])
    if shape is Shape.disk:
        return (
            f"disk, radius {radius:g}, centre at the origin, normal +z",
            "rim contour integral (trapezoid)",
            lambda p: rad.solid_angle_disk(origin, z, radius, p),
            rad.disk_surface(origin, z, radius),
        )
    if shape is Shape.rectangle:
        corner = np.array([-width / 2, -height / 2, 0.0])
        eu, ev = np.array([width, 0.0, 0.0]), np.array([0.0, height, 0.0])
        return (
            f"rectangle {width:g} × {height:g}, centred at the origin in z = 0",
            "two Van Oosterom–Strackee triangles",
            lambda p: rad.solid_angle_rectangle(corner, eu, ev, p),
            rad.rectangle_surface(corner, eu, ev),
        )
    a, b, c = (np.array(v) for v in _parse_vertices(vertices))
    return (
        "triangle " + " ".join(f"({v[0]:g}, {v[1]:g}, {v[2]:g})" for v in (a, b, c)),
        "Van Oosterom–Strackee (1983)",
        lambda p: rad.solid_angle_triangle(a, b, c, p),
        rad.triangle_surface(a, b, c),
    )


def _cap(half_angle: float):
    """(description, exact-method label, Ω, parametric surface, observer) of a spherical cap
    seen from its centre."""
    import numpy as np

    from brdfkit import radiometry as rad

    if not 0.0 < half_angle <= 180.0:
        fail(f"--half-angle must be in (0, 180] degrees; got {half_angle:g}")
    alpha = math.radians(half_angle)
    point = np.zeros(3)
    return (
        f"spherical cap, half-angle {half_angle:g}°, seen from its centre",
        "2π(1 − cos α)",
        float(rad.solid_angle_cap(alpha)),
        rad.cap_surface(point, np.array([0.0, 0.0, 1.0]), 1.0, alpha),
        point,
    )


@app.command("solid-angle")
def solid_angle_command(
    shape: _ShapeArgument,
    radius: _Radius = 1.0,
    width: _Width = 1.0,
    height: _Height = 1.0,
    vertices: _Vertices = DEFAULT_VERTICES,
    distance: _Distance = 1.0,
    offset: _Offset = 0.0,
    half_angle: _HalfAngle = 90.0,
    order: _Order = 64,
    as_json: _Json = False,
) -> None:
    """Solid angle Ω of a shape seen from a point, in sr and as a fraction of the hemisphere,
    checked against the numerical surface integral Ω = ∬ r·n̂ dS / |r|³ (CMU 16-385 lecture 14).
    """
    import numpy as np

    from brdfkit import radiometry as rad

    if shape is Shape.cap:
        description, method, exact, surface, point = _cap(half_angle)
    else:
        point = np.array([offset, 0.0, distance])
        description, method, solid_angle, surface = _planar(shape, radius, width, height, vertices)
        exact = float(solid_angle(point))
    numeric = abs(float(rad.solid_angle_surface(surface, point, order=order)))
    rows = [(method, exact)]
    if shape is Shape.disk and offset == 0.0 and distance != 0.0:
        on_axis = float(rad.solid_angle_disk_on_axis(radius, abs(distance)))
        rows.append(("on axis: 2π(1 − d/√(d²+R²))", on_axis))
    rows.append((f"∬ r·n̂ dS/|r|³ (Gauss–Legendre {order}²)", numeric))
    if as_json:
        record = {
            "shape": shape.value,
            "description": description,
            "observer": point.tolist(),
            "rows": [
                {
                    "method": label,
                    "omega_sr": omega,
                    "fraction_of_hemisphere": omega / (2 * math.pi),
                }
                for label, omega in rows
            ],
            "abs_difference_sr": abs(numeric - exact),
        }
        typer.echo(json.dumps(record, indent=2, ensure_ascii=False))
        return
    _print_table(description, point, rows, abs(numeric - exact))


def _print_table(description: str, point: Any, rows: list, difference: float) -> None:
    """The solid angles by each method, in sr and as fractions of the hemisphere."""
    from rich.table import Table

    table = Table(
        title=f"{description}\nobserver at ({point[0]:g}, {point[1]:g}, {point[2]:g})",
        caption=f"|numerical − exact| = {difference:.3e} sr",
    )
    table.add_column("method")
    table.add_column("Ω [sr]", justify="right")
    table.add_column("Ω / 2π", justify="right")  # the fraction of the hemisphere
    for label, omega in rows:
        table.add_row(label, f"{omega:.10f}", f"{omega / (2 * math.pi):.10f}")
    console.print(table)
