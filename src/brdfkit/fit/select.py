r"""Model selection by held-out error, and the data-driven bivariate fit, for ``brdfkit fit``.

:func:`select_model` fits every candidate (analytic specs, and ``"bivariate"``: the (θh, θd)
table of Romeiro et al. 2008, :func:`brdfkit.measured.bivariate_brdf.fit_bivariate`) to a random
80 % of the measurements, scores each by its RMS residual on the other 20 % (on the fit's
objective scale, all channels pooled), and refits the best on all of them.

References
----------
.. [1] T. Hastie, R. Tibshirani, J. Friedman, *The Elements of Statistical Learning*, 2nd ed.,
       §7.2 (model selection by held-out error), 2009.
.. [2] F. Romeiro, Y. Vasilyev, T. Zickler, "Passive reflectometry", ECCV 2008.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Collection
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.errors import ParameterError
from brdfkit.fit.analytic import OBJECTIVES, FitResult, fit, fit_data, fit_errors, residuals
from brdfkit.measured.bivariate_brdf import fit_bivariate
from brdfkit.measured.tabulated import MeasuredSamples

BIVARIATE = "bivariate"
"""The name of the data-driven candidate."""

CANDIDATES = (
    "lambertian + cook_torrance",
    "lambertian + ggx",
    "lambertian + ward",
    "lambertian + ashikhmin_shirley(rd=0)",
    BIVARIATE,
)
"""What ``--model auto`` chooses from."""

HOLDOUT = 0.2
"""The share of measurements held out to score the candidates."""


@dataclass(frozen=True, eq=False)
class Selection:
    """The outcome of :func:`select_model`: the chosen candidate, every candidate's held-out
    RMS residual, and the chosen candidate refitted on all measurements; where the candidates
    hold both kinds, also the best analytic one (``analytic``) and the data-driven table
    (``data_driven``), each refitted on all measurements (one of them is ``result``), and the
    best analytic candidate's name (``analytic_candidate``)."""

    chosen: str
    held_out: dict[str, float]
    result: FitResult
    analytic: FitResult | None = None
    data_driven: FitResult | None = None
    analytic_candidate: str | None = None


def _split(data: MeasuredSamples, rng: np.random.Generator) -> tuple[MeasuredSamples, ...]:
    held = rng.random(data.wi.shape[0]) < HOLDOUT

    def part(mask: np.ndarray) -> MeasuredSamples:
        return MeasuredSamples(data.wi[mask], data.wo[mask], data.values[mask], name=data.name)

    return part(~held), part(held)


def fit_any(measured: BRDF | MeasuredSamples, spec: str, **options: Any) -> FitResult:
    """:func:`brdfkit.fit.fit`, or the bivariate table when ``spec`` is ``"bivariate"`` (its
    result has no parameters; ``options`` other than ``objective`` do not apply to it).

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> result = fit_any(fit_data(Lambertian(rho=0.5), samples=2000), "bivariate")
    >>> result.spec, result.params, round(result.errors["relative_l2"], 6)
    ('bivariate (32 θh × 16 θd table)', {}, 0.0)
    """
    if spec.strip() != BIVARIATE:
        return fit(measured, spec, **options)
    start = time.perf_counter()
    data = fit_data(measured)
    model = fit_bivariate(data, smoothness=options.get("smoothness", 1e-3))
    nh, nd, _ = model.table.shape
    return FitResult(
        model=model,
        spec=f"{BIVARIATE} ({nh} θh × {nd} θd table)",
        params={},
        errors=fit_errors(model, data),
        objective=options.get("objective", "cube_root"),
        loss="linear",
        loss_scale=0.0,
        mode="per_channel",
        cost=0.0,
        starts=1,
        nfev=1,
        samples=data.wi.shape[0],
        fit_samples=data.wi.shape[0],
        success=True,
        message="weighted linear least squares with a second-difference prior",
        seconds=time.perf_counter() - start,
    )


def select_model(
    measured: BRDF | MeasuredSamples,
    candidates: tuple[str, ...] = CANDIDATES,
    *,
    objective: str = "cube_root",
    seed: int = 0,
    **options: Any,
) -> Selection:
    """Choose among ``candidates`` by held-out error (module docstring) and refit the best.

    ``options`` go to :func:`brdfkit.fit.fit` for the analytic candidates.

    Raises
    ------
    brdfkit.errors.ParameterError
        On an empty ``candidates`` or an unknown ``objective``.

    Examples
    --------
    A plastic (a diffuse base under a glossy lobe) is no Lambertian surface:

    >>> from brdfkit.brdf import parse
    >>> from brdfkit.measured import MeasuredSamples
    >>> from brdfkit.sampling import hemisphere_pairs
    >>> wi, wo = hemisphere_pairs(1000, seed=1)
    >>> plastic = parse("lambertian(rho=0.2) + ggx(alpha=0.3)")
    >>> data = MeasuredSamples(wi, wo, plastic.eval(wi, wo))
    >>> selection = select_model(data, ("lambertian", "lambertian + ggx"), starts=1)
    >>> selection.chosen, sorted(selection.held_out)
    ('lambertian + ggx', ['lambertian', 'lambertian + ggx'])
    >>> round(selection.result.params["1.ggx.alpha"], 6)
    0.3

    With the data-driven table among the candidates, the best of each kind comes back:

    >>> both = select_model(data, ("lambertian + ggx", "bivariate"), starts=1)
    >>> both.analytic.spec.startswith("lambertian"), both.data_driven.spec.startswith("bivariate")
    (True, True)
    """
    if not candidates:
        raise ParameterError("candidates must name at least one model")
    if objective not in OBJECTIVES:
        raise ParameterError(f"objective must be one of {OBJECTIVES}; got {objective!r}")
    data = fit_data(measured, seed=seed)
    train, test = _split(data, np.random.default_rng(seed))
    held_out = {}
    for spec in candidates:
        model = fit_any(train, spec, objective=objective, seed=seed, **options).model
        r = residuals(model, test, objective)
        held_out[spec] = float(np.sqrt(np.mean(r * r)))
    chosen = min(held_out, key=held_out.__getitem__)
    analytic = [spec for spec in held_out if spec.strip() != BIVARIATE]
    both = analytic and len(analytic) < len(held_out)  # both kinds: the best of each
    best = min(analytic, key=held_out.__getitem__) if both else None
    refits = {
        spec: dataclasses.replace(
            fit_any(data, spec, objective=objective, seed=seed, **options), objective=objective
        )
        for spec in ({chosen, best, _bivariate(held_out)} if both else {chosen})
    }
    if not both:
        return Selection(chosen, held_out, refits[chosen])
    data_driven = refits[_bivariate(held_out)]
    return Selection(chosen, held_out, refits[chosen], refits[best], data_driven, best)


def _bivariate(candidates: Collection[str]) -> str:
    """The data-driven candidate's name as ``candidates`` spell it."""
    return next(spec for spec in candidates if spec.strip() == BIVARIATE)


__all__ = ["BIVARIATE", "CANDIDATES", "HOLDOUT", "Selection", "fit_any", "select_model"]
