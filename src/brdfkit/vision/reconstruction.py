"""Photometric stereo from a data set to a surface: normals and albedo, depth, a mesh, and the
errors against the ground truth where the data set holds one.

:func:`reconstruct` chains what ``brdfkit ps`` does: a calibrated method of :data:`SOLVERS`
under the data set's lights (or, with ``uncalibrated=True``, the lights estimated from the
images by :func:`~brdfkit.vision.uncalibrated.uncalibrated` and compared with the given ones),
an integrator of :data:`~brdfkit.vision.depth_from_normals.METHODS` (by default bilateral
normal integration, which keeps depth discontinuities; orthographic, or perspective through a
camera matrix), the mesh of the depth map
(:func:`~brdfkit.vision.depth_from_normals.depth_mesh`) and, when the data set has ground-truth
normals, the angular errors and the depth error against the depth integrated from those normals
(:mod:`~brdfkit.vision.metrics`).

Frame: x right, y up, z towards the camera (:mod:`brdfkit.vision`).

References
----------
.. [1] R. J. Woodham, "Photometric method for determining surface orientation from multiple
   images", Optical Engineering 19(1), 1980.
.. [2] B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A benchmark dataset and evaluation
   for non-Lambertian and uncalibrated photometric stereo", IEEE TPAMI 41(2), 2019 (the
   angular-error measures).
.. [3] Y. Quéau, J.-D. Durou, J.-F. Aujol, "Normal integration: a survey", J. Math. Imaging
   Vis. 60, 2018.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from brdfkit.errors import ParameterError
from brdfkit.vision import (
    bivariate_stereo,
    consensus,
    depth_from_normals,
    inverse_rendering_stereo,
    photometric_stereo,
)
from brdfkit.vision.datasets import PhotometricStereoData
from brdfkit.vision.depth_from_normals import depth_mesh
from brdfkit.vision.metrics import angular_error, angular_error_map, depth_error
from brdfkit.vision.photometric_stereo import PhotometricStereoResult

if TYPE_CHECKING:
    import trimesh

SOLVERS: dict[str, Callable[..., PhotometricStereoResult]] = {
    **photometric_stereo.METHODS,
    **bivariate_stereo.METHODS,
    **consensus.METHODS,
    **inverse_rendering_stereo.METHODS,
}
"""Every calibrated method by name: the Lambertian and robust ones, the bivariate
(non-Lambertian) ones, the consensus search and inverse rendering (the ``--method`` choices of
``brdfkit ps``)."""

_WITHOUT_PROGRESS = ("least_squares", "trimmed")
"""The closed-form methods, which take no progress callback."""

Progress = Callable[[str, int, int | None], None]
"""Progress callback ``progress(stage, done, total)``: the stage's name (the method, then
``integrating (INTEGRATOR)``), and the iterations done of ``total`` (``None``: not known)."""

DEFAULT_METHOD = "shared_bivariate"
"""The solver :func:`reconstruct` (and ``brdfkit ps``) uses unless told otherwise: shared
bivariate reflectance (AZ08, Alldrin et al. 2008), a non-Lambertian method about as fast as
sparse regression (1.3 s against 0.8 s on a 96-image, 612 × 512 stack). On the DiLiGenT-layout
renders of ``benchmarks/bench_ps_materials.py`` (three objects, nine materials, measured
paints among them) its mean error is 6.20° against sparse regression's 9.76°, lower on 7 of
the 9 materials (not on the acryl_blue and cayman paints), and also under the lights that
uncalibrated photometric stereo estimates (``benchmarks/bench_uncalibrated.py``, 7 of 9). On
the real psm gray sphere (12 8-bit photographs) it is 0.5° worse (6.62° against 6.10°,
``benchmarks/bench_vision_accuracy.py``)."""

DEFAULT_INTEGRATION = depth_from_normals.DEFAULT_METHOD
"""The integrator :func:`reconstruct` uses unless told otherwise, that of ``brdfkit
integrate`` (bilateral integration, which keeps depth steps, with piece scales). On normals
that photometric stereo estimated from renders of the seven DiLiGenT objects under three
materials its depth error is below least squares' in 33 of 42 runs, and 22-25 % lower on
average (``benchmarks/bench_ps_depth.py``). Where the normals are off by several degrees over
large areas (a measured paint) the weights may part what is smooth, and least squares can do
better (bear under the krylon paint: 2.17 mm against 1.27)."""


@dataclass(frozen=True)
class Reconstruction:
    """Output of :func:`reconstruct`.

    Attributes
    ----------
    data : the data set, its ``light_directions`` those the normals were solved with (the
        estimated ones with ``uncalibrated``).
    method, integration : the names of the solver and the integrator.
    result : normals ``(H, W, 3)``, albedo ``(H, W, C)`` and the mask.
    depth : ``(H, W)`` depth (orthographic: pixel units along -z; perspective: along the rays).
    mesh : the depth map as a triangle mesh
        (:func:`~brdfkit.vision.depth_from_normals.depth_mesh`).
    light_error : ``(N,)`` angles in degrees between the estimated and the given lights
        (``uncalibrated`` only), else ``None``.
    gbr_cue : the cue that resolved the GBR ambiguity (``uncalibrated`` only), else ``None``.
    angular_error : ``{"mean", "median"}`` of the angular error in degrees over the mask, when
        the data set has ground-truth normals, else ``None``.
    error_map : ``(H, W)`` angular error in degrees (NaN off the mask), with ground truth.
    depth_relative_rmse : RMSE of the depth against the depth integrated from the ground-truth
        normals, after the best scale and offset, over the range of the latter; with ground
        truth.
    """

    data: PhotometricStereoData
    method: str
    integration: str
    result: PhotometricStereoResult
    depth: np.ndarray
    mesh: trimesh.Trimesh
    light_error: np.ndarray | None = None
    gbr_cue: str | None = None
    angular_error: dict[str, float] | None = None
    error_map: np.ndarray | None = None
    depth_relative_rmse: float | None = None

    def measures(self) -> dict[str, Any]:
        """The run and its measures as JSON-ready numbers (what ``brdfkit ps`` writes to
        ``metrics.json``)."""
        summary: dict[str, Any] = {
            "dataset": self.data.name,
            "method": self.method,
            "integration": self.integration,
            "lights": len(self.data.images),
            "pixels": int(self.data.mask.sum()),
        }
        if self.light_error is not None:
            summary["gbr_cue"] = self.gbr_cue
            summary["light_error_deg"] = {
                "mean": float(self.light_error.mean()),
                "median": float(np.median(self.light_error)),
            }
        if self.angular_error is not None:
            summary["angular_error_deg"] = self.angular_error
            summary["depth_relative_rmse"] = self.depth_relative_rmse
        return summary


def _check_choices(method: str, integration: str, camera: np.ndarray | None) -> None:
    if method not in SOLVERS:
        raise ParameterError(f"method must be one of {', '.join(SOLVERS)}; got {method!r}")
    depth_from_normals.check_method(integration, camera, name="integration")


def _integrate(
    normals: np.ndarray,
    data: PhotometricStereoData,
    integration: str,
    camera: np.ndarray | None,
    callback: Callable[[int, int], None] | None,
) -> np.ndarray:
    """Depth of ``normals`` on ``data``'s mask by ``integration``."""
    surface = depth_from_normals.integrate_normal_map(
        depth_from_normals.NormalMap(normals, data.mask, camera, data.name),
        integration,
        callback=callback,
    )
    return surface.depth


