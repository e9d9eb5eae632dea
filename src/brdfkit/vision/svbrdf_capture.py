"""Shape and spatially varying BRDF captured from a photometric-stereo data set, relit under new
lights, and checked on held-out images against photometric stereo's Lambertian model.

:func:`capture_svbrdf` chains what ``brdfkit svbrdf`` does: the number of specular lobes (given,
or chosen by cross-validation, :func:`~brdfkit.vision.svbrdf.select_lobes`), the fit of
Goldman et al. (:func:`~brdfkit.vision.svbrdf.fit_svbrdf`) on the images not held out,
optionally the cast shadows of the fitted shape (:func:`~brdfkit.vision.svbrdf.shadow_visibility`,
its bias chosen on the fitted images by :func:`~brdfkit.vision.svbrdf.select_shadow_bias`), the
renders under new lights, and the RMS error of the renders of the held-out images next to that
of least-squares photometric stereo's Lambertian model under the same shadows.

References
----------
.. [1] D. B. Goldman, B. Curless, A. Hertzmann, S. M. Seitz, "Shape and spatially-varying BRDFs
   from photometric stereo", ICCV 2005 (and IEEE TPAMI 32(6), 2010).
.. [2] R. J. Woodham, "Photometric method for determining surface orientation from multiple
   images", Optical Engineering 19(1), 1980 (the Lambertian baseline).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from brdfkit.errors import FormatError, ParameterError
from brdfkit.vision import photometric_stereo, svbrdf
from brdfkit.vision.datasets import PhotometricStereoData

MIN_FITTED_IMAGES = 3
"""Fewest images left to the fit after the held-out ones."""


@dataclass(frozen=True)
class SVBRDFCapture:
    """Output of :func:`capture_svbrdf`.

    Attributes
    ----------
    name : the data set's name.
    lobes : the number of specular lobes.
    fit : the SVBRDF (normals, albedo, lobe weights and roughness).
    train : indices of the images fitted. held_out : indices of the images held out.
    lobe_scores : ``{K: cross-validated RMS}`` when the lobes were chosen, else ``None``.
    shadow_bias : the cast-shadow bias in pixels of depth (infinite: no cast shadows), or
        ``None`` without cast shadows.
    relit : ``(N, H, W, C)`` renders under the new lights, or ``None``.
    held_out_renders : ``(M, H, W, C)`` renders of the held-out images, or ``None``.
    relighting_rms : ``{"svbrdf": ..., "lambertian": ...}`` RMS errors of the renders of the
        held-out images over the mask, or ``None``.
    """

    name: str
    lobes: int
    fit: svbrdf.SVBRDFResult
    train: list[int]
    held_out: list[int]
    lobe_scores: dict[int, float] | None = None
    shadow_bias: float | None = None
    relit: np.ndarray | None = None
    held_out_renders: np.ndarray | None = None
    relighting_rms: dict[str, float] | None = None

    def summary(self) -> dict[str, Any]:
        """The capture as JSON-ready values (what ``brdfkit svbrdf --json`` prints)."""
        fit = self.fit
        summary: dict[str, Any] = {
            "dataset": self.name,
            "lobes": self.lobes,
            "alphas": [float(a) for a in fit.alphas],
            "basis": fit.basis_specs(),
            "fit_rms": fit.rms[-1] if fit.rms else None,
            "pixels": int(fit.mask.sum()),
        }
        if self.lobe_scores is not None:
            summary["cross_validated_rms"] = {str(k): v for k, v in self.lobe_scores.items()}
        if self.shadow_bias is not None:  # None in the JSON: no cast shadows
            summary["shadow_bias"] = self.shadow_bias if math.isfinite(self.shadow_bias) else None
        if self.relighting_rms is not None:
            summary["held_out"] = self.held_out
            summary["relighting_rms"] = self.relighting_rms
        return summary


def read_light_directions(path: str | os.PathLike) -> np.ndarray:
    """Light directions ``(N, 3)`` from a text file of rows ``x y z`` (not normalised).

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file: unreadable, not rows of three finite numbers, or a zero direction.
    """
    try:
        lights = np.loadtxt(path, ndmin=2, encoding="utf-8")
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise FormatError(path, f"not rows of 'x y z' numbers ({error})") from None
    if lights.shape[1] != 3 or not np.all(np.isfinite(lights)):
        raise FormatError(path, f"expected finite rows 'x y z'; got {lights.shape}")
    if np.any(np.linalg.norm(lights, axis=1) == 0):
        raise FormatError(path, "a light direction is zero")
    return lights


def _check_held_out(held_out: Sequence[int], count: int) -> list[int]:
    held = [int(k) for k in held_out]
    if len(set(held)) != len(held) or not all(0 <= k < count for k in held):
        raise ParameterError(f"hold_out must name distinct images in 0..{count - 1}; got {held}")
    if count - len(held) < MIN_FITTED_IMAGES:
        raise ParameterError(
            f"hold_out {held} leaves {count - len(held)} images; at least "
            f"{MIN_FITTED_IMAGES} are needed"
        )
    return held


def _held_out_errors(
    fit: svbrdf.SVBRDFResult,
    images: np.ndarray,
    lights: np.ndarray,
    train: list[int],
    held: list[int],
    shadows: np.ndarray | None,
) -> tuple[np.ndarray, dict[str, float]]:
    """The renders of the held-out images and the RMS errors of theirs and of the Lambertian
    model's (least squares on the fitted images) over the mask."""
    mask = fit.mask
    rendered = fit.relight(lights[held], visibility=shadows)
    ls = photometric_stereo.least_squares(images[train], lights[train], mask)
    lambert = svbrdf.lambertian_relight(
        ls.albedo, ls.normals, mask, lights[held], visibility=shadows
    )
    real = images[held][:, mask]
    return rendered, {
        "svbrdf": float(np.sqrt(np.mean((rendered[:, mask] - real) ** 2))),
        "lambertian": float(np.sqrt(np.mean((lambert[:, mask] - real) ** 2))),
    }


