"""``brdfkit hdr``: camera response recovery and HDR merging of an exposure stack
(:mod:`brdfkit.vision.calibration`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import output_file

_Images = Annotated[
    list[Path], typer.Argument(metavar="IMAGE", help="8-bit exposures of a static scene.")
]
_Times = Annotated[
    str | None,
    typer.Option(
        "--times",
        "-t",
        metavar="T1,T2,...",
        help="Exposure times in seconds: t1,t2,... (default: each photo's Exif ExposureTime).",
        show_default=False,
    ),
]
_Output = Annotated[Path, typer.Option("--output", "-o", metavar="FILE", help=".exr or .hdr.")]
_Response = Annotated[
    Path | None,
    typer.Option(
        "--response",
        metavar="FILE",
        help="Also write the recovered ln f⁻¹ per code (CSV, 256 rows).",
    ),
]
_Method = Annotated[
    str,
    typer.Option(
        "--method",
        metavar="NAME",
        help="Response recovery: debevec (Debevec & Malik 1997), robertson (Robertson et al. "
        "2003), mitsunaga_nayar (Mitsunaga & Nayar 1999) or emor (a low-dimensional prior).",
    ),
]
_Smoothness = Annotated[
    float, typer.Option("--smoothness", metavar="LAMBDA", min=0.0, help="Smoothness λ.")
]
_Samples = Annotated[
    int,
    typer.Option(
        "--samples",
        metavar="N",
        min=2,
        max=100_000,
        help="Pixels sampled for the fit (at most 100000).",
    ),
]
_FallbackMask = Annotated[
    Path | None,
    typer.Option(
        "--fallback-mask",
        metavar="FILE",
        help="Also write a PNG mask of the pixels no exposure showed well (white), whose "
        "radiance comes from the nearest exposure (a bound, not a measurement).",
    ),
]


@app.command("hdr")
def hdr_command(
    images: _Images,
    times: _Times = None,
    output: _Output = Path("merged.exr"),
    response: _Response = None,
    method: _Method = "debevec",
    smoothness: _Smoothness = 50.0,
    samples: _Samples = 200,
    fallback_mask: _FallbackMask = None,
) -> None:
    """Recover the camera response (--method; --smoothness is Debevec & Malik's) and merge
    the stack to radiance."""
    import numpy as np

    from brdfkit._array import check_param
    from brdfkit.io import atomic_write, write_image
    from brdfkit.params import check_choice
    from brdfkit.vision.calibration import merge_hdr, recover_response
    from brdfkit.vision.response import METHODS, calibrate_response

    output = output_file(output, inputs=images, suffixes=(".exr", ".hdr"))
    if response is not None:
        response = output_file(response, inputs=images, option="--response", suffixes=(".csv",))
    if fallback_mask is not None:
        fallback_mask = output_file(
            fallback_mask, inputs=images, option="--fallback-mask", suffixes=(".png",)
        )
    check_param("--smoothness", smoothness, 0.0)
    check_choice("--method", method, METHODS)
    exposure_times = _exposure_times(times, images)
    with progress() as bar:
        task = bar.add_task("reading exposures", total=len(images))
        stack = _read_stack(images, lambda done: bar.update(task, completed=done))
        bar.update(task, description=f"recovering the response ({method})", total=None, completed=0)
        if method == "debevec":
            g = recover_response(stack, exposure_times, smoothness=smoothness, samples=samples)
        else:
            calibrated = calibrate_response(
                stack, exposure_times, method, samples=samples, bootstrap=0
            )
            g = calibrated.log_inverse()
        bar.update(task, description="merging", completed=0)
        radiance, fell_back = merge_hdr(
            stack, exposure_times, g, return_mask=True,
            callback=lambda done, rows: bar.update(task, completed=done, total=rows),
        )  # fmt: skip
        bar.update(task, description=f"writing {shown(output)}", total=None, completed=0)
        write_image(output, radiance)  # atomic
    if response is not None:
        header = "ln f^-1 per code (rows 0..255), per channel"
        atomic_write(response, lambda tmp: np.savetxt(tmp, g, delimiter=",", header=header))
    if fallback_mask is not None:
        write_image(fallback_mask, fell_back.astype(np.float32), srgb=False)
    count = int(fell_back.sum())
    note = ""
    if count:
        note = (
            f"; {count} pixel(s) ({100 * count / fell_back.size:.2g} %) had no well-exposed "
            "sample and took the nearest exposure"
        )
    console.print(f"wrote {shown(output)} ({radiance.shape[1]}×{radiance.shape[0]}){note}")


def _exposure_times(times: str | None, images: list[Path]) -> list[float]:
    """The exposure time of each image in seconds: ``--times``, else each one's Exif."""
    from brdfkit.vision.calibration import read_exposure_time

    if times is None:
        recorded = [read_exposure_time(path) for path in images]
        for path, seconds in zip(images, recorded, strict=True):
            if seconds is None:
                fail(f"{shown(path)} records no exposure time (Exif); give --times T1,T2,...")
        return recorded
    count = len(images)
    try:
        exposure_times = [float(v) for v in times.split(",")]
    except ValueError:
        fail(f"--times must be comma-separated numbers; got {times!r}")
    if len(exposure_times) != count:
        fail(f"--times lists {len(exposure_times)} times for {count} images")
    return exposure_times


def _read_stack(images: list[Path], callback: Callable[[int], None]) -> list[Any]:
    """The 8-bit codes of every exposure (RGB or grey), all of one size; ``callback(done)``
    after each."""
    import numpy as np

    from brdfkit.io import read_image_codes

    stack = []
    for path in images:
        if path.suffix.lower() in (".hdr", ".exr"):
            fail(f"{shown(path)} is already linear radiance: an exposure stack is 8-bit photos")
        codes = read_image_codes(path)
        if codes.dtype != np.uint8:
            fail(f"{shown(path)} has {codes.dtype} samples; the stack must be 8-bit images")
        codes = codes[..., :3] if codes.shape[-1] >= 3 else codes[..., :1]
        if stack and codes.shape != stack[0].shape:
            fail(
                f"{shown(path)} is {codes.shape}, {shown(images[0])} is {stack[0].shape}: "
                "sizes must match"
            )
        stack.append(codes)
        callback(len(stack))
    return stack
