"""``brdfkit lighting``: SH lighting, a directional light, or a lat-long map from a mirror ball."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from brdfkit.cli._app import app, console, fail, shown
from brdfkit.cli._output import output_file

METHODS = ("sh", "directional", "mirror-ball")

_Image = Annotated[
    Path,
    typer.Argument(metavar="IMAGE", help="Linear .hdr/.exr (or 8/16-bit with --encoding)."),
]
_Method = Annotated[
    str,
    typer.Option(
        "--method",
        "-m",
        metavar="sh|directional|mirror-ball",
        help="sh, directional or mirror-ball.",
    ),
]
_Mask = Annotated[
    Path | None,
    typer.Option("--mask", metavar="FILE", help="Object mask image (white = object)."),
]
_Normals = Annotated[
    Path | None,
    typer.Option(
        "--normals",
        metavar="FILE",
        help="Normal map: .npy (H, W, 3) or an RGB image with n = 2v − 1.",
    ),
]
_Sphere = Annotated[
    bool,
    typer.Option("--sphere", help="The object is a sphere: normals from the mask's fitted circle."),
]
_Albedo = Annotated[
    float,
    typer.Option("--albedo", metavar="RHO", help="Known albedo (1 if unknown: up to scale)."),
]
_Encoding = Annotated[
    str | None,
    typer.Option(
        "--encoding",
        metavar="srgb|linear",
        help="How an 8/16-bit input is encoded: srgb or linear.",
    ),
]
_Output = Annotated[
    Path,
    typer.Option("--output", "-o", metavar="FILE", help="JSON (sh, directional) or .exr/.hdr map."),
]
_Height = Annotated[
    int,
    typer.Option(
        "--height",
        metavar="PIXELS",
        min=2,
        max=4096,
        help="Lat-long map height (mirror-ball; at most 4096).",
    ),
]


@app.command("lighting")
def lighting_command(
    image: _Image,
    method: _Method = "sh",
    mask: _Mask = None,
    normals: _Normals = None,
    sphere: _Sphere = False,
    albedo: _Albedo = 1.0,
    encoding: _Encoding = None,
    output: _Output = Path("lighting.json"),
    height: _Height = 256,
) -> None:
    """Estimate the illumination from an image of a known Lambertian object or a mirror ball."""
    import json

    from brdfkit._array import check_param
    from brdfkit.io import atomic_write, write_image
    from brdfkit.vision.calibration import read_linear_image
    from brdfkit.vision.datasets import read_mask
    from brdfkit.vision.lighting import mirror_ball_to_latlong

    if method not in METHODS:
        fail(f"--method must be one of {', '.join(METHODS)}; got {method!r}")
    suffixes = (".exr", ".hdr") if method == "mirror-ball" else (".json",)
    output = output_file(output, inputs=(image, mask, normals), suffixes=suffixes)
    check_param("--albedo", albedo, 0.0, lo_open=True)
    picture = read_linear_image(image, encoding)
    m = None if mask is None else read_mask(mask)
    if m is not None and m.shape != picture.shape[:2]:
        fail(f"--mask has shape {m.shape}, the image {picture.shape[:2]}: they must match")
    if method == "mirror-ball":
        latlong = mirror_ball_to_latlong(picture[..., :3], m, height=height, width=2 * height)
        write_image(output, latlong)  # atomic
        console.print(f"wrote {shown(output)} ({2 * height}×{height} lat-long map)")
        return
    n = _object_normals(method, m, normals, sphere, picture.shape[:2])
    text = json.dumps(_estimate(method, picture, n, m, albedo), indent=2, allow_nan=False) + "\n"
    atomic_write(output, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    console.print(f"wrote {shown(output)} ({method} lighting)")


def _object_normals(
    method: str, mask: Any, normals: Path | None, sphere: bool, shape: tuple[int, int]
) -> Any:
    """The object's normals ``(H, W, 3)``: of the sphere fitted to ``mask``, or read from the
    ``normals`` file; exits when neither is given or their shape is not the image's."""
    from brdfkit.vision.datasets import read_normal_map
    from brdfkit.vision.photometric_stereo import fit_circle, sphere_normals

    if sphere:
        if mask is None:
            fail("--sphere needs --mask (the sphere's silhouette)")
        c_x, c_y, radius = fit_circle(mask)
        n, _ = sphere_normals(mask.shape, (c_x, c_y), radius)
    elif normals is not None:
        n = read_normal_map(normals)
    else:
        fail(f"--method {method} needs the object's normals: give --normals or --sphere")
    if n.shape != (*shape, 3):
        fail(f"normals have shape {n.shape}; expected {(*shape, 3)} like the image")
    return n


def _estimate(method: str, picture: Any, normals: Any, mask: Any, albedo: float) -> dict:
    """The lighting record that ``--output`` receives: SH coefficients or a directional
    light."""
    from brdfkit.vision.lighting import estimate_directional_light, estimate_sh_lighting

    if method == "sh":
        coeffs = estimate_sh_lighting(picture, normals, mask, albedo)
        return {"method": "sh", "order": 2, "coefficients": coeffs.tolist()}
    estimate = estimate_directional_light(picture, normals, mask, albedo)
    return {
        "method": "directional",
        "direction": estimate.direction.tolist(),
        "irradiance": estimate.irradiance.tolist(),
        "relative_rms": estimate.rms,
    }
