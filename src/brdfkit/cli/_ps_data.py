"""Reading a photometric-stereo folder for a CLI command, its lights optionally re-calibrated
from a chrome-sphere folder (shared by ``brdfkit ps`` and ``brdfkit svbrdf``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from brdfkit.cli._app import fail

if TYPE_CHECKING:
    from brdfkit.vision.datasets import PhotometricStereoData


def load_with_lights(
    dataset: Path,
    chrome: Path | None,
    step: int,
    callback: Callable[[int, int], None],
) -> PhotometricStereoData:
    """The data set in ``dataset`` (every ``step``-th pixel), its light directions replaced by
    those calibrated from the chrome sphere in ``chrome`` when given; exits naming ``--chrome``
    when the two folders hold different numbers of lights."""
    from brdfkit.vision import datasets, photometric_stereo

    lights = None
    if chrome is not None:
        sphere = datasets.load_psm(chrome, step=step, callback=callback)
        lights = photometric_stereo.calibrate_lights_chrome_sphere(sphere.images, sphere.mask)
    data = datasets.load_dataset(dataset, step=step, callback=callback)
    if lights is None:
        return data
    if lights.shape != data.light_directions.shape:
        fail(f"--chrome gave {len(lights)} lights, {dataset} has {len(data.images)}")
    return datasets.PhotometricStereoData(
        data.images, lights, data.mask, data.normals, data.light_intensities, data.name
    )
