"""A measured BRDF fitted end to end: read, fitted by a model spec, by the data-driven
bivariate table or by the candidate of least held-out error, and compared with its fit on
rendered spheres.

:func:`fit_measured` chains what ``brdfkit fit`` does for one file: the reader of the file's
extension (:func:`brdfkit.measured.read`), then :func:`~brdfkit.fit.analytic.fit` for a spec,
:func:`~brdfkit.fit.select.fit_any` for ``"bivariate"`` or
:func:`~brdfkit.fit.select.select_model` for ``"auto"``, and optionally the CIEDE2000
differences of measured and fitted spheres under a directional light and the bundled
environment map (:func:`~brdfkit.fit.appearance.sphere_difference`).

References
----------
.. [1] A. Ngan, F. Durand, W. Matusik, "Experimental analysis of BRDF models", EGSR 2005.
.. [2] G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula: implementation
       notes, supplementary test data, and mathematical observations", Color Res. Appl. 30(1),
       2005.
"""

from __future__ import annotations

import os
from collections.abc import Collection
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.errors import ParameterError
from brdfkit.fit.analytic import FitResult, Progress, fit
from brdfkit.fit.appearance import SphereDifference, sphere_difference
from brdfkit.fit.select import BIVARIATE, Selection, fit_any, select_model

AUTO = "auto"
"""The model name that chooses among :data:`brdfkit.fit.select.CANDIDATES` by held-out error."""


@dataclass(frozen=True, eq=False)
class MeasuredFit:
    """Output of :func:`fit_measured`.

    Attributes
    ----------
    measured : the measured BRDF.
    result : the fit (its model, spec, parameters and errors).
    selection : with ``model="auto"``, every candidate's held-out error and the choice; else
        ``None``.
    spheres : the measured and fitted spheres compared, by light (``"directional"``, then
        ``"envmap"``); empty when no comparison was asked for.
    kinds : with ``model="auto"`` and both kinds among the candidates, the spheres of the best
        analytic fit (``"analytic"``) and of the data-driven table (``"data_driven"``) compared
        with the measurement's (directional light); ``result`` is the closer of the two.
    """

    measured: BRDF
    result: FitResult
    selection: Selection | None = None
    spheres: dict[str, SphereDifference] = field(default_factory=dict)
    kinds: dict[str, SphereDifference] = field(default_factory=dict)

    def record(self) -> dict[str, Any]:
        """The fit and the spheres' differences as JSON-ready values (``brdfkit fit``'s
        ``fit.json``); with ``"auto"``, the best analytic and the data-driven fit beside it."""
        record = self.result.to_dict()
        for light, difference in self.spheres.items():
            record[f"delta_e_{light}"] = difference.to_dict()
        record.update(self.kinds_record())
        return record

    def kinds_record(self) -> dict[str, Any]:
        """With ``"auto"`` and both kinds among the candidates: ``{"analytic": …,
        "data_driven": …}``, each its spec, held-out RMS residual and spheres' CIEDE2000
        (directional light) against the measurement; else empty."""
        selection = self.selection
        if selection is None or selection.analytic is None:
            return {}
        bivariate = next(spec for spec in selection.held_out if spec.strip() == BIVARIATE)
        out = {}
        for kind, result, candidate in (
            ("analytic", selection.analytic, selection.analytic_candidate),
            ("data_driven", selection.data_driven, bivariate),
        ):
            out[kind] = {
                "spec": result.spec,
                "candidate": candidate,
                "held_out_rms": selection.held_out[candidate],
                "errors": result.errors,
                "delta_e_directional": self.kinds[kind].to_dict(),
            }
        return out

    def spheres_image(self) -> np.ndarray:
        """The spheres side by side, measured | fitted, one row per light (linear, exposed
        alike, in [0, 1])."""
        rows = [np.concatenate([d.reference, d.other], axis=1) for d in self.spheres.values()]
        return np.concatenate(rows, axis=0)


