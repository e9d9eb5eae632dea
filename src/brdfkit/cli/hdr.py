"""``brdfkit hdr``: camera response recovery and HDR merging of an exposure stack."""

from __future__ import annotations

from pathlib import Path

import typer

from brdfkit.cli._app import app, atomic_output, console, fail


@app.command("hdr")
def hdr_command(
    images: list[Path] = typer.Argument(..., help="8-bit exposures of a static scene."),
    times: str = typer.Option(..., "--times", "-t", help="Exposure times in seconds: t1,t2,..."),
    output: Path = typer.Option(Path("merged.exr"), "--output", "-o", help=".exr or .hdr."),
    response: Path | None = typer.Option(
        None, "--response", help="Also write the recovered ln f⁻¹ per code (CSV, 256 rows)."
    ),
    smoothness: float = typer.Option(50.0, "--smoothness", min=0.0, help="Smoothness λ."),
    samples: int = typer.Option(200, "--samples", min=2, help="Pixels sampled for the fit."),
) -> None:
    """Recover the camera response (Debevec & Malik 1997) and merge the stack to radiance."""
    import cv2
    import numpy as np

    from brdfkit.io import write_image
    from brdfkit.vision.calibration import merge_hdr, recover_response

    if output.suffix.lower() not in (".exr", ".hdr"):
        fail(f"--output must be .exr or .hdr (linear radiance); got {output.name!r}")
    try:
        exposure_times = [float(v) for v in times.split(",")]
    except ValueError:
        fail(f"--times must be comma-separated numbers; got {times!r}")
    if len(exposure_times) != len(images):
        fail(f"--times lists {len(exposure_times)} times for {len(images)} images")
    stack = []
    for path in images:
        if path.suffix.lower() in (".hdr", ".exr"):
            fail(f"{path} is already linear radiance: an exposure stack is 8-bit photos")
        codes = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if codes is None:
            fail(f"cannot read image {path}")
        if codes.dtype != np.uint8:
            fail(f"{path} has {codes.dtype} samples; the stack must be 8-bit images")
        codes = codes[..., None] if codes.ndim == 2 else codes[..., 2::-1]
        if stack and codes.shape != stack[0].shape:
            fail(f"{path} is {codes.shape}, {images[0]} is {stack[0].shape}: sizes must match")
        stack.append(codes)
    try:
        g = recover_response(stack, exposure_times, smoothness=smoothness, samples=samples)
        radiance = merge_hdr(stack, exposure_times, g)
    except ValueError as error:
        fail(str(error))
    write_image(output, radiance)  # atomic
    if response is not None:
        with atomic_output(response) as tmp:
            np.savetxt(tmp, g, delimiter=",", header="ln f^-1 per code (rows 0..255), per channel")
    console.print(f"wrote {output} ({radiance.shape[1]}×{radiance.shape[0]})")
