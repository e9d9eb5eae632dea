"""``brdfkit synth``: render photometric-stereo data sets (DiLiGenT layout) from shapes × BRDFs
× light sets, one Dask task per set."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import app, console, fail, progress, shown
from brdfkit.cli._output import OutputFolder

_Shapes = Annotated[
    list[str],
    typer.Option(
        "--shape",
        "-s",
        metavar="SHAPE",
        help="sphere[:PIXELS] or a normal map file (mask.png beside it); repeatable.",
    ),
]
_Brdfs = Annotated[
    list[str],
    typer.Option(
        "--brdf",
        "-b",
        metavar="SPEC|FILE",
        help="A model spec or a measured file (.binary, .bsdf, .brdf); repeatable.",
    ),
]
_LightSets = Annotated[
    list[str],
    typer.Option(
        "--lights",
        "-l",
        metavar="SET",
        help="diligent, grid:COLUMNSxROWS:DEGREES or a file of x y z rows; repeatable.",
    ),
]
_AllLit = Annotated[
    bool,
    typer.Option("--all-lit", help="Mask only the pixels every light reaches (no shadows)."),
]
_Output = Annotated[
    Path,
    typer.Option("--output", "-o", metavar="FOLDER", help="Output folder: one per set."),
]
_Workers = Annotated[
    int | None,
    typer.Option("--workers", metavar="N", min=1, help="Local Dask worker processes."),
]
_Scheduler = Annotated[
    str | None,
    typer.Option("--scheduler", metavar="ADDRESS", help="A Dask scheduler (tcp://host:8786)."),
]
_Json = Annotated[bool, typer.Option("--json", help="Print the sets written as JSON.")]


@app.command("synth")
def synth_command(
    shapes: _Shapes = ("sphere",),
    brdfs: _Brdfs = ("lambertian(rho=0.6)",),
    lights: _LightSets = ("diligent",),
    all_lit: _AllLit = False,
    output: _Output = Path("synth"),
    workers: _Workers = None,
    scheduler: _Scheduler = None,
    as_json: _Json = False,
) -> None:
    """Render photometric-stereo data sets: every shape × BRDF × light set, as Dask tasks.

    Each set is a folder in the DiLiGenT layout (001.png … 16-bit, filenames.txt,
    light_directions.txt, light_intensities.txt, mask.png, Normal_gt.mat) that brdfkit ps
    reads. Images are f_r E cos θ_i of an orthographic view, exposed so that the brightest pixel
    is 0.9; light_intensities.txt holds that exposure. Only attached shadows; noise-free.
    """
    from brdfkit.distributed import cluster, synth

    cluster.require_dask()
    tasks = [synth.SynthTask(s, b, ls, all_lit) for s in shapes for b in brdfs for ls in lights]
    tasks = list({t.folder: t for t in tasks}.values())
    inputs = [Path(p) for p in (*shapes, *brdfs, *lights) if Path(p).exists()]
    for task in tasks:
        synth.check(task)
    top = OutputFolder(output, ("sets.json",), inputs=inputs)
    names = {}
    for task in tasks:  # the file names depend on the light count, known from the spec
        count = len(synth.light_set(task.lights))
        names[task.folder] = [f"{k + 1:03d}.png" for k in range(count)]
    folders = {
        t.folder: OutputFolder(output / t.folder, (*names[t.folder], *_SET_FILES), inputs=inputs)
        for t in tasks
    }
    written = []
    with cluster.client(workers, scheduler) as dask_client, progress() as bar:
        job = bar.add_task("rendering", total=len(tasks))

        def save(task, data) -> None:
            _save(folders[task.folder], names[task.folder], data)
            written.append({"folder": task.folder, "shape": task.shape, "brdf": task.brdf,
                            "lights": task.lights, "images": len(data.images),
                            "pixels": int(data.mask.sum())})  # fmt: skip
            bar.update(job, advance=1, description=task.folder)

        synth.run(dask_client, tasks, save)
    written.sort(key=lambda r: r["folder"])
    text = json.dumps({"sets": written}, indent=1) + "\n"
    top.write("sets.json", lambda p: p.write_text(text, encoding="utf-8"))
    if as_json:
        typer.echo(json.dumps({"output": shown(output), "sets": written}, indent=2))
        return
    for record in written:
        console.print(f"{record['folder']}: {record['images']} images, {record['pixels']} pixels")
    console.print(f"wrote {len(written)} sets to {shown(output)}/")


_SET_FILES = ("filenames.txt", "light_directions.txt", "light_intensities.txt", "mask.png",
              "Normal_gt.mat")  # fmt: skip


def _save(folder: OutputFolder, names: list[str], data) -> None:
    """Write ``data`` in the DiLiGenT layout, each file atomically through ``folder``: the raw
    images (radiance times the exposure) as 16-bit PNGs, the exposure as the intensities."""
    import numpy as np
    import scipy.io

    from brdfkit.io import write_image

    if len(names) != len(data.images):
        fail(f"{folder.path}: rendered {len(data.images)} images, expected {len(names)}")
    intensities = data.light_intensities
    for name, image, scale in zip(names, data.images, intensities, strict=True):
        raw = image.astype(np.float64) * scale
        folder.write(name, lambda p, raw=raw: write_image(p, raw, bit_depth=16, srgb=False))
    rows = np.broadcast_to(intensities[:, :1] if intensities.shape[1] == 1 else intensities,
                           (len(names), 3))  # fmt: skip
    listing = "\n".join(names) + "\n"
    folder.write("filenames.txt", lambda p: p.write_text(listing, encoding="utf-8"))
    folder.write(
        "light_directions.txt", lambda p: np.savetxt(p, data.light_directions, fmt="%.10f")
    )
    folder.write("light_intensities.txt", lambda p: np.savetxt(p, rows, fmt="%.10g"))
    mask = data.mask.astype(np.float32)
    folder.write("mask.png", lambda p: write_image(p, mask, srgb=False))
    folder.write("Normal_gt.mat", lambda p: scipy.io.savemat(p, {"Normal_gt": data.normals}))
