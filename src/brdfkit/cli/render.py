"""``brdfkit render``: render a sphere, plane, cylinder or normal map with a model under a light
(:func:`brdfkit.render.shading.shade` of a G-buffer)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from brdfkit.cli._app import (
    MODEL_HELP,
    app,
    console,
    fail,
    load_model,
    model_label,
    progress,
    shown,
)
from brdfkit.cli._output import light_files, output_file

_BYTES_PER_PIXEL = 300
"""Peak memory of a render per pixel (1.2 GB at 2048×2048, about 270 bytes a pixel, rounded
up)."""

_Shape = Annotated[
    str,
    typer.Argument(
        metavar="SHAPE", help="sphere, plane, cylinder, or a normal map (.npy/.png/.exr)."
    ),
]
_Brdf = Annotated[
    str,
    typer.Option(
        "--brdf",
        "-b",
        metavar="MODEL",
        help=f"The model: {MODEL_HELP}; e.g. \"ggx(alpha=0.3, material='Au')\".",
    ),
]
_Lights = Annotated[
    list[str],
    typer.Option(
        "--light",
        "-l",
        metavar="SPEC",
        help="Light spec (repeatable): directional:X,Y,Z[:E], point:X,Y,Z[:I], sky[:L], "
        "envmap[:PATH[:SCALE]].",
    ),
]
_Output = Annotated[
    Path,
    typer.Option(
        "--output",
        "-o",
        metavar="FILE",
        help="Output image (.png sRGB, .hdr or .exr linear).",
    ),
]
_Resolution = Annotated[
    int,
    typer.Option(
        "--resolution", "-r", metavar="PIXELS", min=8, max=8192, help="Image size in pixels."
    ),
]
_Samples = Annotated[
    int,
    typer.Option(
        "--samples",
        "-s",
        metavar="N",
        min=1,
        max=65536,
        help="Monte Carlo samples per pixel and strategy (at most 65536).",
    ),
]
_Exposure = Annotated[
    float,
    typer.Option("--exposure", metavar="STOPS", help="Exposure in stops for PNG output."),
]
_Mask = Annotated[
    Path | None,
    typer.Option("--mask", metavar="FILE", help="Mask image for a normal-map input."),
]


@app.command("render")
def render_command(
    shape: _Shape = "sphere",
    brdf: _Brdf = "lambertian(albedo=0.8)",
    light: _Lights = ("envmap",),
    output: _Output = Path("render.png"),
    resolution: _Resolution = 256,
    samples: _Samples = 64,
    exposure: _Exposure = 0.0,
    mask: _Mask = None,
) -> None:
    """Render what a surface looks like (direct lighting, linear radiance)."""
    import numpy as np

    from brdfkit._array import check_param
    from brdfkit.io import write_image
    from brdfkit.light.spec import parse_light
    from brdfkit.render.shading import shade

    output = output_file(
        output,
        inputs=(_shape_file(shape), mask, *light_files(light)),
        suffixes=(".png", ".hdr", ".exr"),
    )
    check_param("--exposure", exposure, -64.0, 64.0)
    model = load_model(brdf)
    lights = [parse_light(spec) for spec in light]
    g = _gbuffer(shape, mask, resolution)
    height = g.shape[0]
    with progress() as bar:
        task = bar.add_task(f"rendering {g.shape[1]}×{height}", total=height)
        image = shade(
            g,
            model,
            lights,
            samples=samples,
            progress=lambda done, total: bar.update(task, completed=done),
        )
    if image.shape[-1] == 1:
        image = np.repeat(image, 3, axis=-1)
    # write_image is atomic: it never leaves a half-written file.
    write_image(
        output, image.astype(np.float32), exposure=exposure if output.suffix == ".png" else 0.0
    )
    console.print(f"wrote {shown(output)} ({g.shape[1]}×{height}, {model_label(model, brdf)})")


def _gbuffer(shape: str, mask: Path | None, resolution: int) -> Any:
    """The G-buffer of a built-in shape at ``resolution``, or of the normal-map file ``shape``
    (``mask`` its mask image); refused before any work when it would not fit in memory."""
    from brdfkit._checks import check_memory
    from brdfkit.io import read_image
    from brdfkit.render.scene import Cylinder, Plane, Sphere, gbuffer, normal_map_gbuffer
    from brdfkit.vision.datasets import read_normal_map

    shapes = {"sphere": Sphere(), "plane": Plane(), "cylinder": Cylinder()}
    if shape in shapes:
        check_memory(
            f"rendering {resolution}×{resolution} pixels", _BYTES_PER_PIXEL * resolution**2
        )
        return gbuffer(shapes[shape], None, resolution)
    path = _shape_file(shape)
    if path is None:
        fail(f"shape must be one of {sorted(shapes)} or a normal-map file; got {shown(shape)!r}")
    normals = read_normal_map(path)
    height, width = normals.shape[:2]
    check_memory(f"rendering {width}×{height} pixels", _BYTES_PER_PIXEL * width * height)
    m = None if mask is None else read_image(mask)[..., 0] > 0.5
    return normal_map_gbuffer(normals, m)


def _shape_file(shape: str) -> Path | None:
    """The normal-map file that ``shape`` names, or ``None`` for a built-in shape."""
    path = Path(shape)
    return path if path.is_file() else None