def capture_svbrdf(
    data: PhotometricStereoData,
    *,
    lobes: int | str = 1,
    hold_out: Sequence[int] = (),
    relight: ArrayLike | None = None,
    cast_shadows: bool = False,
    progress: Callable[[str], None] | None = None,
) -> SVBRDFCapture:
    """Normals, albedo and Ward specular lobes with per-pixel weights (Goldman et al. 2005),
    their renders under new lights, and the held-out relighting error.

    Parameters
    ----------
    data : the images, lights and mask (:func:`~brdfkit.vision.datasets.load_dataset`).
    lobes : specular basis lobes, 0 … :data:`~brdfkit.vision.svbrdf.MAX_LOBES`, or ``"auto"``
        (cross-validated over 0, 1 and 2 on the fitted images).
    hold_out : indices of images left out of the fit, rendered and compared.
    relight : ``(N, 3)`` directions of unit-irradiance lights to render under.
    cast_shadows : render with the cast shadows of the fitted shape (both models of the
        held-out comparison get the same shadows).
    progress : ``progress(stage)`` as each stage begins.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``lobes`` outside its range, ``hold_out`` naming an image twice or none of the data
        set's, or leaving fewer than :data:`MIN_FITTED_IMAGES` images; or what the fit raises.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.vision import datasets, photometric_stereo
    >>> normals, mask = photometric_stereo.sphere_normals((12, 12), (5.5, 5.5), 5.0)
    >>> lights = datasets.diligent_like_lights(3, 3, np.radians(20))
    >>> data = datasets.render_synthetic(normals, mask, lights, albedo=0.5)
    >>> capture = capture_svbrdf(data, lobes=0, hold_out=[4])
    >>> capture.train == [0, 1, 2, 3, 5, 6, 7, 8]
    True
    >>> capture.relighting_rms["svbrdf"] < 0.01
    True
    """
    report = progress if progress is not None else (lambda stage: None)
    images, lights = data.images.astype(np.float64), data.light_directions
    held = _check_held_out(hold_out, len(images))
    train = [k for k in range(len(images)) if k not in held]
    scores = None
    if lobes == "auto":
        report("choosing the lobes (cross-validation)")
        lobes, scores = svbrdf.select_lobes(images[train], lights[train], data.mask)
    elif not (isinstance(lobes, int) and 0 <= lobes <= svbrdf.MAX_LOBES):
        raise ParameterError(f"lobes must be 0 to {svbrdf.MAX_LOBES} or 'auto'; got {lobes!r}")
    report(f"fitting {lobes} lobe(s)")
    fit = svbrdf.fit_svbrdf(images[train], lights[train], data.mask, lobes=lobes)
    bias = None
    if cast_shadows:
        bias, _ = svbrdf.select_shadow_bias(fit, images[train], lights[train])

    def visibility(directions: np.ndarray) -> np.ndarray | None:
        """The cast shadows of the fitted shape under ``directions``, or ``None``."""
        if bias is None:
            return None
        return svbrdf.shadow_visibility(fit.normals, data.mask, directions, bias=bias)

    relit = None if relight is None else fit.relight(relight, visibility=visibility(relight))
    rendered, rms = None, None
    if held:
        rendered, rms = _held_out_errors(fit, images, lights, train, held, visibility(lights[held]))
    return SVBRDFCapture(data.name, lobes, fit, train, held, scores, bias, relit, rendered, rms)
