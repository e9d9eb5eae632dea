"""``brdfkit lighting``: SH lighting, a directional light, or a lat-long map from a mirror ball."""

from __future__ import annotations

from pathlib import Path

import typer

from brdfkit.cli._app import app, console, fail, shown
from brdfkit.cli._output import output_file

METHODS = ("sh", "directional", "mirror-ball")


@app.command("lighting")
def lighting_command(
    image: Path = typer.Argument(
        ..., metavar="IMAGE", help="Linear .hdr/.exr (or 8/16-bit with --encoding)."
    ),
    method: str = typer.Option(
        "sh",
        "--method",
        "-m",
        metavar="sh|directional|mirror-ball",
        help="sh, directional or mirror-ball.",
    ),
    mask: Path | None = typer.Option(
        None, "--mask", metavar="FILE", help="Object mask image (white = object)."
    ),
    normals: Path | None = typer.Option(
        None,
        "--normals",
        metavar="FILE",
        help="Normal map: .npy (H, W, 3) or an RGB image with n = 2v − 1.",
    ),
    sphere: bool = typer.Option(
        False, "--sphere", help="The object is a sphere: normals from the mask's fitted circle."
    ),
    albedo: float = typer.Option(
        1.0, "--albedo", metavar="RHO", help="Known albedo (1 if unknown: up to scale)."
    ),
    encoding: str | None = typer.Option(
        None,
        "--encoding",
        metavar="srgb|linear",
        help="How an 8/16-bit input is encoded: srgb or linear.",
    ),
    output: Path = typer.Option(
        Path("lighting.json"),
        "--output",
        "-o",
        metavar="FILE",
        help="JSON (sh, directional) or .exr/.hdr map.",
    ),
    height: int = typer.Option(
        256,
        "--height",
        metavar="PIXELS",
        min=2,
        max=4096,
        help="Lat-long map height (mirror-ball; at most 4096).",
    ),
) -> None:
    """Estimate the illumination from an image of a known Lambertian object or a mirror ball."""
    import json

    from brdfkit._array import check_param
    from brdfkit.io import atomic_write, read_image, write_image
    from brdfkit.vision.calibration import read_linear_image
    from brdfkit.vision.datasets import read_normal_map
    from brdfkit.vision.lighting import (
        estimate_directional_light,
        estimate_sh_lighting,
        mirror_ball_to_latlong,
    )
    from brdfkit.vision.photometric_stereo import fit_circle, sphere_normals

    if method not in METHODS:
        fail(f"--method must be one of {', '.join(METHODS)}; got {method!r}")
    suffixes = (".exr", ".hdr") if method == "mirror-ball" else (".json",)
    output = output_file(output, inputs=(image, mask, normals), suffixes=suffixes)
    check_param("--albedo", albedo, 0.0, lo_open=True)
    picture = read_linear_image(image, encoding)
    m = None if mask is None else read_image(mask)[..., 0] > 0.5
    if m is not None and m.shape != picture.shape[:2]:
        fail(f"--mask has shape {m.shape}, the image {picture.shape[:2]}: they must match")
    if method == "mirror-ball":
        latlong = mirror_ball_to_latlong(picture[..., :3], m, height=height, width=2 * height)
        write_image(output, latlong)  # atomic
        console.print(f"wrote {shown(output)} ({2 * height}×{height} lat-long map)")
        return
    if sphere:
        if m is None:
            fail("--sphere needs --mask (the sphere's silhouette)")
        c_x, c_y, radius = fit_circle(m)
        n, _ = sphere_normals(m.shape, (c_x, c_y), radius)
    elif normals is not None:
        n = read_normal_map(normals)
    else:
        fail(f"--method {method} needs the object's normals: give --normals or --sphere")
    if n.shape != (*picture.shape[:2], 3):
        fail(f"normals have shape {n.shape}; expected {(*picture.shape[:2], 3)} like the image")
    if method == "sh":
        coeffs = estimate_sh_lighting(picture, n, m, albedo)
        record = {"method": "sh", "order": 2, "coefficients": coeffs.tolist()}
    else:
        estimate = estimate_directional_light(picture, n, m, albedo)
        record = {
            "method": "directional",
            "direction": estimate.direction.tolist(),
            "irradiance": estimate.irradiance.tolist(),
            "relative_rms": estimate.rms,
        }
    text = json.dumps(record, indent=2, allow_nan=False) + "\n"
    atomic_write(output, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    console.print(f"wrote {shown(output)} ({method} lighting)")
