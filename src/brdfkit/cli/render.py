"""``brdfkit render``: render a sphere, plane, cylinder, normal map or mesh with a model under a
light (:func:`brdfkit.render.shading.shade` of a G-buffer; meshes with shadows,
:func:`brdfkit.render.mesh.render_mesh`, in Mitsuba 3's world frame)."""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
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
    status,
)
from brdfkit.cli._entry import start_up
from brdfkit.cli._output import light_files, output_file

_BYTES_PER_PIXEL = 300
"""Peak memory of a render per pixel (1.2 GB at 2048×2048, about 270 bytes a pixel, rounded
up)."""

_Shape = Annotated[
    str,
    typer.Argument(
        metavar="SHAPE",
        help="sphere, plane, cylinder, a normal map (.npy/.png/.exr), or a mesh "
        "(.obj/.ply/.stl/.gltf/.glb, or bundled:knot / bundled:shaderball: Mitsuba 3's "
        "world frame, shadows).",
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
_LookAt = Annotated[
    str | None,
    typer.Option(
        "--look-at",
        metavar="ORIGIN:TARGET:UP",
        help="Mesh camera as Mitsuba's look_at, e.g. 0,2,3:0,0,0:0,1,0 (default: the mesh's "
        "centre seen from +z, up +y).",
    ),
]
_Fov = Annotated[
    float | None,
    typer.Option(
        "--fov",
        metavar="DEGREES",
        help="Mesh camera's horizontal field of view (default: orthographic, [-1, 1] wide).",
    ),
]
_Size = Annotated[
    str | None,
    typer.Option(
        "--size", metavar="WIDTHxHEIGHT", help="Image size of a mesh render (default: square)."
    ),
]
_Supersample = Annotated[
    int,
    typer.Option(
        "--supersample",
        metavar="K",
        min=1,
        max=8,
        help="Mesh renders: K×K shading points per pixel (antialiased edges).",
    ),
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
    look_at: _LookAt = None,
    fov: _Fov = None,
    size: _Size = None,
    supersample: _Supersample = 1,
) -> None:
    """Render what a surface looks like (direct lighting, linear radiance)."""
    _blas_on_one_thread()
    with start_up():
        from brdfkit._array import check_param
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
        mesh = _is_mesh(shape)
        if not mesh:
            if (look_at, fov, size, supersample) != (None, None, None, 1):
                fail("--look-at, --fov, --size and --supersample apply to mesh files only")
            g = _scene(shape, mask, resolution, model, lights)
    if mesh:
        camera = _MeshCamera(look_at, fov, _image_size(size, resolution), supersample)
        image = _render_mesh(Path(shape), model, lights, camera, samples)
        _write(output, image, exposure, model_label(model, brdf))
        return
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
    _write(output, image, exposure, model_label(model, brdf))


def _blas_on_one_thread() -> None:
    """Have OpenBLAS (NumPy's BLAS) start one thread rather than one per core, unless the
    user chose (``OPENBLAS_NUM_THREADS``) or NumPy is imported already. A render's BLAS
    products are small (frames, 3×3 rotations; its images are the same bit for bit) and its
    work runs on the kernels' own threads, while OpenBLAS starting its threads is ~60 ms of
    NumPy's import on a two-core machine."""
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _scene(shape: str, mask: Path | None, resolution: int, model: Any, lights: list[Any]) -> Any:
    """The G-buffer of ``shape`` (:func:`_gbuffer`), traced and the maps' tables computed while
    the shading kernels load (or compile) on a thread of their own, which has ended when
    this returns."""
    kernels = _in_background(lambda: _build_kernels(model, lights))
    g = _gbuffer(shape, mask, resolution)
    _prepare_maps(model, lights)
    kernels()
    return g


def _in_background(work: Callable[[], None]) -> Callable[[], None]:
    """Start ``work`` on a thread of its own; returns the function that waits for it to end
    and raises what it raised. Loading or compiling kernels (Python and numba, holding the GIL
    most of the time) then overlaps the NumPy set-up of the G-buffer and the maps."""
    failure: list[BaseException] = []

    def run() -> None:
        try:
            work()
        except BaseException as error:  # handed to the waiting thread, raised there
            failure.append(error)

    thread = threading.Thread(target=run, name="brdfkit-kernels", daemon=True)
    thread.start()

    def wait() -> None:
        thread.join()
        if failure:
            raise failure[0]

    return wait


def _prepare_maps(model: Any, lights: list[Any]) -> None:
    """Compute the maps' irradiance tables the render will read (NumPy, while the kernels
    load on their thread), once per map."""
    from brdfkit.light import EnvironmentMap
    from brdfkit.render.compiled_shading import uses_irradiance

    if uses_irradiance(model):
        for light in lights:
            if isinstance(light, EnvironmentMap):
                light.irradiance_table  # noqa: B018 (a cached property, built here)


def _build_kernels(model: Any, lights: list[Any]) -> None:
    """Build the compiled shading kernels the render takes before it starts, saying so in one
    line on stderr where that compiles them (once per model structure and machine; a later
    process loads them from the disk cache silently)."""
    from brdfkit.render.compiled_shading import build_estimate, build_kernels, pending_kernels

    part = pending_kernels(model, lights)
    if part is None:
        return
    name = getattr(part, "spec_name", None) or str(part.to_spec()).partition("(")[0]
    status.print(f"compiling kernels for {name} (once, ~{build_estimate():.0f} s)")
    build_kernels(model, lights)


def _write(output: Path, image: Any, exposure: float, label: str) -> None:
    """Write ``image`` (grey becomes RGB) atomically and say so, naming the model ``label``."""
    import numpy as np

    from brdfkit.io import write_image

    if image.shape[-1] == 1:
        image = np.repeat(image, 3, axis=-1)
    # write_image is atomic: it never leaves a half-written file.
    write_image(
        output, image.astype(np.float32), exposure=exposure if output.suffix == ".png" else 0.0
    )
    height, width = image.shape[:2]
    console.print(f"wrote {shown(output)} ({width}×{height}, {label})")


def _gbuffer(shape: str, mask: Path | None, resolution: int) -> Any:
    """The G-buffer of a built-in shape at ``resolution``, or of the normal-map file ``shape``
    (``mask`` its mask image); refused before any work when it would not fit in memory."""
    from brdfkit._checks import check_memory
    from brdfkit.render.scene import Cylinder, Plane, Sphere, gbuffer, normal_map_gbuffer

    shapes = {"sphere": Sphere(), "plane": Plane(), "cylinder": Cylinder()}
    if shape in shapes:
        check_memory(
            f"rendering {resolution}×{resolution} pixels", _BYTES_PER_PIXEL * resolution**2
        )
        return gbuffer(shapes[shape], None, resolution)
    path = _shape_file(shape)
    if path is None:
        fail(f"shape must be one of {sorted(shapes)} or a normal-map file; got {shown(shape)!r}")
    from brdfkit.vision.datasets import read_mask, read_normal_map  # readers only: vision is heavy

    normals = read_normal_map(path)
    height, width = normals.shape[:2]
    check_memory(f"rendering {width}×{height} pixels", _BYTES_PER_PIXEL * width * height)
    m = None if mask is None else read_mask(mask)
    return normal_map_gbuffer(normals, m)


def _shape_file(shape: str) -> Path | None:
    """The normal-map file that ``shape`` names, or ``None`` for a built-in shape."""
    path = Path(shape)
    return path if path.is_file() else None


def _is_mesh(shape: str) -> bool:
    from brdfkit.render.bundled_meshes import is_mesh_source

    return is_mesh_source(shape)


@dataclass(frozen=True)
class _MeshCamera:
    """The mesh camera's options as given: ``look_at`` text, ``fov`` (degrees or ``None``),
    ``size`` ``(height, width)`` and the supersampling."""

    look_at: str | None
    fov: float | None
    size: tuple[int, int]
    supersample: int


def _image_size(size: str | None, resolution: int) -> tuple[int, int]:
    """``(height, width)`` from ``--size WIDTHxHEIGHT``, else ``--resolution`` squared."""
    if size is None:
        return resolution, resolution
    width, sep, height = size.lower().partition("x")
    if not (sep and width.isdigit() and height.isdigit()):
        fail(f"--size must be WIDTHxHEIGHT in pixels, e.g. 64x48; got {shown(size)!r}")
    if not (8 <= int(width) <= 8192 and 8 <= int(height) <= 8192):
        fail(f"--size must be 8 to 8192 pixels each way; got {shown(size)!r}")
    return int(height), int(width)


def _look_at(text: str | None, mesh: Any) -> tuple[Any, Any, Any]:
    """``(origin, target, up)`` from ``--look-at``, or the default view of ``mesh``."""
    import numpy as np

    if text is None:
        low, high = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
        centre = (low + high) / 2
        distance = 2 * float(np.linalg.norm(high - low))
        return centre + np.array([0.0, 0.0, distance]), centre, (0, 1, 0)
    parts = text.split(":")
    try:
        vectors = [[float(x) for x in part.split(",")] for part in parts]
    except ValueError:
        vectors = []
    if len(vectors) != 3 or any(len(v) != 3 or not np.all(np.isfinite(v)) for v in vectors):
        fail(
            "--look-at must be ORIGIN:TARGET:UP, three points of three finite numbers "
            f"(e.g. 0,2,3:0,0,0:0,1,0); got {shown(text)!r}"
        )
    return vectors[0], vectors[1], vectors[2]


def _render_mesh(path: Path, model: Any, lights: list[Any], camera: _MeshCamera, samples: int):
    """Read the mesh at ``path`` and render it with shadows, progress on stderr."""
    from brdfkit._checks import check_memory
    from brdfkit.errors import ParameterError
    from brdfkit.render.bundled_meshes import BUNDLED_PREFIX, load_mesh
    from brdfkit.render.mesh import render_mesh
    from brdfkit.render.mitsuba_frame import look_at_camera, mitsuba_oriented

    if not (str(path).startswith(BUNDLED_PREFIX) or path.is_file()):
        fail(f"SHAPE: no mesh file {shown(str(path))!r}")
    mesh = load_mesh(path)
    height, width = camera.size
    k = camera.supersample
    check_memory(f"rendering {width}×{height} pixels", _BYTES_PER_PIXEL * width * height * k * k)
    try:
        view = look_at_camera(*_look_at(camera.look_at, mesh), fov=camera.fov, size=camera.size)
    except ValueError as error:  # the camera's own checks: a zero view, up along it
        raise ParameterError(f"--look-at / --fov: {error}") from error
    lights = [mitsuba_oriented(light) for light in lights]
    with progress() as bar:
        task = bar.add_task(f"rendering {width}×{height}", total=height * k)
        return render_mesh(
            mesh, model, lights, view, (height, width), supersample=k, samples=samples,
            progress=lambda done, total: bar.update(task, completed=done),
        )  # fmt: skip