def _solve(
    data: PhotometricStereoData,
    method: str,
    uncalibrated: bool,
    gbr_cue: str,
    sigma: float,
    progress: Progress,
) -> tuple[PhotometricStereoData, PhotometricStereoResult, np.ndarray | None, str | None]:
    """The normals and albedo; with ``uncalibrated``, the data set with the estimated lights,
    their angles in degrees to the given ones and the GBR cue used."""
    from brdfkit.vision.uncalibrated import uncalibrated as solve_uncalibrated

    progress(method, 0, None)
    extra = {}
    if method not in _WITHOUT_PROGRESS:
        extra["callback"] = lambda done, total: progress(method, done, total)
    if not uncalibrated:
        result = SOLVERS[method](data.images, data.light_directions, data.mask, **extra)
        return data, result, None, None
    estimate = solve_uncalibrated(data.images, data.mask, cue=gbr_cue, sigma=sigma)
    cosine = np.sum(estimate.light_directions * data.light_directions, axis=1)
    light_error = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    scaled = data.images / estimate.light_intensities.reshape(-1, 1, 1, 1)
    result = SOLVERS[method](scaled, estimate.light_directions, data.mask, **extra)
    data = replace(data, light_directions=estimate.light_directions)
    return data, result, light_error, estimate.cue


