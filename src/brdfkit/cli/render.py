"""``brdfkit render``: render a sphere, plane, cylinder or normal map with a model under a light."""

from __future__ import annotations

from pathlib import Path

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import light_files, output_file

_BYTES_PER_PIXEL = 300
"""Peak memory of a render per pixel (measured: 1.2 GB peak at 2048×2048, ≈ 270 B a pixel)."""


@app.command("render")
def render_command(
    shape: str = typer.Argument(
        "sphere", metavar="SHAPE", help="sphere, plane, cylinder, or a normal map (.npy/.png/.exr)."
    ),
    brdf: str = typer.Option(
        "lambertian(albedo=0.8)",
        "--brdf",
        "-b",
        metavar="SPEC",
        help="Model spec, e.g. \"ggx(alpha=0.3, material='Au')\".",
    ),
    light: list[str] = typer.Option(
        ["envmap"],
        "--light",
        "-l",
        metavar="SPEC",
        help="Light spec (repeatable): directional:X,Y,Z[:E], point:X,Y,Z[:I], sky[:L], "
        "envmap[:PATH[:SCALE]].",
    ),
    output: Path = typer.Option(
        Path("render.png"),
        "--output",
        "-o",
        metavar="FILE",
        help="Output image (.png sRGB, .hdr or .exr linear).",
    ),
    resolution: int = typer.Option(
        256, "--resolution", "-r", metavar="PIXELS", min=8, max=8192, help="Image size in pixels."
    ),
    samples: int = typer.Option(
        64,
        "--samples",
        "-s",
        metavar="N",
        min=1,
        max=65536,
        help="Monte Carlo samples per pixel and strategy (at most 65536).",
    ),
    exposure: float = typer.Option(
        0.0, "--exposure", metavar="STOPS", help="Exposure in stops for PNG output."
    ),
    mask: Path | None = typer.Option(
        None, "--mask", metavar="FILE", help="Mask image for a normal-map input."
    ),
) -> None:
    """Render what a surface looks like (direct lighting, linear radiance)."""
    import numpy as np

    from brdfkit._array import check_param
    from brdfkit._checks import check_memory
    from brdfkit.brdf import parse
    from brdfkit.io import read_image, write_image
    from brdfkit.light.spec import parse_light
    from brdfkit.render.scene import Cylinder, Plane, Sphere, gbuffer, normal_map_gbuffer
    from brdfkit.render.shading import shade
    from brdfkit.vision.datasets import read_normal_map

    output = output_file(
        output,
        inputs=(_shape_file(shape), mask, *light_files(light)),
        suffixes=(".png", ".hdr", ".exr"),
    )
    check_param("--exposure", exposure, -64.0, 64.0)
    model = parse(brdf)
    lights = [parse_light(spec) for spec in light]
    shapes = {"sphere": Sphere(), "plane": Plane(), "cylinder": Cylinder()}
    if shape in shapes:
        check_memory(
            f"rendering {resolution}×{resolution} pixels", _BYTES_PER_PIXEL * resolution**2
        )
        g = gbuffer(shapes[shape], None, resolution)
    else:
        path = _shape_file(shape)
        if path is None:
            fail(
                f"shape must be one of {sorted(shapes)} or a normal-map file; got {shown(shape)!r}"
            )
        normals = read_normal_map(path)
        height, width = normals.shape[:2]
        check_memory(f"rendering {width}×{height} pixels", _BYTES_PER_PIXEL * width * height)
        m = None if mask is None else read_image(mask)[..., 0] > 0.5
        g = normal_map_gbuffer(normals, m)
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
    console.print(f"wrote {shown(output)} ({g.shape[1]}×{height}, {model.to_spec()})")


def _shape_file(shape: str) -> Path | None:
    """The normal-map file that ``shape`` names, or ``None`` for a built-in shape."""
    path = Path(shape)
    return path if path.is_file() else None