def compare_spheres(
    measured: BRDF, fitted: BRDF, resolution: int, *, envmap: bool = False
) -> dict[str, SphereDifference]:
    """CIEDE2000 differences of spheres of ``resolution`` pixels rendered with ``measured`` and
    ``fitted``, under the default directional light and, with ``envmap``, under the bundled
    environment map (Monte Carlo)."""
    from brdfkit.data import default_envmap_path
    from brdfkit.light.environment import EnvironmentMap

    lights = {"directional": None}
    if envmap:
        lights["envmap"] = [EnvironmentMap.from_file(default_envmap_path())]
    return {
        name: sphere_difference(measured, fitted, light, resolution)
        for name, light in lights.items()
    }


def fit_measured(
    measured: BRDF | str | os.PathLike,
    model: str = "lambertian + cook_torrance",
    *,
    objective: str = "cube_root",
    loss: str = "soft_l1",
    loss_scale: float = 0.5,
    mode: str = "shared",
    starts: int = 4,
    fixed: Collection[str] = (),
    seed: int = 0,
    spheres: int | None = None,
    envmap: bool = False,
    progress: Progress | None = None,
) -> MeasuredFit:
    """Fit ``model`` to a measured BRDF and optionally compare the two on rendered spheres.

    Parameters
    ----------
    measured : a BRDF, or a MERL ``.binary``, RGL ``.bsdf`` or Cornell ``.brdf`` file.
    model : a model spec (its written parameters stay fixed), ``"bivariate"`` (the data-driven
        ``(θh, θd)`` table) or ``"auto"``: the candidates fitted to 80 % of the measurements
        and scored on the rest (:func:`~brdfkit.fit.select.select_model`); of the best analytic
        one and the data-driven table, refitted on all, the one whose sphere looks closer to the
        measurement's (CIEDE2000 under the directional light, what a user judges: on the four
        Cornell paints the table, though the held-out residual prefers the analytic fit on
        three).
    objective, loss, loss_scale, mode, starts, seed : as :func:`~brdfkit.fit.analytic.fit`
        (``"bivariate"`` takes only ``objective``).
    fixed : parameters to hold fixed (specs only).
    spheres : pixels across the spheres to compare (:func:`compare_spheres`); no comparison
        when ``None``.
    envmap : compare also under the bundled environment map.
    progress : ``progress(completed, total, description)`` as the fit advances.

    Returns
    -------
    MeasuredFit

    Raises
    ------
    brdfkit.errors.ParameterError
        ``fixed`` with ``"bivariate"`` or ``"auto"``, or what the fit raises.
    brdfkit.errors.FormatError
        A file the readers refuse.
    """
    from brdfkit import measured as readers

    if isinstance(measured, str | os.PathLike):
        measured = readers.read(measured)
    name = model.strip()
    if name in (AUTO, BIVARIATE) and fixed:
        raise ParameterError(f"fixed does not apply to model {name!r}; got {sorted(fixed)}")
    options: dict[str, Any] = {"objective": objective, "loss": loss, "loss_scale": loss_scale,
                               "mode": mode, "starts": starts, "seed": seed}  # fmt: skip
    if progress is not None:
        options["progress"] = progress
    selection = None
    if name == AUTO:
        selection = select_model(measured, **options)
        result = selection.result
    elif name == BIVARIATE:
        result = fit_any(measured, BIVARIATE, objective=objective)
    else:
        result = fit(measured, model, fixed=fixed, **options)
    kinds = {}
    if selection is not None and selection.analytic is not None:
        resolution = KINDS_RESOLUTION if spheres is None else spheres
        kinds = {
            kind: sphere_difference(measured, getattr(selection, kind).model, None, resolution)
            for kind in ("analytic", "data_driven")
        }
        result = getattr(selection, min(kinds, key=lambda kind: kinds[kind].mean))
    compared = {} if spheres is None else compare_spheres(measured, result.model, spheres,
                                                          envmap=envmap)  # fmt: skip
    return MeasuredFit(measured, result, selection, compared, kinds)


KINDS_RESOLUTION = 64
"""Pixels across the spheres that compare the best analytic and the data-driven fit with the
measurement under ``"auto"`` when no other resolution is asked for."""