def reconstruct(
    data: PhotometricStereoData,
    *,
    method: str = DEFAULT_METHOD,
    integration: str = DEFAULT_INTEGRATION,
    camera: np.ndarray | None = None,
    uncalibrated: bool = False,
    gbr_cue: str = "auto",
    sigma: float = 1.0,
    progress: Progress | None = None,
) -> Reconstruction:
    """Normals, albedo, depth and mesh of a photometric-stereo data set, and their errors where
    it holds ground-truth normals.

    Parameters
    ----------
    data : the images, lights, mask and (optionally) ground-truth normals
        (:func:`~brdfkit.vision.datasets.load_dataset`).
    method : a calibrated method of :data:`SOLVERS`.
    integration : an integrator of :data:`brdfkit.vision.depth_from_normals.METHODS`.
    camera : ``(3, 3)`` intrinsics ``K`` for perspective integration
        (:func:`~brdfkit.vision.depth_from_normals.read_intrinsics`; an integrator of
        :data:`~brdfkit.vision.depth_from_normals.PERSPECTIVE_METHODS`); orthographic when
        ``None``.
    uncalibrated : estimate the lights from the images
        (:func:`~brdfkit.vision.uncalibrated.uncalibrated`, the ambiguity resolved by
        ``gbr_cue``), then solve with ``method`` under them; the data set's lights are only
        compared with the estimate.
    gbr_cue : a cue of :data:`brdfkit.vision.uncalibrated.CUES` (``"auto"``: the specular
        cue where the images show highlights, else entropy).
    sigma : smoothing in pixels of ``data`` before the integrability derivatives
        (``uncalibrated`` only).
    progress : ``progress(stage, done, total)`` as the work advances (:data:`Progress`).

    Returns
    -------
    Reconstruction

    Raises
    ------
    brdfkit.errors.ParameterError
        An unknown method or integrator, a camera with another integrator, or what the solver
        raises on the data.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.vision import datasets, photometric_stereo
    >>> normals, mask = photometric_stereo.sphere_normals((16, 16), (7.5, 7.5), 7.0)
    >>> lights = datasets.diligent_like_lights(3, 3, np.radians(20))
    >>> data = datasets.render_synthetic(normals, mask, lights, albedo=0.5)
    >>> surface = reconstruct(data, method="least_squares")
    >>> surface.angular_error["mean"] < 1.0
    True
    >>> surface.depth.shape, len(surface.mesh.vertices) == int(mask.sum())
    ((16, 16), True)
    """
    _check_choices(method, integration, camera)
    report = progress if progress is not None else (lambda stage, done, total: None)
    data, result, light_error, cue = _solve(data, method, uncalibrated, gbr_cue, sigma, report)
    stage = f"integrating ({integration})"
    report(stage, 0, None)
    depth = _integrate(result.normals, data, integration, camera, lambda d, t: report(stage, d, t))
    mesh = depth_mesh(depth, data.mask, camera)
    errors: dict[str, Any] = {}
    if data.normals is not None:
        truth_depth = _integrate(data.normals, data, integration, camera, None)
        errors = {
            "angular_error": angular_error(result.normals, data.normals, data.mask),
            "error_map": angular_error_map(result.normals, data.normals, data.mask),
            "depth_relative_rmse": float(
                depth_error(depth, truth_depth, data.mask)["relative_rmse"]
            ),
        }
    return Reconstruction(
        data, method, integration, result, depth, mesh, light_error,
        cue, **errors,
    )  # fmt: skip
