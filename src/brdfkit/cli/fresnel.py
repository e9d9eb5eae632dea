"""``brdfkit fresnel``: Fresnel reflectance (s, p, unpolarised) against the angle of incidence."""

from __future__ import annotations

import json
import math
from typing import Annotated, Any

import typer

from brdfkit.cli._app import app, console, fail

DEFAULT_ANGLES = "0,15,30,45,60,75,85,89"


def _parse_angles(text: str) -> list[float]:
    try:
        angles = [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        fail(f"--angles must be comma-separated numbers of degrees; got {text!r}")
    if not angles or not all(0.0 <= a <= 90.0 for a in angles):
        fail(f"--angles must be degrees in [0, 90]; got {text!r}")
    return angles


def _interface(material: str | None, ior: float | None, k: float | None) -> dict[str, Any]:
    """The interface to tabulate: its label, kind ('dielectric'/'conductor'), eta and k."""
    from brdfkit.fresnel import CONDUCTORS, IOR, conductor, dielectric

    if (material is None) == (ior is None):
        fail("give exactly one of --material NAME or --ior ETA")
    if material is not None:
        if k is not None:
            fail("--k goes with --ior (a custom conductor), not with --material")
        if material.strip().lower() in IOR:
            eta = dielectric(material)
            return {
                "label": f"{material} (η = {eta:g})",
                "kind": "dielectric",
                "eta": [eta],
                "k": None,
            }
        if material.strip().lower() in {name.lower() for name in CONDUCTORS}:
            eta_rgb, k_rgb = conductor(material)
            return {"label": material, "kind": "conductor", "eta": list(eta_rgb), "k": list(k_rgb)}
        fail(
            f"--material {material!r} is unknown; conductors: {', '.join(CONDUCTORS)}; "
            f"dielectrics: {', '.join(IOR)}"
        )
    if k is None:
        return {"label": f"η = {ior:g}", "kind": "dielectric", "eta": [ior], "k": None}
    return {"label": f"η + iκ = {ior:g} + {k:g}i", "kind": "conductor", "eta": [ior], "k": [k]}


def _cell(values: Any) -> str:
    return " ".join(f"{float(v):.4f}" for v in values)


_Material = Annotated[
    str | None,
    typer.Option(
        "--material",
        "-m",
        metavar="NAME",
        help="A preset: a conductor (Au, Ag, Al, Cu, Cr, W; RGB) or a dielectric (water, bk7, "
        "diamond, …).",
    ),
]
_Ior = Annotated[
    float | None,
    typer.Option(
        "--ior", metavar="ETA", help="Relative index of refraction η = n_inside / n_outside."
    ),
]
_Kappa = Annotated[
    float | None,
    typer.Option(
        "--k",
        metavar="KAPPA",
        help="Extinction coefficient κ: with --ior, a conductor of index η + iκ.",
    ),
]
_Angles = Annotated[
    str,
    typer.Option(
        "--angles",
        metavar="A1,A2,...",
        help="Angles of incidence in degrees, comma-separated.",
    ),
]
_Inside = Annotated[
    bool,
    typer.Option(
        "--inside",
        help="Dielectrics: light arrives from inside (shows total internal "
        "reflection beyond the critical angle).",
    ),
]
_Json = Annotated[bool, typer.Option("--json", help="Print the table as JSON.")]


@app.command("fresnel")
def fresnel_command(
    material: _Material = None,
    ior: _Ior = None,
    k: _Kappa = None,
    angles: _Angles = DEFAULT_ANGLES,
    inside: _Inside = False,
    as_json: _Json = False,
) -> None:
    """Tabulate the Fresnel reflectance Rs, Rp and R = (Rs + Rp)/2 against the angle."""
    import numpy as np

    from brdfkit.fresnel import fresnel_conductor, fresnel_dielectric

    theta_deg = _parse_angles(angles)
    spec = _interface(material, ior, k)
    if spec["kind"] == "conductor" and inside:
        fail("--inside applies to dielectrics only (a conductor is opaque)")
    cos = np.cos(np.radians(theta_deg))[:, None]
    eta = np.asarray(spec["eta"], dtype=np.float64)
    try:
        if spec["kind"] == "conductor":
            r_s, r_p = fresnel_conductor(cos, eta, np.asarray(spec["k"]), polarized=True)
        else:
            r_s, r_p = fresnel_dielectric(-cos if inside else cos, eta, polarized=True)
    except ValueError as error:
        fail(str(error))
    r = 0.5 * (r_s + r_p)
    rows = [
        {"angle_deg": a, "Rs": r_s[i].tolist(), "Rp": r_p[i].tolist(), "R": r[i].tolist()}
        for i, a in enumerate(theta_deg)
    ]
    if as_json:
        record = {**spec, "inside": inside, "rows": rows}
        typer.echo(json.dumps(record, indent=2, ensure_ascii=False))
        return
    _print_table(spec, inside, eta, rows)


def _print_table(spec: dict[str, Any], inside: bool, eta: Any, rows: list[dict]) -> None:
    """The reflectances by angle (and the transmittance of a dielectric) as a table."""
    import numpy as np
    from rich.table import Table

    from brdfkit.geometry import critical_angle

    side = " (from inside)" if inside else ""
    channels = " (R G B)" if len(eta) == 3 else ""
    title = f"Fresnel reflectance of {spec['label']}{side}{channels}"
    if spec["kind"] == "conductor":
        title += f"\nη = {_cell(eta)}   κ = {_cell(spec['k'])}"
    elif inside and eta[0] > 1:
        title += f"\ncritical angle {math.degrees(float(critical_angle(eta[0]))):.2f}°"
    table = Table(title=title, title_justify="left")
    table.add_column("θi (°)", justify="right", no_wrap=True)
    for name in ("Rs", "Rp", "R"):
        table.add_column(name, justify="right", no_wrap=True)
    if spec["kind"] == "dielectric":
        table.add_column("T = 1 − R", justify="right", no_wrap=True)
    for row in rows:
        cells = [f"{row['angle_deg']:g}", _cell(row["Rs"]), _cell(row["Rp"]), _cell(row["R"])]
        if spec["kind"] == "dielectric":
            cells.append(_cell(1 - np.asarray(row["R"])))
        table.add_row(*cells)
    console.print(table)
